"""Tests of the adjustment algorithm (rtsim.control, SPEC §5) and its closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtsim.analysis.kinematics import (
    Thresholds,
    follower_msbs,
    formation_velocity,
    msb_separation,
    rho_dot,
)
from rtsim.control import (
    FollowerEstimate,
    adjust,
    coupled_speed,
    decide,
    paper_speed,
    predict_msbs,
    predictor,
)

DEG = math.pi / 180.0
W_SCH = 237.4
V_LD = 25.0
KINDS = ("localization", "separation", "path_diversion", "bearing")
UNIT = dict(r_H=1.0, T_rho=1.0, T_eps=1.0, T_beta=1.0)
FIELD = {
    "localization": "r_H",
    "separation": "T_rho",
    "path_diversion": "T_eps",
    "bearing": "T_beta",
}
BIG = dict(r_H=1e7, T_rho=1e5, T_eps=1e5, T_beta=1e5)


# ------------------------------------------------------------------ independent helpers


def _bounds_formation(f: FollowerEstimate, v: float, kappa: float, thr: Thresholds):
    """The four bounds of ``f`` with the formation model at leader speed v (written here)."""
    slot = (f.rho, f.beta) if f.beta_d is None else (f.rho_d, f.beta_d)
    v_f, theta = formation_velocity(v, kappa * v, *slot)
    return follower_msbs(v, kappa * v, v_f, f.rho, f.beta, theta, f.rho_d, thr)


def _min_formation(fs, v, kappa, thr) -> float:
    return min(min(_bounds_formation(f, v, kappa, thr).values()) for f in fs)


def _bisect_largest(ok, grid):
    """Hand-written root finder: the largest grid point passing ``ok``, refined by bisection."""
    prev = None
    for v in sorted(grid, reverse=True):
        if ok(v):
            if prev is None:
                return v
            lo, hi = v, prev
            for _ in range(200):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if ok(mid) else (lo, mid)
            return lo
        prev = v
    return None


def _thresholds_binding(kind: str, f: FollowerEstimate, kappa: float, ratio: float = 0.5, **kw):
    """Thresholds making ``kind`` the only small bound of ``f``: ratio·w_sch at V_Ld."""
    unit = _bounds_formation(f, V_LD, kappa, Thresholds(**UNIT, **kw))[kind]
    assert math.isfinite(unit) and unit > 0
    values = dict(BIG)
    values[FIELD[kind]] = ratio * W_SCH / unit
    return Thresholds(**values, **kw)


def _check_restored_and_largest(a, fs, kappa, thr):
    """The bound holds at w_sch at the returned speed, and fails 0.1 % above it."""
    assert a.feasible
    assert a.w == W_SCH and a.slack == 0.0
    assert 0.0 < a.v_leader <= V_LD
    assert _min_formation(fs, a.v_leader, kappa, thr) >= W_SCH - 1e-6
    above = a.v_leader * (1 + 1e-3)
    if above <= V_LD:
        assert _min_formation(fs, above, kappa, thr) < W_SCH


# ------------------------------------------------------------------ each kind, both sides, turns


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("beta_deg", [165.0, 195.0])
@pytest.mark.parametrize("kappa", [1 / 200, -1 / 200, 1 / 120])
def test_bound_restored_for_each_kind_side_and_turn(kind, beta_deg, kappa):
    beta = beta_deg * DEG
    # displaced from its slot (ρ_d = 390, β_d = β ± 10°), so ρ̇, β̇ ≠ 0 in the formation model
    f = FollowerEstimate(
        rho=370.0,
        beta=beta,
        theta=0.05,
        v_f=30.0,
        rho_d=390.0,
        beta_d=beta + (10 if beta_deg < 180 else -10) * DEG,
    )
    other_beta = (360 - beta_deg) * DEG  # the other side, on its slot
    other = FollowerEstimate(
        rho=390.0, beta=other_beta, theta=0.0, v_f=30.0, rho_d=390.0, beta_d=other_beta
    )
    fs = [other, f] if beta_deg > 180 else [f, other]
    thr = _thresholds_binding(kind, f, kappa)
    a = adjust(fs, v_ld=V_LD, w_sch=W_SCH, thresholds=thr, omega_l=kappa * V_LD, kappa=kappa)
    per = [min(_bounds_formation(g, V_LD, kappa, thr).values()) for g in fs]
    m = min(per)  # ≤ 0.5·w_sch; for path diversion the other follower can be lower still
    assert a.binding_kind == kind and a.binding_follower == per.index(m) + 1
    if kind != "path_diversion":
        assert a.binding_follower == fs.index(f) + 1
    assert a.critical and a.msb_min == pytest.approx(m, rel=1e-9) and m <= 0.5 * W_SCH * 1.000001
    assert a.margin == pytest.approx(m - W_SCH, rel=1e-9)
    assert a.method in ("closed-form", "coupled")
    _check_restored_and_largest(a, fs, kappa, thr)
    # every bound ∝ 1/V_L in the formation model: V_L = V_Ld · m / w_sch
    assert a.v_leader == pytest.approx(V_LD * m / W_SCH, rel=1e-9)


def test_full_localization_bound_restored():
    kappa = 1 / 150
    f = FollowerEstimate(
        rho=360.0, beta=170 * DEG, theta=0.0, v_f=30.0, rho_d=390.0, beta_d=160 * DEG
    )
    thr = _thresholds_binding("localization", f, kappa, ratio=0.3, localization="full")
    a = adjust([f], v_ld=V_LD, w_sch=W_SCH, thresholds=thr, kappa=kappa)
    assert a.binding_kind == "localization"
    _check_restored_and_largest(a, [f], kappa, thr)


def test_two_followers_different_kinds_the_stricter_wins():
    kappa = 1 / 200
    f1 = FollowerEstimate(380.0, 160 * DEG, 0.0, 30.0, 390.0, 165 * DEG)
    f2 = FollowerEstimate(390.0, 195 * DEG, 0.0, 60.0, 390.0, 195 * DEG)  # on its slot
    unit_sep = _bounds_formation(f1, V_LD, kappa, Thresholds(**UNIT))["separation"]
    unit_pd = _bounds_formation(f2, V_LD, kappa, Thresholds(**UNIT))["path_diversion"]
    # separation of f1 at 0.7·w_sch, path diversion of f2 at 0.6·w_sch (and of f1 above it)
    thr = Thresholds(r_H=1e7, T_rho=0.7 * W_SCH / unit_sep, T_eps=0.6 * W_SCH / unit_pd, T_beta=1e5)
    a = adjust([f1, f2], v_ld=V_LD, w_sch=W_SCH, thresholds=thr, kappa=kappa)
    assert a.binding == "path_diversion:2"
    _check_restored_and_largest(a, [f1, f2], kappa, thr)
    assert a.v_leader == pytest.approx(0.6 * V_LD, rel=1e-9)


@pytest.mark.parametrize(
    "beta_deg, slot_deg",
    [
        (90.0 + 1e-6, 100.0),  # cos β ≈ 0
        (270.0 - 1e-6, 260.0),  # cos β ≈ 0
        (180.0 + 1e-9, 195.0),  # sin β ≈ 0
        (180.0, 165.0),  # sin β = 0 (exactly, in floating point up to π's rounding)
    ],
)
@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("kappa", [1 / 200, -1 / 200])
def test_near_singular_bearings(beta_deg, slot_deg, kind, kappa):
    f = FollowerEstimate(390.0, beta_deg * DEG, 0.0, 30.0, 390.0, slot_deg * DEG)
    thr = _thresholds_binding(kind, f, kappa, ratio=0.4)
    a = adjust([f], v_ld=V_LD, w_sch=W_SCH, thresholds=thr, omega_l=kappa * V_LD, kappa=kappa)
    assert a.binding_kind == kind
    assert all(math.isfinite(v) or math.isnan(v) for v in a.candidates.values())
    _check_restored_and_largest(a, [f], kappa, thr)


# ------------------------------------------------------------------ the closed forms themselves


def _held_bound(kind, v, f, omega_l, thr):
    """The paper's view: V_F, θ, ω_L held at the estimates."""
    return follower_msbs(v, omega_l, f.v_f, f.rho, f.beta, f.theta, f.rho_d, thr)[kind]


