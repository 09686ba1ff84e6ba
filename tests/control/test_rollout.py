"""The command-aware rollout (rtsim.control.rollout) and the ``commands`` predictor.

The rollout is checked against the world's own follow-the-leader controller driven with the
same noise-free inputs: a world without actuation, sensing or initial-estimate noise, whose
leader's target changes at the decision; the rollout starts from the world's state at the
decision and predicts the changes the world then observes between its scans.

Tolerance: 0.05 cm on the displacement, |Δρ| and distance driven per window, 5e-4 rad on
|Δβ|. The rollout integrates a held command with the world's own
:class:`~rtsim.world.follower.FollowerGroup` and commands with the world's own law, but the
world commands on its EKF's estimate, which propagates a command's speed ramp in one arc
where the truth sub-steps it: at a turn entry (Test 2, a follower accelerating to 1.7 V_L)
the estimate drifts from the truth by up to 0.06 cm, and the predicted changes differ from
the observed ones by at most 0.022 cm and 7e-5 rad (measured; elsewhere below 1e-5 cm).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from rollout_states import world_state

from rtsim.config.scenario import load_scenario
from rtsim.control.adjust import search_rollout
from rtsim.control.rollout import DECIDED, Rollout, RolloutState, decided_state, rollout_state
from rtsim.world import World

QUIET = {
    "follower.speed_noise": 0.0,
    "follower.turn_noise_deg": 0.0,
    "sensing.position_noise": 0.0,
    "localization.model": "gaussian",  # exact fixes (the hough model's cells quantise them)
    "ekf.init_position_sd": 0.0,
    "ekf.init_heading_sd_deg": 0.0,
}
OFFSETS = (130.0, 136.0)
TOL_CM, TOL_RAD = 0.05, 5e-4  # each follower's send after its window's scan (ms)


def _quiet_world(name: str, model: str = "follow-the-leader") -> World:
    sc = load_scenario(name, overrides={**QUIET, "formation.model": model})
    return World(sc.world, np.random.default_rng(1))


def _window(world: World, t: float, w: float) -> None:
    world.estimate(world.scan(t))
    for i, off in enumerate(OFFSETS, start=1):
        world.command(i, t + off)


@pytest.mark.parametrize(
    ("name", "v_target", "windows", "model"),
    [
        ("test2", 12.0, 12, "follow-the-leader"),  # braking hard into the followers' first turn
        ("test2", 30.0, 40, "follow-the-leader"),  # holding V_Ld through it
        ("test1", 18.0, 60, "follow-the-leader"),
        ("test2", 15.0, 115, "l-psi"),  # the l-ψ law, the leader in its first turn
    ],
)
def test_rollout_matches_the_world(name: str, v_target: float, windows: int, model: str) -> None:
    w = 237.0
    world = _quiet_world(name, model)
    for j in range(windows):  # drive some windows, then decide at 210 ms into the last
        _window(world, j * w, w)
    t_d = (windows - 1) * w + 210.0
    world.advance(t_d)
    state = world_state(world, t_d, windows * w, OFFSETS, w)
    ro = Rollout(state)
    ahead = [w, w, w]
    pred = ro.changes(v_target, ahead)
    # the world: the same target at the decision, then its own windows
    world.set_leader_speed(v_target, t_d)
    seen = []
    for j in range(windows, windows + len(ahead) + 1):
        t = j * w
        scan = world.scan(t)
        seen.append(scan.changes)
        world.estimate(scan)
        for i, off in enumerate(OFFSETS, start=1):
            world.command(i, t + off)
    keys = ("displacement", "d_rho", "travel", "d_beta")
    for jw, per in enumerate(pred):
        for k, c in enumerate(per):
            for q, key in enumerate(keys):
                tol = TOL_RAD if key == "d_beta" else TOL_CM
                assert c[q] == pytest.approx(seen[jw + 1][key][k], abs=tol), (jw, k, key)
    # the rollout never touched the world's law (a clone) and memoises
    assert ro.count == 1
    ro.changes(v_target, ahead)
    assert ro.count == 1
    # bounds: L·w / change, so a bound below w exactly when the change exceeds its limit
    rows = ro.rows(v_target)
    thr = world.config.thresholds
    rho_d = world.config.formation.rho_d[0]
    assert rows[0][2] == pytest.approx(thr.T_eps * rho_d * w / pred[0][0][2])


def test_search_rollout_brackets_and_bisects() -> None:
    # a min bound that passes below 17.3 cm/s only: found within 0.5 % of V_Ld, from below
    calls = []

    def m(v: float) -> float:
        calls.append(v)
        return 300.0 if v <= 17.3 else 100.0

    v, method, found = search_rollout(m, 30.0, 237.0, 3.0)
    assert method == "numeric" and 17.3 - 0.005 * 30.0 <= v <= 17.3 and found == v
    assert len(calls) <= 1 + 7 + 5
    # nothing passes: the least-bad speed, the larger one on a tie, method best
    v, method, found = search_rollout(lambda v: 100.0 + (v if v < 20 else 0.0), 30.0, 237.0, 3.0)
    assert method == "best" and math.isnan(found) and v == pytest.approx(30.0 * 5 / 8)


def _search_floor_first(
    m: Callable[[float], float], v_ld: float, need: float, v_floor: float
) -> tuple[float, str, float]:
    """search_rollout as it was before the floor's evaluation moved last (the reference)."""
    above = v_ld
    best_v, best_m = v_floor, m(v_floor) if v_floor > 0.0 else -math.inf
    for j in range(1, 8):
        v = v_ld * (1.0 - j / 8)
        mv = m(v)
        if mv >= need:
            lo, hi = v, above
            while hi - lo > 0.005 * v_ld:
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if m(mid) >= need else (lo, mid)
            return lo, "numeric", lo
        if mv > best_m:
            best_v, best_m = v, mv
        above = v
    return best_v, "best", math.nan


