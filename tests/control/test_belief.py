"""The paper's prediction (issue 15 item 3) and belief beside truth in windows.csv (item 4).

- ``predictor = "paper"``: Eq 17 and Eqs 19–21 on the estimates (V̂_F, θ̂, ω_L held, ρ̂, β̂)
  at a candidate leader speed, checked against values computed by hand (below) and against
  finite differences of the two robots' motion; the adjustment's speed against Eq 24 solved
  by hand.
- ``f{i}_msb_{bound}_true`` against a recomputation from the poses recorded in windows.csv,
  and ``_true < w`` exactly where the window broke the bound.
- ``f{i}_msb_{bound}_pred`` is the decision's predictor at the highest leader speed.
- old names (``[adjust] model``, ``estimate``) are input errors naming the new ones.

Hand values (calculator, SPEC §4 conventions): ρ = 390 cm, β = 195°, θ = 10°, V̂_F = 30 cm/s,
ω_L = 0.1 rad/s, r_H = 25 cm, T_ρ = 0.01, T_ε = 0.025, T_β = 5°, ρ_d = 390 cm.
At V_L = 25: ρ̇ = 30 cos 205° − 25 cos 195° = −27.18923 + 24.14815 = −3.04109 cm/s,
β̇ = (25 sin 195° − 30 sin 205°)/390 − 0.1 = (−6.47048 + 12.67855)/390 − 0.1 = −0.0840819 rad/s,
so localization 25/3.04109 = 8.2207 s, separation 3.9/3.04109 = 1.28244 s, path diversion
9.75/30 = 0.325 s, bearing 0.0872665/0.0840819 = 1.03787 s.
At V_L = 15 (V̂_F, θ̂, ω_L held): ρ̇ = −27.18923 + 14.48889 = −12.70035, β̇ = −0.0774455:
localization 1.96845 s, separation 0.307078 s, path diversion 0.325 s, bearing 1.12681 s.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from rtsim.analysis.kinematics import BOUND_KINDS, Thresholds
from rtsim.config.scenario import load_scenario
from rtsim.control import adjust, decide
from rtsim.control.adjust import predicted_rows
from rtsim.control.predict import FollowerEstimate, check_predictor, predict_msbs, predictor
from rtsim.coupling import run_scenario
from rtsim.errors import InputError, ScenarioError

SCEN = Path(__file__).resolve().parents[2] / "experiments" / "scenarios"
TEST2 = SCEN / "test2.toml"
THR = Thresholds(r_H=25.0, T_rho=0.01, T_eps=0.025, T_beta=math.radians(5.0))
F = FollowerEstimate(
    rho=390.0, beta=math.radians(195), theta=math.radians(10), v_f=30.0, rho_d=390.0
)
HAND = {  # ms, by hand (module docstring)
    25.0: {
        "localization": 8220.74,
        "separation": 1282.44,
        "path_diversion": 325.0,
        "bearing": 1037.87,
    },
    15.0: {
        "localization": 1968.45,
        "separation": 307.078,
        "path_diversion": 325.0,
        "bearing": 1126.81,
    },
}


# -- the paper predictor ----------------------------------------------------------------
@pytest.mark.parametrize("v_l", [25.0, 15.0])
def test_paper_predictor_matches_hand_values(v_l: float) -> None:
    got = predict_msbs([F], v_l, predictor("paper", omega_l=0.1, kappa=0.0), THR)[0]
    for k in BOUND_KINDS:
        assert got[k] == pytest.approx(HAND[v_l][k], rel=2e-5), k
    rows = predicted_rows([F], v_l, thresholds=THR, predictor="paper", omega_l=0.1)
    assert rows[0] == tuple(got[k] for k in BOUND_KINDS)
    # what decide() reports at V_Ld is the same evaluation
    d = decide(
        "fixed-wsch", [F], v_ld=v_l, w_sch=200.0, thresholds=THR, omega_l=0.1, predictor="paper"
    )
    assert d.msbs[0] == got


def _relative(lead: tuple[float, float, float], fol: tuple[float, float]) -> tuple[float, float]:
    """(ρ, β) of a follower position in the leader's frame, from scratch."""
    dx, dy = fol[0] - lead[0], fol[1] - lead[1]
    c, s = math.cos(lead[2]), math.sin(lead[2])
    x, y = c * dx + s * dy, -s * dx + c * dy
    return math.hypot(x, y), math.atan2(y, x) % (2 * math.pi)