@pytest.mark.parametrize("kind", ["separation", "localization", "bearing", "full"])
def test_paper_closed_forms_match_a_root_finder(kind):
    rng = np.random.default_rng(7)
    loc = "full" if kind == "full" else "radial"
    kind = "localization" if kind == "full" else kind
    thr = Thresholds(r_H=25.0, T_rho=0.02, T_eps=0.025, T_beta=0.05, localization=loc)
    grid = np.linspace(-3000.0, 3000.0, 1201)
    checked = 0
    for _ in range(30):
        f = FollowerEstimate(
            rng.uniform(150, 450),
            rng.uniform(95, 265) * DEG,
            rng.uniform(-1, 1),
            rng.uniform(0, 60),
            390.0,
        )
        omega_l = rng.uniform(-0.2, 0.2)
        w = rng.uniform(100, 400)
        got = paper_speed(
            kind,
            rho=f.rho,
            beta=f.beta,
            theta=f.theta,
            v_f=f.v_f,
            omega_l=omega_l,
            rho_d=f.rho_d,
            thr=thr,
            w=w,
        )
        want = _bisect_largest(
            lambda v, f=f, om=omega_l, w=w: _held_bound(kind, v, f, om, thr) >= w, grid
        )
        if want is None:  # the feasible interval, if any, fell between grid points
            assert got is None or _held_bound(kind, got, f, omega_l, thr) == pytest.approx(w)
            continue
        checked += 1
        assert got == pytest.approx(want, rel=1e-7, abs=1e-7)
        assert _held_bound(kind, got, f, omega_l, thr) == pytest.approx(w, rel=1e-7)
    assert checked >= 20