def test_search_rollout_rolls_the_floor_out_last() -> None:
    """The floor's m is asked for only when no scanned speed passes, and the result is the
    floor-first search's in every case: random bounds with ties (values on a coarse grid),
    NaN, a zero floor and a floor above some scanned speeds."""
    rng = np.random.default_rng(3)

    def m(v: float, calls: list[float], table: dict[float, float]) -> float:
        calls.append(v)
        if v not in table:
            table[v] = float(rng.choice([math.nan, *range(90, 110)]))
        return table[v]

    for trial in range(3000):
        table: dict[float, float] = {}

        v_ld = float(rng.uniform(5.0, 40.0))
        v_floor = float(rng.choice([0.0, 0.1 * v_ld, 0.4 * v_ld, math.nan]))
        need = float(rng.choice([95.0, 105.0, 120.0]))
        ref_calls: list[float] = []
        ref = _search_floor_first(
            functools.partial(m, calls=ref_calls, table=table), v_ld, need, v_floor
        )
        calls: list[float] = []
        got = search_rollout(functools.partial(m, calls=calls, table=table), v_ld, need, v_floor)
        assert repr(got) == repr(ref), trial
        if got[1] == "numeric" and v_floor > 0.0:  # the floor (no scanned speed) not asked
            assert v_floor not in calls and len(calls) == len(ref_calls) - 1
        else:
            assert sorted(calls, key=repr) == sorted(ref_calls, key=repr)


def test_rollouts_run_counts_each_rollout_once() -> None:
    """rollouts_run() grows by one per rollout run, not per memoised read."""
    from rtsim.control.rollout import rollouts_run

    world = _quiet_world("test2")
    for j in range(12):
        _window(world, j * 237.0, 237.0)
    t_d = 11 * 237.0 + 210.0
    world.advance(t_d)
    ro = Rollout(world_state(world, t_d, 12 * 237.0, OFFSETS, 237.0))
    before = rollouts_run()
    ro.changes(12.0, (237.0,))
    ro.changes(12.0, (237.0,))
    ro.changes(20.0, (237.0, 237.0))
    assert rollouts_run() - before == 2 == ro.count