@pytest.mark.parametrize("v_l", [25.0, 15.0, 5.0])
@pytest.mark.parametrize(
    "beta_deg, theta_deg, omega", [(195, 10, 0.1), (160, -20, -0.05), (240, 35, 0.2)]
)
def test_paper_predictor_rates_agree_with_finite_differences(
    v_l: float, beta_deg: float, theta_deg: float, omega: float
) -> None:
    """Move the leader (V_L, ω_L) and the follower (V̂_F, heading θ_L − θ) for ±1 ms and
    difference ρ and β: the rates behind the predicted bounds (|ρ̇| = r_H / localization
    bound, |β̇| = T_β / bearing bound) are those of the motion, at every candidate speed."""
    rho, beta, theta, v_f = 300.0, math.radians(beta_deg), math.radians(theta_deg), 20.0
    f = FollowerEstimate(rho=rho, beta=beta, theta=theta, v_f=v_f, rho_d=300.0)
    got = predict_msbs([f], v_l, predictor("paper", omega_l=omega, kappa=0.0), THR)[0]
    h = 1e-3
    lead0 = (0.0, 0.0, 0.3)
    fol0 = (rho * math.cos(0.3 + beta), rho * math.sin(0.3 + beta))
    th_f = 0.3 - theta

    def at(t: float) -> tuple[float, float]:
        lead = (v_l * t * math.cos(0.3), v_l * t * math.sin(0.3), 0.3 + omega * t)
        # the leader turns at ω: to first order its position is the straight one
        if omega:
            r = v_l / omega
            lead = (
                r * (math.sin(0.3 + omega * t) - math.sin(0.3)),
                -r * (math.cos(0.3 + omega * t) - math.cos(0.3)),
                0.3 + omega * t,
            )
        fol = (fol0[0] + v_f * t * math.cos(th_f), fol0[1] + v_f * t * math.sin(th_f))
        return _relative(lead, fol)

    (r1, b1), (r2, b2) = at(-h), at(h)
    rho_dot = (r2 - r1) / (2 * h)
    beta_dot = math.remainder(b2 - b1, 2 * math.pi) / (2 * h)
    assert abs(_relative(lead0, fol0)[0] - rho) < 1e-9
    assert 1000 * THR.r_H / got["localization"] == pytest.approx(abs(rho_dot), rel=1e-5, abs=1e-6)
    assert 1000 * THR.T_beta / got["bearing"] == pytest.approx(abs(beta_dot), rel=1e-5, abs=1e-8)
    assert got["path_diversion"] == pytest.approx(1000 * THR.T_eps * 300.0 / v_f)


def test_paper_predictor_adjustment_solves_eq24_by_hand() -> None:
    """A follower trailing at β = 190°, θ = 5°, V̂_F = 10 cm/s, closing its gap: only the
    separation bound is below w_sch = 300 ms at V_Ld = 25 (ρ̇ = 10 cos 195° − 25 cos 190° =
    −9.65926 + 24.62019 = 14.96093 cm/s: 3.9 / 14.96093 = 260.68 ms). Eq 24 (with cos(β+θ),
    SPEC §5): V_L = (V_F cos(β+θ) − T_ρ ρ_d / w)/cos β = (−9.65926 − 13)/(−0.984808) =
    23.00881 cm/s, at which the bound is exactly w_sch."""
    f = FollowerEstimate(
        rho=390.0, beta=math.radians(190), theta=math.radians(5), v_f=10.0, rho_d=390.0
    )
    a = adjust([f], v_ld=25.0, w_sch=300.0, thresholds=THR, predictor="paper")
    assert a.msb_min == pytest.approx(260.68, rel=1e-4)
    assert a.binding == "separation:1"
    assert a.v_leader == pytest.approx(23.00881, rel=1e-6)
    assert a.method == "closed-form" and a.feasible
    assert a.msbs_after[0]["separation"] == pytest.approx(300.0, rel=1e-9)
    # the largest such speed: a little faster breaks the bound again
    above = predicted_rows([f], a.v_leader * (1 + 1e-6), thresholds=THR, predictor="paper")
    assert min(above[0]) < 300.0