def test_paper_eq26_assumes_follower_at_leader_speed():
    thr = Thresholds(r_H=25.0, T_rho=0.01, T_eps=0.025, T_beta=0.1)
    v = paper_speed(
        "path_diversion",
        rho=390,
        beta=math.pi,
        theta=0,
        v_f=0,
        omega_l=0,
        rho_d=390.0,
        thr=thr,
        w=W_SCH,
    )
    assert v == pytest.approx(0.025 * 390.0 / 0.2374)  # 41.07 cm/s, above V_Ld = 25


def test_paper_closed_form_with_cos_beta_zero():
    thr = Thresholds(r_H=25.0, T_rho=0.01, T_eps=0.025, T_beta=0.1)
    kw = dict(rho=390.0, beta=math.pi / 2, omega_l=0.0, rho_d=390.0, thr=thr, w=W_SCH)
    # ρ̇ = V_F cos(β+θ) whatever V_L; θ = −π/2 → cos(0) = 1
    small = paper_speed("separation", theta=-math.pi / 2, v_f=1.0, **kw)
    assert small == math.inf  # |ρ̇| = 1 ≤ 3.9/0.2374 (cos(π/2) = 6e-17 counts as zero)
    assert paper_speed("separation", theta=-math.pi / 2, v_f=40.0, **kw) is None