def test_paper_infeasible_is_exact_against_brute_force() -> None:
    """The ``paper`` model's exact empty-intersection test against a scan of 4,000 speeds:
    when it says no speed keeps every bound, none of the scan does; when the scan finds one,
    it never says empty; and it says empty in most windows where the scan finds none."""
    from rtsim.analysis.kinematics import Thresholds
    from rtsim.control.adjust import paper_infeasible, predicted_rows
    from rtsim.control.predict import FollowerEstimate

    rng = np.random.default_rng(7)
    thr = Thresholds(r_H=25.0, T_rho=0.005, T_eps=0.025, T_beta=math.radians(5))
    v_ld, w_sch = 30.0, 237.0
    grid = np.linspace(v_ld / 4000, v_ld, 4000)
    agree = empty = 0
    for _ in range(150):
        fols = [
            FollowerEstimate(
                rng.uniform(250, 400),
                rng.uniform(2.6, 3.7),
                rng.normal(0, 0.4),
                rng.uniform(0, 45),
                325.0,
            )
            for _ in range(2)
        ]
        omega = rng.normal(0, 0.15)
        says = paper_infeasible(fols, v_ld, w_sch, thr, omega)
        ok = any(
            min(
                min(r)
                for r in predicted_rows(
                    fols, float(v), thresholds=thr, predictor="paper", omega_l=omega
                )
            )
            >= w_sch * (1 - 1e-9)
            for v in grid
        )
        assert not (says and ok)
        empty += not ok
        agree += says == (not ok)
    assert empty > 15 and agree >= 147


def test_a_users_policy_gets_the_rollout() -> None:
    """The documented hook: a policy class with ``needs_rollout = True`` receives
    ``PolicyInput.rollout`` in a coupled run, and its rows at V_Ld are the ``commands``
    predictor's (the decision of the paper's algorithm on the rollout)."""
    from rtsim.control.adjust import Decision
    from rtsim.control.policy import ADJUSTMENT_POLICIES, PaperPolicy, register_adjustment_policy
    from rtsim.control.predict import min_bound_rows
    from rtsim.coupling import run_scenario

    seen = []

    class Probe:
        params: dict = {}
        needs_rollout = True

        def decide(self, ctx):  # type: ignore[no-untyped-def]
            rows = ctx.rollout.rows(ctx.v_ld)
            d = PaperPolicy().decide(ctx)  # the paper's algorithm with predictor commands
            seen.append((ctx.predictor, rows == d.rows, ctx.rollout.count >= 1))
            assert len(ctx.followers) == 2  # (no needs_followers = False: the estimates too)
            m = min_bound_rows(rows)[0]
            return Decision(ctx.w_sch, ctx.v_ld, m, "none", 0, "none", True, rows, rows, m, {})

    register_adjustment_policy("probe-rollout")(Probe)
    try:
        res = run_scenario(
            "test2", policy="probe-rollout", duration_s=5.0, seed=0, record_jobs=False
        )
    finally:
        ADJUSTMENT_POLICIES.pop("probe-rollout")
    assert seen and all(p == "commands" and same and ran for p, same, ran in seen)
    assert res.summary["predictor"] == "commands"


def test_plan_reads_no_followers(monkeypatch: pytest.MonkeyPatch) -> None:
    """``plan`` sets ``needs_followers = False``: a coupled run leaves its
    ``PolicyInput.followers`` empty (it reads the estimates through the rollout), and the
    decisions are those it makes with them (the pinned digests hold the runs bit for bit)."""
    from rtsim.control.policy import PlanPolicy
    from rtsim.coupling import run_scenario

    seen: list[int] = []
    decide = PlanPolicy.decide

    def probe(self, ctx):  # type: ignore[no-untyped-def]
        seen.append(len(ctx.followers))
        full = dataclasses.replace(ctx, followers=tuple(range(5)))  # (never read)
        made = decide(self, ctx)
        assert repr(decide(self, full)) == repr(made)  # (repr: a NaN found speed is equal)
        return made

    monkeypatch.setattr(PlanPolicy, "decide", probe)
    run_scenario("test2", policy="plan", duration_s=3.0, seed=0, record_jobs=False)
    assert seen and set(seen) == {0}