def test_paper_predictor_numeric_fallback_when_closed_forms_are_off() -> None:
    """Without the closed forms the numeric search finds the same speed (SPEC §5 fallback)."""
    f = FollowerEstimate(
        rho=390.0, beta=math.radians(190), theta=math.radians(5), v_f=10.0, rho_d=390.0
    )
    a = adjust([f], v_ld=25.0, w_sch=300.0, thresholds=THR, predictor="paper", methods=("numeric",))
    assert a.method == "numeric"
    assert a.v_leader == pytest.approx(23.00881, rel=1e-6)


# -- old names --------------------------------------------------------------------------
def test_old_predictor_names_are_input_errors() -> None:
    with pytest.raises(InputError, match=r"'estimate' was renamed; did you mean 'paper'\?"):
        check_predictor("estimate")
    with pytest.raises(InputError, match=r"did you mean 'paper'\?"):
        check_predictor("papr")
    with pytest.raises(InputError, match=r"must be one of paper, formation, hybrid"):
        decide("adjust", [F], v_ld=25.0, w_sch=200.0, thresholds=THR, predictor="estimate")
    with pytest.raises(TypeError, match="model"):
        adjust([F], v_ld=25.0, w_sch=200.0, thresholds=THR, model="paper")  # type: ignore[call-arg]


@pytest.mark.parametrize(
    "snippet, message",
    [
        (
            'model = "formation"',
            r"^.*/t\.toml: adjust: unknown key 'model' \(renamed; did you mean "
            r"'predictor'\?\)$",
        ),
        (
            'predictor = "estimate"',
            r"^.*/t\.toml: adjust\.predictor: must be one of paper, formation, "
            r"hybrid, commands or 'package\.module:Name', got 'estimate' "
            r"\('estimate' was renamed; "
            r"did you mean 'paper'\?\)$",
        ),
        (
            'predictor = "hybird"',
            r"^.*/t\.toml: adjust\.predictor: .* \(did you mean 'hybrid'\?\)$",
        ),
    ],
)
def test_old_scenario_keys_are_errors_with_did_you_mean(
    tmp_path: Path, snippet: str, message: str
) -> None:
    text = TEST2.read_text(encoding="utf-8")
    text = "\n".join(line for line in text.splitlines() if not line.startswith("predictor"))
    path = tmp_path / "t.toml"
    path.write_text(text.replace("[adjust]\n", f"[adjust]\n{snippet}\n", 1), encoding="utf-8")
    with pytest.raises(ScenarioError, match=message):
        load_scenario(path)


def test_old_adjust_key_in_inputs_is_an_error() -> None:
    from rtsim.coupling import ScenarioInputs

    sc = load_scenario(TEST2)
    bad = ScenarioInputs(sc.world, sc.load_taskset(), adjust={"model": "paper"})
    with pytest.raises(
        InputError,
        match=r"unknown key 'model' \(renamed; did you mean "
        r"'predictor'\?\)",
    ):
        run_scenario(bad, duration_s=1)


# -- belief beside truth in windows.csv -------------------------------------------------
@pytest.fixture(scope="module", params=["paper", "formation"])
def run2(request, tmp_path_factory):  # type: ignore[no-untyped-def]
    """40 s of Test 2 in adjust mode (the first turn and its exit) with each predictor."""
    text = TEST2.read_text(encoding="utf-8")
    text = "\n".join(line for line in text.splitlines() if not line.startswith("predictor"))
    path = tmp_path_factory.mktemp("belief") / "t2.toml"
    path.write_text(
        text.replace("[adjust]\n", f'[adjust]\npredictor = "{request.param}"\n', 1),
        encoding="utf-8",
    )
    return run_scenario(path, policy="adjust", duration_s=40, record_jobs=False)


@pytest.fixture(scope="module", params=["paper", "formation"])
def run2_instant(request, tmp_path_factory):  # type: ignore[no-untyped-def]
    """The same 40 s with an instant leader (``accel_max = decel_max = inf``, the paper's
    speed step): the speed is piecewise constant and changes only at a decision."""
    text = TEST2.read_text(encoding="utf-8")
    text = "\n".join(line for line in text.splitlines() if not line.startswith("predictor"))
    path = tmp_path_factory.mktemp("belief_instant") / "t2.toml"
    path.write_text(
        text.replace("[adjust]\n", f'[adjust]\npredictor = "{request.param}"\n', 1),
        encoding="utf-8",
    )
    return run_scenario(
        path,
        policy="adjust",
        duration_s=40,
        record_jobs=False,
        overrides={"leader.accel_max": math.inf, "leader.decel_max": math.inf},
    )