def test_eq23_printed_is_the_smaller_root_when_sin_beta_negative():
    thr = Thresholds(r_H=25.0, T_rho=0.01, T_eps=0.025, T_beta=0.1)
    rho, beta, theta, v_f, om = 390.0, 200 * DEG, 0.1, 40.0, 0.1
    printed = (rho * (thr.T_beta / 0.2374 + om) + v_f * math.sin(beta + theta)) / math.sin(beta)
    got = paper_speed(
        "bearing",
        rho=rho,
        beta=beta,
        theta=theta,
        v_f=v_f,
        omega_l=om,
        rho_d=390.0,
        thr=thr,
        w=W_SCH,
    )
    f = FollowerEstimate(rho, beta, theta, v_f, 390.0)
    assert _held_bound("bearing", printed, f, om, thr) == pytest.approx(W_SCH)  # a root ...
    assert got > printed  # ... but not the larger one
    assert _held_bound("bearing", got, f, om, thr) == pytest.approx(W_SCH)
    assert _held_bound("bearing", 0.5 * (got + printed), f, om, thr) > W_SCH


def test_printed_sin_eq24_does_not_satisfy_the_bound():
    rng = np.random.default_rng(24)
    t_rho, rho_d, ws = 0.01, 390.0, W_SCH / 1000
    for _ in range(25):
        beta = rng.uniform(100, 260) * DEG
        theta, v_f = rng.uniform(-1, 1), rng.uniform(10, 60)
        fixed = (v_f * math.cos(beta + theta) - t_rho * rho_d / ws) / math.cos(beta)
        printed = (v_f * math.sin(beta + theta) - t_rho * rho_d / ws) / math.cos(beta)
        at_fixed = msb_separation(rho_dot(fixed, v_f, beta, theta), t_rho, rho_d)
        at_printed = msb_separation(rho_dot(printed, v_f, beta, theta), t_rho, rho_d)
        assert at_fixed == pytest.approx(W_SCH, rel=1e-9)
        assert abs(at_printed - W_SCH) > 1e-3 * W_SCH


@pytest.mark.parametrize("kind", KINDS + ("full",))
def test_coupled_closed_forms_match_a_root_finder(kind):
    rng = np.random.default_rng(99)
    loc = "full" if kind == "full" else "radial"
    kind = "localization" if kind == "full" else kind
    thr = Thresholds(r_H=25.0, T_rho=0.02, T_eps=0.025, T_beta=0.05, localization=loc)
    for _ in range(20):
        kappa = rng.uniform(-1 / 100, 1 / 100)
        f = FollowerEstimate(
            rng.uniform(150, 450),
            rng.uniform(95, 265) * DEG,
            0.0,
            0.0,
            390.0,
            rng.uniform(95, 265) * DEG,
        )
        s, theta_f = formation_velocity(1.0, kappa, *f.slot)
        got = coupled_speed(
            kind,
            rho=f.rho,
            beta=f.beta,
            s=s,
            theta_f=theta_f,
            kappa=kappa,
            rho_d=f.rho_d,
            thr=thr,
            w=W_SCH,
        )
        want = _bisect_largest(
            lambda v, f=f, k=kappa: _bounds_formation(f, v, k, thr)[kind] >= W_SCH,
            np.geomspace(1e-3, 1e6, 400),
        )
        assert got == pytest.approx(want, rel=1e-9)


# ------------------------------------------------------------------ no overload, caps, floors


def test_no_overload_keeps_desired_speed_and_takes_min_msb():
    kappa = 1 / 200
    f = FollowerEstimate(390.0, 165 * DEG, 0.0, 25.0, 390.0, 165 * DEG)
    thr = Thresholds(r_H=25.0, T_rho=0.01, T_eps=0.025, T_beta=0.1)
    a = adjust([f], v_ld=V_LD, w_sch=200.0, thresholds=thr, kappa=kappa)
    m = _min_formation([f], V_LD, kappa, thr)
    s = formation_velocity(1.0, kappa, 390.0, 165 * DEG)[0]
    assert m == pytest.approx(1000 * 0.025 * 390 / (s * V_LD))  # on its slot: path diversion
    assert a.method == "none" and a.feasible and not a.critical
    assert a.v_leader == V_LD and a.w == pytest.approx(m) and a.msb_min == pytest.approx(m)
    assert a.slack == pytest.approx(m - 200.0) and a.margin == pytest.approx(m - 200.0)
    assert a.binding == "path_diversion:1"