def test_rollout_state_is_the_dataclass() -> None:
    """`rollout_state` (the fields written at once) builds what `RolloutState` does: equal,
    the same hash, every field and default the same, frozen; too few or too many fields
    are refused as the dataclass refuses them."""
    world = _quiet_world("test2")
    st = world_state(world, 0.0, 0.0, OFFSETS, 240.0)
    values = [getattr(st, f) for f in ("path", "law", "params", "step_ms", "t_now")]
    values += [getattr(st, f) for f in RolloutState.__dataclass_fields__][5:19]
    for given in (values, values + [st.group, st.beta_d, 12.5]):
        made = rollout_state(*given, turns=(0.1, 0.2))
        want = RolloutState(*given, turns=(0.1, 0.2))
        assert made == want and hash(made) == hash(want) and vars(made) == vars(want)
        with pytest.raises(AttributeError):
            made.t_now = 1.0  # type: ignore[misc]
    for bad in (values[:-1], [*values, st.group, st.beta_d, 12.5, 0.0]):
        with pytest.raises(TypeError):
            RolloutState(*bad)
        with pytest.raises(TypeError):
            rollout_state(*bad)


def test_decided_state_is_replace() -> None:
    """`decided_state` (a run's fixed fields copied, a decision's written in) builds what
    ``dataclasses.replace`` does: equal, the same hash and fields, frozen; the base is not
    changed; a wrong count of decision fields is refused."""
    world = _quiet_world("test2")
    base = world_state(world, 0.0, 0.0, OFFSETS, 240.0)
    keep = dict(vars(base))
    values = (
        12.5,
        base.leader_s + 3.0,
        17.0,
        ((1.0, 2.0, 0.1), (3.0, 4.0, 0.2)),
        (10.0, 11.0),
        ((10.0, 0.01), (11.0, 0.02)),
        ((20.0,), ()),
        40.0,
        (131.0, 137.0),
        (0.01, 0.02),
    )
    made = decided_state(base, *values)
    want = dataclasses.replace(base, **dict(zip(DECIDED, values, strict=True)))
    assert made == want and hash(made) == hash(want) and vars(made) == vars(want)
    assert made != base and vars(base) == keep
    with pytest.raises(AttributeError):
        made.t_now = 1.0  # type: ignore[misc]
    with pytest.raises(TypeError):
        decided_state(base, *values[:-1])


@pytest.mark.parametrize("backend", ["python", "compiled"])
def test_plan_on_rollout_is_its_decide(backend: str) -> None:
    """`PlanPolicy.on_rollout` (a run's decisions without a `PolicyInput` each) decides as
    `decide` on the same input with the rollout in it, on two rollouts of one state: the
    same decision (repr: a NaN found speed) and the same memo, for margins that keep V_Ld,
    search or find nothing; None once ``decide`` is not the class's own."""
    from rtsim.control.policy import PlanPolicy, PolicyInput

    sc = load_scenario("test2", overrides={**QUIET, "world.backend": backend})
    world = World(sc.world, np.random.default_rng(1))
    w = 237.0
    for j in range(40):
        _window(world, j * w, w)
    t = 39 * w + 210.0
    world.advance(t)
    st = world_state(world, t, 40 * w, OFFSETS, w)
    for margin in (0.0, 0.4, 0.9):
        pol = PlanPolicy(windows=2, margin=margin)
        ctx = PolicyInput((), st.v_ld, st.w_sch, st.thresholds)
        ro_a, ro_b = Rollout(st), Rollout(st)
        assert ro_b == ro_a and (ro_b._compiled is None) == (backend == "python")
        decider = pol.on_rollout(ctx)
        assert decider is not None
        a = pol.decide(dataclasses.replace(ctx, rollout=ro_a))
        assert repr(decider(ro_b)) == repr(a), margin
        assert ro_b.count == ro_a.count and set(ro_b._memo) == set(ro_a._memo)
        assert set(ro_b._raw) == set(ro_a._raw)

    class Own(PlanPolicy):
        def decide(self, ctx: PolicyInput) -> Any:
            return super().decide(ctx)

    assert Own().on_rollout(PolicyInput((), st.v_ld, st.w_sch, st.thresholds)) is None