def test_summary_records_predictor_and_formation_model(run2) -> None:  # type: ignore[no-untyped-def]
    s = run2.summary
    assert s["predictor"] in ("paper", "formation")
    assert s["formation_model"] == run2.inputs.world.formation.model


def test_no_old_bound_columns_left(run2) -> None:  # type: ignore[no-untyped-def]
    df = run2.windows
    for c in df.columns:
        if "_msb_" in c:
            assert c.endswith(("_pred", "_true")), c
    for i in (1, 2):
        for k in BOUND_KINDS:
            assert {f"f{i}_msb_{k}_pred", f"f{i}_msb_{k}_true"} <= set(df.columns)
    assert {"v_leader", "v_leader_target", "v_leader_max"} <= set(df.columns)


def test_true_bounds_recomputed_from_recorded_poses(run2) -> None:  # type: ignore[no-untyped-def]
    """Rows k and k+1 hold the truth at consecutive scans: the follower's position in the
    leader's frame (from leader_x/y/heading and f{i}_x/y), its ρ and β, give the changes
    over window k from scratch; the threshold·w / change is its `_true` column. The distance
    travelled is the odometer's: at least the straight-line chord and, over a quarter-second
    arc, close to it (a follower that nearly stops and turns at a turn's entry drives a
    curved path between two scans: there, within 20 %)."""
    df = run2.windows
    assert (np.diff(df["window"]) == 1).all()
    thr = run2.inputs.world.thresholds
    rho_d = list(run2.inputs.world.formation.rho_d)
    w = df["w"].to_numpy()[:-1]
    lx, ly, lh = (df[c].to_numpy() for c in ("leader_x", "leader_y", "leader_heading"))
    for i in (1, 2):
        dx, dy = df[f"f{i}_x"].to_numpy() - lx, df[f"f{i}_y"].to_numpy() - ly
        x = np.cos(lh) * dx + np.sin(lh) * dy
        y = -np.sin(lh) * dx + np.cos(lh) * dy
        rho, beta = np.hypot(x, y), np.arctan2(y, x)
        disp = np.hypot(np.diff(x), np.diff(y))
        d_rho = np.abs(np.diff(rho))
        d_beta = np.abs(np.angle(np.exp(1j * np.diff(beta))))
        chord = np.hypot(np.diff(df[f"f{i}_x"].to_numpy()), np.diff(df[f"f{i}_y"].to_numpy()))
        expect = {
            "localization": thr.r_H * w / disp,
            "separation": thr.T_rho * rho_d[i - 1] * w / d_rho,
            "bearing": thr.T_beta * w / d_beta,
        }
        for k, e in expect.items():
            got = df[f"f{i}_msb_{k}_true"].to_numpy()[:-1]
            np.testing.assert_allclose(got, e, rtol=1e-6, err_msg=f"f{i} {k}")
        path = df[f"f{i}_msb_path_diversion_true"].to_numpy()[:-1]
        by_chord = thr.T_eps * rho_d[i - 1] * w / chord
        assert (path <= by_chord * (1 + 1e-9)).all()
        assert (path >= by_chord * 0.8).all()
        assert np.median(path / by_chord) > 0.999


def test_true_below_w_exactly_when_the_window_broke_the_bound(run2) -> None:  # type: ignore[no-untyped-def]
    df = run2.windows
    w = df["w"].to_numpy()
    for i in (1, 2):
        for k in BOUND_KINDS:
            broke = df[f"f{i}_viol_{k}"].to_numpy(dtype=bool)
            assert np.array_equal(df[f"f{i}_msb_{k}_true"].to_numpy() < w, broke), (i, k)
    # and the summary's largest violation ratio is w / min _true
    s = run2.summary
    for k in BOUND_KINDS:
        ratio = max(float((w / df[f"f{i}_msb_{k}_true"]).max()) for i in (1, 2))
        assert ratio == pytest.approx(s["max_violation_ratio"][k], rel=1e-9)