def test_large_and_infinite_bounds_are_capped():
    f = FollowerEstimate(390.0, 165 * DEG, 0.0, 25.0, 390.0, 165 * DEG)
    thr = Thresholds(r_H=25.0, T_rho=0.01, T_eps=10.0, T_beta=0.1)
    a = adjust([f], v_ld=V_LD, w_sch=W_SCH, thresholds=thr)  # straight: 156 s bound
    assert a.w == pytest.approx(10 * W_SCH) and a.slack == pytest.approx(9 * W_SCH)
    a = adjust([f], v_ld=V_LD, w_sch=W_SCH, thresholds=thr, cap=500.0)
    assert a.w == 500.0
    still = adjust([f], v_ld=0.0, w_sch=W_SCH, thresholds=thr, cap=700.0)
    assert still.msb_min == math.inf and still.w == 700.0 and still.binding == "none"


def test_infeasible_reports_and_slows_to_floor():
    # Paper's view (V_F held): ρ̇ = V_F cos(180°) − V_L cos(180°) = V_L − 60, and
    # |ρ̇| ≤ T_ρ ρ_d / w_sch = 3.9/0.2374 = 16.4 needs V_L ≥ 43.6 > V_Ld.
    f = FollowerEstimate(390.0, math.pi, 0.0, 60.0, 390.0)
    thr = Thresholds(r_H=1e4, T_rho=0.01, T_eps=1e3, T_beta=1e3)
    a = adjust([f], v_ld=V_LD, w_sch=W_SCH, thresholds=thr, predictor="paper")
    assert a.binding_kind == "separation"
    assert not a.feasible and a.method == "floor"
    assert a.v_leader == pytest.approx(0.05 * V_LD) and a.w == W_SCH and a.slack == 0.0
    b = adjust([f], v_ld=V_LD, w_sch=W_SCH, thresholds=thr, predictor="paper", floor_frac=0.2)
    assert b.v_leader == pytest.approx(5.0)
    # the hand-computed lower end: only V_L ≥ 43.57 works, beyond V_Ld
    assert 60 - 3.9 / 0.2374 > V_LD


def test_paper_predictor_paper_form_is_exact():
    # V_F held at 10, β = 180°: |V_L − 10| ≤ 16.43 → largest V_L = 26.43 capped ... use tighter:
    f = FollowerEstimate(390.0, math.pi, 0.0, 10.0, 390.0)
    thr = Thresholds(r_H=1e4, T_rho=0.002, T_eps=1e3, T_beta=1e3)
    a = adjust([f], v_ld=V_LD, w_sch=W_SCH, thresholds=thr, predictor="paper")
    assert a.method == "closed-form" and a.feasible
    assert a.v_leader == pytest.approx(10.0 + 0.78 / 0.2374, rel=1e-9)


def test_straight_path_diversion_eq26_and_coupled_tie():
    f = FollowerEstimate(390.0, 165 * DEG, 0.0, V_LD, 390.0, 165 * DEG)
    thr = Thresholds(r_H=25.0, T_rho=0.01, T_eps=0.01, T_beta=0.1)
    a = adjust([f], v_ld=V_LD, w_sch=W_SCH, thresholds=thr)
    assert a.method == "closed-form"  # Eq 26 exact when V_F = V_L (κ = 0)
    assert a.v_leader == pytest.approx(0.01 * 390 / 0.2374, rel=1e-12)
    assert a.candidates["coupled"] == pytest.approx(a.candidates["closed-form"], rel=1e-12)
    turning = adjust([f], v_ld=V_LD, w_sch=W_SCH, thresholds=thr, kappa=-1 / 200)
    assert turning.method == "coupled"  # Eq 26 ignores V_F = s·V_L > V_L