@pytest.mark.parametrize("localization", ["radial", "predicted"])
def test_bounds_are_limit_times_w_over_change(localization: str) -> None:
    """`Rollout.bounds`: per follower (r_H, T_ρ·ρ_d, T_ε·ρ_d, T_β) · w / change, inf where
    a change is ≤ 0 (NaN stays NaN), the localization bound the predicted one when the
    window follows the predicted motion; checked against `true_bounds` (the windows
    table's own formula) on the finite changes."""
    from rtsim.coupling.recorder import true_bounds

    world = _quiet_world("test2")
    world.advance(100.0)
    st = world_state(world, 100.0, 237.0, OFFSETS, 237.0)
    thr = dataclasses.replace(st.thresholds, localization=localization, predicted_ms=123.0)
    ro = Rollout(dataclasses.replace(st, thresholds=thr))
    w = 211.0
    rng = np.random.default_rng(5)
    changes = [tuple(rng.uniform(-1.0, 3.0, 5).tolist()) for _ in st.rho_d]
    changes[0] = (0.0, -0.0, math.nan, 2.5, 7.0)
    rows = ro.bounds(changes, w)
    for k, (c, rho_d) in enumerate(zip(changes, st.rho_d, strict=True)):
        lims = (thr.r_H, thr.T_rho * rho_d, thr.T_eps * rho_d, thr.T_beta)
        for j in range(4):
            got = rows[k][j]
            if j == 0 and localization == "predicted":
                assert got == 123.0
            elif math.isnan(c[j]):
                assert math.isnan(got)
            else:
                assert got == float(true_bounds(np.array(w), np.array(c[j]), lims[j]))


@pytest.mark.parametrize("pending", [False, True])
def test_compiled_plan_is_the_python_plan(pending: bool) -> None:
    """The compiled decision (its pack of the state, made per decision, and its kernel) is
    the Python reference's bit for bit: on the same world on both backends, `PlanPolicy`
    decides the same (repr: a NaN found speed), and every rollout the compiled search left
    for the memo (arrays, and the ones it stopped after a window, rolled out whole when
    asked) gives the Python rollout's changes of the same target and windows; with and
    without sends pending."""
    from rtsim.control.compiled_rollout import _Rest
    from rtsim.control.policy import PlanPolicy, PolicyInput

    st_py, st_c = (_mid_run(backend, pending)[2] for backend in ("python", "compiled"))
    assert vars(st_py).keys() == vars(st_c).keys()
    rested = 0
    for margin in (0.0, 0.4, 0.9):
        pol = PlanPolicy(windows=2, margin=margin)
        ro_py, ro_c = Rollout(st_py), Rollout(st_c)
        ro_py._compiled = None  # (the Python reference on the compiled law's numbers)
        assert ro_c._compiled is not None
        ctx = PolicyInput((), st_c.v_ld, st_c.w_sch, st_c.thresholds)
        made_c = pol.decide(dataclasses.replace(ctx, rollout=ro_c))
        made_py = pol.decide(dataclasses.replace(ctx, rollout=ro_py))
        assert repr(made_c) == repr(made_py), margin
        for key, raw in list(ro_c._raw.items()):
            rested += isinstance(raw, _Rest)
            assert ro_c.changes(*key) == ro_py.changes(*key), key
    assert rested