def test_pred_with_ramps_lies_between_the_scans_speeds_and_v_ld(run2) -> None:  # type: ignore[no-untyped-def]
    """With leader dynamics (Test 2's ramps) the speed changes between decisions. v_leader_max
    is the highest speed between scans k and k+1; ``v_leader`` is the speed at the release
    t_k, which precedes scan k. So v_leader_max[k] >= v_leader[k+1] (release k+1 lies
    between the scans), v_leader_max[k] >= v_leader[k] less what the leader can shed between
    t_k and scan k (at most decel_max·response, the scan precedes the job's end; a speed
    that rose in that gap counts in full), and never above V_Ld. `_pred` is the decision's
    predictor at v_leader_max: at V_Ld its minimum is msb_min, and with the formation
    predictor (every bound ∝ 1/V_L) `_pred`·v_leader_max/V_Ld is msb_min."""
    df = run2.windows
    world = run2.inputs.world
    assert world.leader_accel_max < math.inf  # the ramps are on
    v, vmax = df["v_leader"].to_numpy(), df["v_leader_max"].to_numpy()
    v_ld = df["v_leader_desired"].to_numpy()
    assert (vmax <= v_ld * (1 + 1e-12)).all()
    assert (vmax[:-1] >= v[1:]).all()
    shed = world.leader_decel_max * df["response"].to_numpy() / 1000.0
    assert (vmax >= v - shed - 1e-9).all()
    assert (vmax >= v).mean() > 0.9  # ... and mostly the release's speed or more
    assert (df["v_leader_target"] != df["v_leader"]).any()  # the leader ramps to its target
    pred = np.column_stack([df[f"f{i}_msb_{k}_pred"] for i in (1, 2) for k in BOUND_KINDS])
    at_ld = vmax == v_ld
    np.testing.assert_array_equal(pred[at_ld].min(axis=1), df["msb_min"].to_numpy()[at_ld])
    assert (~at_ld).sum() > 5  # the leader was slowed in the turn
    if run2.summary["predictor"] == "formation":
        np.testing.assert_allclose(pred.min(axis=1) * vmax / v_ld, df["msb_min"], rtol=1e-9)


def test_pred_is_the_decision_at_the_leaders_highest_speed(run2_instant) -> None:  # type: ignore[no-untyped-def]
    """`_pred` is the decision's predictor on its estimates at v_leader_max. Without leader
    dynamics the speed is piecewise constant and changes only at a decision, so the highest
    speed between scans k and k+1 is max(V_L at t_k, V_L at t_{k+1}); with the formation
    predictor every bound ∝ 1/V_L, so `_pred`·v_leader_max is the same at every speed."""
    run2 = run2_instant
    assert run2.inputs.world.leader_accel_max == math.inf
    df = run2.windows
    v, vmax = df["v_leader"].to_numpy(), df["v_leader_max"].to_numpy()
    v_ld = df["v_leader_desired"].to_numpy()
    assert (vmax <= v_ld * (1 + 1e-12)).all()
    assert (vmax[:-1] >= v[1:]).all()
    # the no-ramp identity (with leader dynamics, vmax lies between the two)
    np.testing.assert_array_equal(vmax[:-1], np.maximum(v[:-1], v[1:]))
    assert (df["v_leader_target"] == df["v_leader"]).all()  # no ramp: the target at once
    # at V_Ld the prediction is what the decision saw: msb_min is its minimum
    at_ld = vmax == v_ld
    pred = np.column_stack([df[f"f{i}_msb_{k}_pred"] for i in (1, 2) for k in BOUND_KINDS])
    np.testing.assert_array_equal(pred[at_ld].min(axis=1), df["msb_min"].to_numpy()[at_ld])
    assert (~at_ld).sum() > 5  # the leader was slowed in the turn
    if run2.summary["predictor"] == "formation":
        # every bound ∝ 1/V_L: scaled back to V_Ld the prediction's minimum is msb_min
        np.testing.assert_allclose(pred.min(axis=1) * vmax / v_ld, df["msb_min"], rtol=1e-9)
    else:
        # Eqs 17, 19-21 on the recorded estimates at v_leader_max, with ω_L the leader's
        # turn rate when the decision was taken (at the end of the previous window: κ of
        # that window's or this window's segment, times the speed then)
        from rtsim.analysis.kinematics import follower_msbs

        thr = run2.inputs.world.thresholds
        rho_d = list(run2.inputs.world.formation.rho_d)
        kap = df["curvature"].to_numpy()
        for j in range(1, len(df)):
            row = df.iloc[j]
            for kappa in (kap[j], kap[j - 1]):
                ok = True
                for i in (1, 2):
                    m = follower_msbs(
                        vmax[j],
                        kappa * v[j - 1],
                        max(row[f"f{i}_v_est"], 0.0),
                        row[f"f{i}_rho_est"],
                        row[f"f{i}_beta_est"],
                        row[f"f{i}_theta_est"],
                        rho_d[i - 1],
                        thr,
                    )
                    ok &= all(
                        math.isclose(m[k], row[f"f{i}_msb_{k}_pred"], rel_tol=1e-9)
                        for k in BOUND_KINDS
                    )
                if ok:
                    break
            else:
                raise AssertionError(f"window {j}: _pred differs from Eqs 17-21 on the estimates")
    # in the critical windows where a speed restored the bounds (feasible) and the leader
    # drove at it all along, the decision's prediction holds w_sch there
    crit = (
        df["critical"].to_numpy(dtype=bool)
        & df["feasible"].to_numpy(dtype=bool)
        & (vmax == df["v_leader"].to_numpy())
    )
    if crit.any():
        assert (pred[crit].min(axis=1) >= df["w_sch"].to_numpy()[crit] * (1 - 1e-6)).all()