def test_numeric_fallback_for_a_non_homogeneous_model():
    # V_F = V_L + 8 cm/s (a feedback term that does not scale): Eq 26 and the coupled form
    # both miss; the bound 1000·T_ε ρ_d/(V_L + 8) = w_sch gives V_L = T_ε ρ_d/w − 8 by hand.
    thr = Thresholds(r_H=1e4, T_rho=1e3, T_eps=0.01, T_beta=1e3)
    f = FollowerEstimate(390.0, math.pi, 0.0, 33.0, 390.0)

    def model(fe, v):
        return v + 8.0, 0.0, 0.0

    a = adjust([f], v_ld=V_LD, w_sch=W_SCH, thresholds=thr, predictor=model)
    assert a.method == "numeric" and a.feasible
    assert a.v_leader == pytest.approx(3.9 / 0.2374 - 8.0, rel=1e-8)


def test_numeric_scan_finds_a_feasible_interval_away_from_zero():
    # V_F = |2 V_L − 30|: path diversion holds for |2V − 30| ≤ 3.9/0.2374 = 16.43, i.e.
    # V ∈ [6.79, 23.21]; the largest is 23.21 by hand, and low speeds fail.
    thr = Thresholds(r_H=1e4, T_rho=1e3, T_eps=0.01, T_beta=1e3)
    f = FollowerEstimate(390.0, math.pi, 0.0, 20.0, 390.0)
    a = adjust(
        [f],
        v_ld=V_LD,
        w_sch=W_SCH,
        thresholds=thr,
        predictor=lambda fe, v: (abs(2 * v - 30.0), 0.0, 0.0),
    )
    assert a.method == "numeric"
    assert a.v_leader == pytest.approx((30 + 3.9 / 0.2374) / 2, rel=1e-8)


# ------------------------------------------------------------------ modes and validation


def test_modes():
    kappa = 1 / 120
    f = FollowerEstimate(325.0, 195 * DEG, 0.0, 30.0, 325.0, 195 * DEG)
    thr = Thresholds(r_H=25.0, T_rho=0.01, T_eps=0.025, T_beta=0.1)
    m = _min_formation([f], 30.0, kappa, thr)
    assert m < W_SCH
    fixed = decide("fixed-wsch", [f], v_ld=30.0, w_sch=W_SCH, thresholds=thr, kappa=kappa)
    assert fixed.w == W_SCH and fixed.v_leader == 30.0 and not fixed.feasible
    assert fixed.slack == 0.0 and fixed.margin == pytest.approx(m - W_SCH)
    low = decide("min-msb", [f], v_ld=30.0, w_sch=W_SCH, thresholds=thr, kappa=kappa)
    assert low.w == pytest.approx(m) and low.v_leader == 30.0 and low.method == "none"
    tiny = decide(
        "min-msb",
        [f],
        v_ld=30.0,
        w_sch=W_SCH,
        kappa=kappa,
        thresholds=Thresholds(25.0, 0.01, 1e-6, 0.1),
    )
    assert tiny.msb_min < 1.0 and tiny.w == 1.0
    adj = decide("adjust", [f], v_ld=30.0, w_sch=W_SCH, thresholds=thr, kappa=kappa)
    assert adj.w == W_SCH and adj.v_leader < 30.0 and adj.feasible


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(rho=0.0), "rho"),
        (dict(rho_d=-1.0), "rho_d"),
        (dict(v_f=math.nan), "v_f"),
        (dict(v_f=-1.0), "v_f"),
        (dict(beta_d=math.inf), "beta_d"),
    ],
)
def test_follower_estimate_validated(kwargs, match):
    base = dict(rho=390.0, beta=math.pi, theta=0.0, v_f=25.0, rho_d=390.0)
    with pytest.raises(ValueError, match=match):
        FollowerEstimate(**{**base, **kwargs})


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(cap=100.0), "cap"),
        (dict(w_sch=0.0), "w_sch"),
        (dict(v_ld=-1.0), "v_ld"),
        (dict(floor_frac=2.0), "floor_frac"),
        (dict(predictor="magic"), "predictor"),
        (dict(methods=("guess",)), "methods"),
    ],
)
def test_adjust_validated(kwargs, match):
    f = FollowerEstimate(390.0, math.pi, 0.0, 25.0, 390.0)
    args = dict(v_ld=V_LD, w_sch=W_SCH, thresholds=Thresholds(25.0, 0.01, 0.025, 0.1))
    with pytest.raises(ValueError, match=match):
        adjust([f], **{**args, **kwargs})