def test_estimate_rows_are_the_decisions_reads() -> None:
    """`World.estimate_rows` (what a coupled run's decision reads in one call) is, per
    follower, its `estimate_at`, the turn rate `_propagate` carries and `held_command`, on
    both backends and the same bits on both (a noisy world, decided mid-window, some sends
    done); a compiled rollout packed from those rows (`Rollout.decided`, a run's) is the
    one packed from the state's tuples made of them."""
    from rtsim.control.rollout import decided_state

    seen = []
    for backend in ("python", "compiled"):
        sc = load_scenario("test2", overrides={"world.backend": backend})
        world = World(sc.world, np.random.default_rng(3))
        w = 237.0
        for j in range(30):
            _window(world, j * w, w)
        world.estimate(world.scan(30 * w))
        world.command(1, 30 * w + OFFSETS[0])
        t = 30 * w + 133.0
        world.advance(t)
        rows = world.estimate_rows(t)
        n = world.n
        assert rows == [
            [*world.estimate_at(i, t)[0], world.estimate_at(i, t)[1],
             world._propagate(i - 1, t)[2], *world.held_command(i)]
            for i in range(1, n + 1)
        ]  # fmt: skip
        seen.append([[x.hex() for x in r] for r in rows])
        if backend == "compiled":
            base = world_state(world, t, 31 * w, OFFSETS, w)
            state = decided_state(
                base, t, base.leader_s, base.leader_speed,
                tuple([(r[0], r[1], r[2]) for r in rows]), tuple([r[3] for r in rows]),
                tuple([(r[5], r[6]) for r in rows]), base.pending, base.next_scan,
                base.send_offsets, (),
            )  # fmt: skip
            decided = Rollout.decided(base)
            values = (t, base.leader_s, base.leader_speed, rows, base.pending, base.next_scan)
            values += (base.send_offsets,)
            a, b = Rollout(state)._compiled.pack(), decided(*values, False)._compiled.pack()
            assert [x.tobytes() for x in a[:3]] == [y.tobytes() for y in b[:3]]
            # the turn-rate column from the rows when the state has turns
            turned = dataclasses.replace(state, turns=tuple([r[4] for r in rows]))
            a, b = Rollout(turned)._compiled.pack(), decided(*values, True)._compiled.pack()
            assert a[1].tobytes() == b[1].tobytes()
            # the pending sends' pack: NaN-padded rows, read flat when as many for each
            for pending, want in (
                (((1.5,), (2.5, 3.5)), [[1.5, math.nan], [2.5, 3.5]]),
                (((1.5, 4.5), (2.5, 3.5)), [[1.5, 4.5], [2.5, 3.5]]),
                (((1.5,), (2.5,)), [[1.5], [2.5]]),
            ):
                got = Rollout(dataclasses.replace(state, pending=pending))._compiled.pack()[2]
                assert got.tobytes() == np.array(want).tobytes(), pending
    assert seen[0] == seen[1]


def _mid_run(backend: str, pending: bool = False) -> tuple[World, float, RolloutState]:
    """A test2 world 39 windows in on ``backend``, decided mid-window (sends done, or the
    last window's still to come), and its state (`world_state`)."""
    sc = load_scenario("test2", overrides={**QUIET, "world.backend": backend})
    world = World(sc.world, np.random.default_rng(1))
    w = 237.0
    for j in range(39):
        _window(world, j * w, w)
    if pending:
        world.estimate(world.scan(39 * w))
    else:
        _window(world, 39 * w, w)
    t = 39 * w + (100.0 if pending else 210.0)
    world.advance(t)
    sends = tuple((39 * w + o,) for o in OFFSETS) if pending else None
    return world, t, world_state(world, t, 40 * w, OFFSETS, w, sends)