# -- the hybrid predictor's fast path (Test 1/2's predictor) -------------------------------
def test_hybrid_fast_path_is_bit_identical_to_the_predictor() -> None:
    """The per-window path of the ``hybrid`` model (constants once per decision) gives the
    same floats as the reference: :func:`predictor` + :func:`predict_msb_rows`."""
    from rtsim.control.adjust import _hybrid_consts, _hybrid_rows
    from rtsim.control.predict import predict_msb_rows

    rng = np.random.default_rng(5)
    for _ in range(200):
        kappa = float(rng.choice([0.0, 1 / 200, -1 / 120, float(rng.uniform(-0.01, 0.01))]))
        v_now = float(rng.uniform(0.0, 30.0))
        fols = [
            FollowerEstimate(
                rho=float(rng.uniform(100, 500)),
                beta=float(rng.uniform(0, 2 * math.pi)),
                theta=float(rng.uniform(-1, 1)),
                v_f=float(rng.choice([0.0, float(rng.uniform(0, 80))])),
                rho_d=float(rng.uniform(100, 500)),
                beta_d=float(rng.choice([math.radians(195), math.radians(165)])),
            )
            for _ in range(3)
        ]
        pre = _hybrid_consts(fols, THR, kappa, v_now)
        assert pre is not None
        ref = predictor("hybrid", omega_l=0.0, kappa=kappa, v_now=v_now)
        for v in (0.0, v_now, float(rng.uniform(0, 30)), 30.0):
            assert _hybrid_rows(pre, v, v_now, kappa) == predict_msb_rows(fols, v, ref, THR)
    # not applicable: full localization, or a non-float speed
    full = Thresholds(r_H=25.0, T_rho=0.01, T_eps=0.025, T_beta=0.1, localization="full")
    assert _hybrid_consts([F], full, 0.0, 10.0) is None
    assert _hybrid_consts([F], THR, 0.0, None) is None
    # and through adjust(): the same decision as with the reference predictor as a callable
    f2 = [
        FollowerEstimate(
            rho=330.0,
            beta=math.radians(190),
            theta=0.4,
            v_f=70.0,
            rho_d=325.0,
            beta_d=math.radians(195),
        )
    ]
    kw = dict(v_ld=30.0, w_sch=237.4, thresholds=THR, kappa=1 / 120, omega_l=0.25)
    fast = adjust(f2, predictor="hybrid", v_now=30.0, **kw)
    slow = adjust(f2, predictor=predictor("hybrid", omega_l=0.25, kappa=1 / 120, v_now=30.0), **kw)
    assert fast.critical and fast.v_leader == slow.v_leader and fast.msbs == slow.msbs
    assert fast.msbs_after == slow.msbs_after and fast.method == slow.method


def test_cli_names_the_file_and_the_renamed_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from rtsim.cli import main

    text = re.sub(
        r'^predictor = "\w+"',
        'model = "paper"',
        TEST2.read_text(encoding="utf-8"),
        count=1,
        flags=re.MULTILINE,
    )
    assert 'model = "paper"' in text
    path = tmp_path / "old.toml"
    path.write_text(text, encoding="utf-8")
    assert main(["scenario", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "old.toml: adjust: unknown key 'model' (renamed; did you mean 'predictor'?)" in err
    assert err.count("\n") == 1