def test_unknown_mode():
    with pytest.raises(ValueError, match="mode"):
        decide("fast", [], v_ld=V_LD, w_sch=W_SCH, thresholds=Thresholds(25.0, 0.01, 0.025, 0.1))


# ------------------------------------------------------------------ the hybrid model


def _hybrid_by_hand(f: FollowerEstimate, v: float, v_now: float, kappa: float):
    """u(V) = û + f(V) − f(V_now) written out from formation_velocity (leader frame)."""

    def ff(vl: float) -> tuple[float, float]:
        vf, th = formation_velocity(vl, kappa * vl, f.rho_d, f.beta_d)
        return vf * math.cos(th), -vf * math.sin(th)

    a, b = ff(v), ff(v_now)
    ux = f.v_f * math.cos(f.theta) + a[0] - b[0]
    uy = -f.v_f * math.sin(f.theta) + a[1] - b[1]
    return ux, uy


@pytest.mark.parametrize("kappa", [0.0, 1 / 200, -1 / 120])
@pytest.mark.parametrize("beta_deg", [165.0, 195.0])
def test_hybrid_without_correction_equals_formation(kappa, beta_deg):
    # the follower moves exactly at its slot's feed-forward velocity at the current V_L = 17:
    # no correction velocity, so hybrid = formation at every V_L
    slot = beta_deg * DEG
    v_now = 17.0
    vf, th = formation_velocity(v_now, kappa * v_now, 390.0, slot)
    f = FollowerEstimate(388.0, slot + 0.01, th, vf, 390.0, slot)
    hyb = predictor("hybrid", omega_l=kappa * v_now, kappa=kappa, v_now=v_now)
    form = predictor("formation", omega_l=kappa * v_now, kappa=kappa)
    for v in (0.5, 9.0, 17.0, 25.0):
        h, g = hyb(f, v), form(f, v)
        assert h[0] == pytest.approx(g[0], rel=1e-12, abs=1e-12)
        assert math.cos(h[1] - g[1]) == pytest.approx(1.0, abs=1e-12)
        assert h[2] == g[2] == kappa * v


def test_hybrid_equals_estimate_at_the_current_speed():
    f = FollowerEstimate(380.0, 190 * DEG, 0.7, 31.0, 390.0, 195 * DEG)
    hyb = predictor("hybrid", omega_l=0.1, kappa=1 / 200, v_now=20.0)
    v_f, theta, omega = hyb(f, 20.0)
    assert v_f == pytest.approx(31.0, rel=1e-12)
    assert theta == pytest.approx(0.7, abs=1e-12)
    assert omega == pytest.approx(20.0 / 200, rel=1e-12)