@pytest.mark.parametrize("backend", ["python", "compiled"])
@pytest.mark.parametrize("pending", [False, True])
def test_decided_rollout_is_the_rows_state(backend: str, pending: bool) -> None:
    """`Rollout.decided` (a coupled run's rollouts) is the rollout of `rows_state`: its
    state, read, is that state (made only when read on the compiled backend), and its
    compiled pack the one `Rollout` packs of that state, with the rows'
    turn rates as the turns or the held commands' (``turned``)."""
    from rtsim.control.rollout import rows_state

    world, t, st = _mid_run(backend, pending)
    rows = world.estimate_rows(t)
    make = Rollout.decided(st)
    for turned in (False, True):
        values = (t, st.leader_s, st.leader_speed, rows, st.pending, st.next_scan)
        values += (st.send_offsets, turned)
        ro = make(*values)
        want = rows_state(st, *values)
        assert ("state" in vars(ro)) == (backend == "python")
        assert ro.state == want and ro.base.w_sch == want.w_sch
        assert want.turns == (tuple([r[4] for r in rows]) if turned else ())
        if backend == "compiled":
            a, b = ro._compiled.pack(), Rollout(want)._compiled.pack()
            assert [x.tobytes() for x in a[:3]] == [y.tobytes() for y in b[:3]]
            assert a[3:] == b[3:]
        else:
            assert ro._compiled is None


@pytest.mark.parametrize("pending", [False, True])
def test_planned_step_is_decided_then_plan(pending: bool) -> None:
    """`Rollout.planned`'s step (the pack written by the estimates' carry in place, the plan
    in the same step) is `Rollout.decided`'s rollout of the world's `estimate_rows` and its
    `plan`, bit for bit: the pack's arrays, the state read, the plan's answer, and the memo
    its rollouts leave, with and without turns, for margins that keep V_Ld or search; the
    rows the step hands back start with the estimates' rows. ``World.estimate_rows`` with an
    ``out`` array writes those rows into its first seven columns, on either backend."""
    for backend in ("python", "compiled"):
        world, t, st = _mid_run(backend, pending)
        out = np.full((world.n, 9), 7.5)
        assert world.estimate_rows(t, out) is out
        assert out[:, :7].tolist() == world.estimate_rows(t) and (out[:, 7:] == 7.5).all()
    assert Rollout.planned(dataclasses.replace(st, law=None), False, 1, 1, 1, 1, 2, 0) is None
    rows = world.estimate_rows(t)
    make = Rollout.decided(st)
    need, cap, v_floor = st.w_sch * 0.999, 3.0 * st.w_sch, 0.3 * st.v_ld
    methods = set()
    for turned in (False, True):
        for margin in (0.0, 0.9):
            step = Rollout.planned(st, turned, 1.0 - margin, need, cap, v_floor, 2, 60.0)
            assert step is not None
            values = (t, st.leader_s, st.leader_speed, st.pending, st.next_scan)
            step(world.estimate_rows, *values, st.send_offsets)  # (its template kept)
            ro, hit, got = step(world.estimate_rows, *values, st.send_offsets)
            want = make(*values[:3], rows, *values[3:], st.send_offsets, turned)
            a, b = ro._compiled.pack(), want._compiled.pack()
            assert [x.tobytes() for x in a[:3]] == [y.tobytes() for y in b[:3]]
            assert a[3:] == b[3:]
            assert type(got) is np.ndarray  # (the pack's rows, read as lists when asked)
            assert [r[:4] for r in got.tolist()] == [r[:4] for r in rows]
            assert ro.state == want.state
            plan = want.plan(st.v_ld, 1.0 - margin, need, cap, v_floor, 2, st.w_sch, 60.0)
            assert repr(hit) == repr(plan)
            methods.add(hit[2])
            assert ro.count == want.count and ro._memo == want._memo
            assert ro._raw.keys() == want._raw.keys()
    assert "none" in methods and len(methods) > 1  # (V_Ld kept, and a search)