def test_hybrid_rho_dot_is_eq17_on_the_summed_velocity_vector():
    # by hand: ρ̇ = (u − v_L)·e_ρ in the leader frame (the leader frame's rotation moves the
    # follower tangentially only), u = û + f(V) − f(V_now)
    kappa, v_now, v = 1 / 200, 14.0, 22.0
    f = FollowerEstimate(380.0, 192 * DEG, 0.9, 28.0, 390.0, 195 * DEG)
    v_f, theta, omega = predictor("hybrid", omega_l=kappa * v_now, kappa=kappa, v_now=v_now)(f, v)
    ux, uy = _hybrid_by_hand(f, v, v_now, kappa)
    assert v_f == pytest.approx(math.hypot(ux, uy), rel=1e-12)
    er = (math.cos(f.beta), math.sin(f.beta))
    by_hand = (ux - v) * er[0] + uy * er[1]
    assert rho_dot(v, v_f, f.beta, theta) == pytest.approx(by_hand, rel=1e-12, abs=1e-12)
    # and the separation bound the model gives is T_ρ ρ_d / |ρ̇| in ms
    thr = Thresholds(r_H=25.0, T_rho=0.01, T_eps=0.025, T_beta=5 * DEG)
    m = predict_msbs([f], v, predictor("hybrid", omega_l=0.0, kappa=kappa, v_now=v_now), thr)
    assert m[0]["separation"] == pytest.approx(1000 * 3.9 / abs(by_hand), rel=1e-12)


def test_hybrid_correction_does_not_scale_with_the_leader():
    # on a straight, a follower 6 cm/s faster than the leader at 20 cm/s, heading along it:
    # hybrid predicts V_F = V_L + 6 at every V_L (the correction is held), formation V_F = V_L
    f = FollowerEstimate(390.0, math.pi, 0.0, 26.0, 390.0, math.pi)
    hyb = predictor("hybrid", omega_l=0.0, kappa=0.0, v_now=20.0)
    for v in (3.0, 10.0, 25.0):
        assert hyb(f, v)[0] == pytest.approx(v + 6.0, rel=1e-12)


@pytest.mark.parametrize("kappa", [1 / 200, -1 / 120])
def test_hybrid_bound_holds_at_the_returned_speed(kappa):
    # two followers off their slots with a correction velocity, mid-turn, leader at 0.6 V_Ld
    v_now = 0.6 * V_LD
    fs = []
    for slot_deg, drho, dv in ((195.0, -4.0, 3.0), (165.0, 2.0, -2.0)):
        slot = slot_deg * DEG
        vf, th = formation_velocity(v_now, kappa * v_now, 390.0, slot)
        fs.append(FollowerEstimate(390.0 + drho, slot + 0.02, th + 0.05, vf + dv, 390.0, slot))
    thr = Thresholds(r_H=25.0, T_rho=0.01, T_eps=0.025, T_beta=5 * DEG)
    a = adjust(
        fs,
        v_ld=V_LD,
        w_sch=W_SCH,
        thresholds=thr,
        kappa=kappa,
        omega_l=kappa * v_now,
        predictor="hybrid",
        v_now=v_now,
    )
    assert a.critical and a.feasible and 0 < a.v_leader < V_LD

    def bounds(v):  # written here from the hand formula, not from the predictor
        out = []
        for f in fs:
            ux, uy = _hybrid_by_hand(f, v, v_now, kappa)
            vf, th = math.hypot(ux, uy), -math.atan2(uy, ux)
            out.append(follower_msbs(v, kappa * v, vf, f.rho, f.beta, th, f.rho_d, thr))
        return min(min(m.values()) for m in out)

    assert bounds(a.v_leader) >= W_SCH * (1 - 1e-9)
    assert bounds(a.v_leader * (1 + 1e-6)) < W_SCH  # the largest such speed
    assert a.msb_min_after == pytest.approx(bounds(a.v_leader), rel=1e-9)


def test_hybrid_needs_the_current_speed():
    with pytest.raises(ValueError, match="v_now"):
        predictor("hybrid", omega_l=0.0, kappa=0.0)
    with pytest.raises(ValueError, match="v_now must be non-negative"):
        predictor("hybrid", omega_l=0.0, kappa=0.0, v_now=-1.0)
    with pytest.raises(ValueError, match="'hybrid'"):
        predictor("hybird", omega_l=0.0, kappa=0.0)