@pytest.mark.parametrize("pending", [False, True])
def test_kept_rollouts_read_as_put(pending: bool) -> None:
    """A compiled decision's rollouts kept as the kernel left them (`_Kept`) read as the
    memo's entries they make when put (`Rollout._raw`): every key's `_Kept.first` is the
    entry (the same array, or a `_Rest` of the same rollout), other keys none; a rollout
    that reads a key directly (`changes`, `closest`) ends with the memo, entries and count
    of one that put them all first, for margins that keep V_Ld, search or find nothing."""
    from rtsim.control.compiled_rollout import _Rest
    from rtsim.control.policy import PlanPolicy, PolicyInput

    world, t, st = _mid_run("compiled", pending)
    ctx = PolicyInput((), st.v_ld, st.w_sch, st.thresholds)
    for margin in (0.0, 0.4, 0.9):
        pol = PlanPolicy(windows=2, margin=margin)
        lazy, put = Rollout(st), Rollout(st)
        a = pol.decide(dataclasses.replace(ctx, rollout=lazy))
        assert repr(pol.decide(dataclasses.replace(ctx, rollout=put))) == repr(a)
        kept = lazy._kept
        assert kept is not None and put._raw  # (read: put)
        for key, entry in put._raw.items():
            got = kept.first(key)
            if isinstance(entry, _Rest):
                assert isinstance(got, _Rest) and got[1:3] == entry[1:3]
            else:
                assert got.tobytes() == entry.tobytes() and got.shape == entry.shape
        assert kept.first((-1.0, (st.w_sch,))) is None
        for r in range(kept[3]):  # (each rollout's first window's closest approaches)
            assert kept.near(r) == kept.changes()[r, 0, :, 4].tolist()
        keys = list(put._raw)
        for key in [keys[0], keys[-1], (st.v_ld, (st.w_sch,)), (0.5 * st.v_ld, (st.w_sch,))]:
            assert lazy.closest(key[0], key[1][0]) == put.closest(key[0], key[1][0])
            assert lazy.changes(*key) == put.changes(*key), key
            assert lazy._kept is not None  # (not put: read directly)
        assert lazy.count == put.count and lazy._memo == put._memo
        assert lazy._raw.keys() == put._raw.keys()


@pytest.mark.parametrize("backend", ["python", "compiled"])
def test_rows_closest_is_rows_and_closest(backend: str) -> None:
    """`Rollout.rows_closest` (the window close's `_pred` read) gives `rows` and `closest`
    at a speed the decision did not evaluate, with one rollout made, not two."""
    from rtsim.control.policy import PlanPolicy, PolicyInput

    world, t, st = _mid_run(backend, False)
    ctx = PolicyInput((), st.v_ld, st.w_sch, st.thresholds)
    pol = PlanPolicy(windows=2, margin=0.4)
    both, apart = Rollout(st), Rollout(st)
    pol.decide(dataclasses.replace(ctx, rollout=both))
    pol.decide(dataclasses.replace(ctx, rollout=apart))
    v = 0.37 * st.v_ld  # (no speed of the search)
    before = both.count
    rows, near = both.rows_closest(v)
    assert both.count == before + 1
    assert rows == apart.rows(v) and near == apart.closest(v)
    assert near == [c[4] for c in apart.changes(v, (st.w_sch,))[0]]


def test_bearing_is_atan2_mod_two_pi() -> None:
    """The rollout's bearing of a sample (`_bearing`: no fmod) is ``math.atan2(y, x) % 2π``
    bit for bit, as plain Python and compiled: random points, the axes, zeros of either
    sign (+0.0 out), NaN."""
    from rtsim.control.kernels import _bearing
    from rtsim.world.compiled import available

    rng = np.random.default_rng(48)
    pts = rng.standard_normal((5000, 2)) * 10.0 ** rng.integers(-6, 6, (5000, 1))
    pairs = [(y, x) for x, y in pts.tolist()]
    edge = [0.0, -0.0, 1.0, -1.0, 1e-320, -1e-320, math.inf, -math.inf]
    pairs += [(y, x) for y in edge for x in edge]
    fns = [_bearing]
    if available():
        from rtsim.world.jit import build  # lazy: imports numba

        fns.append(build(_bearing))
    for fn in fns:
        for y, x in pairs:
            assert fn(y, x).hex() == (math.atan2(y, x) % (2.0 * math.pi)).hex(), (y, x)
        assert math.isnan(fn(math.nan, 1.0)) and math.isnan(fn(1.0, math.nan))
