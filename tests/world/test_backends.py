"""The world's ``compiled`` backend gives the ``python`` backend's results bit for bit.

The Python classes are the reference (their own tests check them against hand derivations
and filterpy); here every compiled kernel is compared with the Python code it replaces, on
random inputs, and whole coupled runs (Test 1, Test 2, the frozen pin scenarios, random
variations) are compared byte for byte: windows.csv, jobs.csv and the summary.
"""

from __future__ import annotations

import itertools
import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rollout_states import world_state

from rtsim.config.scenario import load_scenario
from rtsim.coupling import run_scenario
from rtsim.errors import ScenarioError
from rtsim.world import compiled
from rtsim.world.ekf import EkfParams, FastFollowerEKF
from rtsim.world.follower import FollowerGroup, FollowerParams
from rtsim.world.ftl import TraceFollower
from rtsim.world.path import rounded_rectangle
from rtsim.world.world import World

ROOT = Path(__file__).resolve().parents[2]
PIN = ROOT / "tests" / "data" / "policy_pin"

needs_numba = pytest.mark.skipif(not compiled.available(), reason="numba is not importable")
BACKENDS = ["python", pytest.param("compiled", marks=needs_numba), "filterpy"]


def _bits(x: Any) -> Any:
    if isinstance(x, float):
        return x.hex()
    if isinstance(x, list | tuple):
        return [_bits(v) for v in x]
    if isinstance(x, dict):
        return {k: _bits(v) for k, v in x.items()}
    return x


def _run(scenario: Any, backend: str, **kw: Any) -> Any:
    over = dict(kw.pop("overrides", {}))
    over["world.backend"] = backend
    return run_scenario(scenario, overrides=over, **kw)


def _same_run(a: Any, b: Any) -> None:
    assert a.windows.to_csv(index=False) == b.windows.to_csv(index=False)
    if a.jobs is not None:
        assert a.jobs.to_csv(index=False) == b.jobs.to_csv(index=False)
    assert json.dumps(a.summary, sort_keys=True, default=str) == json.dumps(
        b.summary, sort_keys=True, default=str
    )


@needs_numba
@pytest.mark.parametrize("scenario", ["test1", "test2"])
def test_shipped_scenarios_bit_identical(scenario: str) -> None:
    py = _run(scenario, "python", duration_s=150, seed=5)
    co = _run(scenario, "compiled", duration_s=150, seed=5)
    _same_run(py, co)


@needs_numba
@pytest.mark.parametrize("pin", ["pin1", "pin2"])
@pytest.mark.parametrize("mode", ["adjust", "min-msb"])
def test_pin_scenarios_bit_identical(pin: str, mode: str) -> None:
    py = _run(PIN / f"{pin}.toml", "python", policy=mode, duration_s=20.0, seed=1)
    co = _run(PIN / f"{pin}.toml", "compiled", policy=mode, duration_s=20.0, seed=1)
    _same_run(py, co)


@needs_numba
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_variations_bit_identical(seed: int) -> None:
    """Followers, formation model, speeds, noise and ramps drawn at random."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 5))
    over = {
        "formation.followers": n,
        "formation.model": str(rng.choice(["follow-the-leader", "l-psi"])),
        "leader.speed": float(rng.uniform(10, 40)),
        "follower.max_accel": float(rng.uniform(20, 300)),
        "follower.speed_noise": float(rng.uniform(0, 3)),
        "sensing.position_noise": float(rng.uniform(0.2, 4)),
        "world.step_ms": float(rng.choice([2.5, 10.0, 40.0])),
    }
    py = _run("test2", "python", duration_s=60, seed=seed, overrides=over, record_jobs=False)
    co = _run("test2", "compiled", duration_s=60, seed=seed, overrides=over, record_jobs=False)
    _same_run(py, co)


@needs_numba
def test_follower_advance_kernel() -> None:
    rng = np.random.default_rng(7)
    p = FollowerParams(max_accel=80.0)
    for _ in range(200):
        n = 3
        args = (
            rng.uniform(-500, 500, n),
            rng.uniform(-500, 500, n),
            rng.uniform(-7, 7, n),
            rng.uniform(0, 60, n),
        )
        a, b = FollowerGroup(*args, p), compiled.CompiledFollowerGroup(*args, p)
        for g in (a, b):
            g.cmd_v = [float(v) for v in rng.uniform(-20, 80, n)] if g is a else list(a.cmd_v)
            g.cmd_w = [float(v) for v in rng.uniform(-0.5, 0.5, n)] if g is a else list(a.cmd_w)
        t = float(rng.uniform(0, 400))
        step = float(rng.choice([1.0, 10.0, 33.3]))
        a.advance_all(t, step)
        b.advance_all(t, step)
        for field in ("x", "y", "th", "v", "odometer", "t"):
            assert _bits(getattr(a, field)) == _bits(getattr(b, field)), field


@needs_numba
def test_ekf_kernels() -> None:
    rng = np.random.default_rng(11)
    params = EkfParams(speed_noise=0.7, turn_noise=0.01, position_drift=0.3)
    for _ in range(100):
        pose = tuple(float(v) for v in rng.uniform(-300, 300, 3))
        a, b = FastFollowerEKF(pose, params), compiled.CompiledFollowerEKF(pose, params)
        for _ in range(5):
            v, w, dt = (
                float(rng.uniform(-10, 50)),
                float(rng.uniform(-1, 1)),
                float(rng.choice([0.0, rng.uniform(0.01, 0.5)])),
            )
            if rng.random() < 0.2:
                w = 0.0
            a.predict(v, w, dt)
            b.predict(v, w, dt)
            z = (pose[0] + float(rng.normal(0, 5)), pose[1] + float(rng.normal(0, 5)))
            a.update(z)
            b.update(z)
            assert _bits(a.x) == _bits(b.x)
            assert _bits(a._p) == _bits(b._p)


@needs_numba
def test_ftl_command_kernel() -> None:
    """TraceFollower.command and the compiled one, from the same states, on random leader
    positions along the path: the same command and the same remembered arc lengths."""
    rng = np.random.default_rng(3)
    path = rounded_rectangle(800, 400, 120)
    rho, lat = [325.0, 325.0, 500.0, 520.0], [80.0, -80.0, 80.0, -60.0]
    a = TraceFollower(path, rho, lat, 0.5, 40.0)
    b = compiled.CompiledTraceFollower(path, rho, lat, 0.5, 40.0)
    s_l = 1000.0
    for k in range(4):
        assert _bits(a.initial(k, s_l, path.pose(s_l), 30.0)) == _bits(
            b.initial(k, s_l, path.pose(s_l), 30.0)
        )
    for _ in range(300):
        s_l += float(rng.uniform(0, 40))
        leader = path.pose(s_l)
        k = int(rng.integers(0, 4))
        x, y, h = a.point(k, a._s_ref[k] if a._s_ref[k] is not None else s_l)
        x, y, h = (
            x + float(rng.normal(0, 5)),
            y + float(rng.normal(0, 5)),
            h + float(rng.normal(0, 0.05)),
        )
        v_l = float(rng.uniform(0, 35))
        assert _bits(a.command(k, s_l, leader, v_l, x, y, h)) == _bits(
            b.command(k, s_l, leader, v_l, x, y, h)
        )
        assert _bits(a._s_ref) == _bits(b._s_ref) and _bits(a._s_f) == _bits(b._s_f)


@pytest.mark.parametrize("backend", BACKENDS)
def test_each_backend_runs_the_world(backend: str) -> None:
    """Every backend builds its world and runs Test 2 for a few windows (CI runs all)."""
    sc = load_scenario("test2", overrides={"world.backend": backend})
    w = World(sc.world, np.random.default_rng(0))
    assert w.backend == backend
    res = _run("test2", backend, duration_s=10, seed=0)
    assert res.summary["windows"] > 30


def test_backend_switch_and_alias() -> None:
    assert load_scenario("test2").world.resolved_backend() == (
        "compiled" if compiled.available() else "python"
    )
    sc = load_scenario("test2", overrides={"ekf.backend": "filterpy"})
    assert sc.world.resolved_backend() == "filterpy"
    w = World(sc.world, np.random.default_rng(0))
    assert type(w.filters[0]).__name__ == "FollowerEKF"
    with pytest.raises(ScenarioError, match="world.backend: 'python' contradicts ekf.backend"):
        load_scenario("test2", overrides={"ekf.backend": "filterpy", "world.backend": "python"})
    with pytest.raises(ScenarioError, match="world.backend: must be one of"):
        load_scenario("test2", overrides={"world.backend": "fast"})


def test_compiled_without_numba_is_an_error(monkeypatch: pytest.MonkeyPatch) -> None:
    import rtsim.world.kernels as kernels_module

    monkeypatch.setattr(kernels_module, "_AVAILABLE", False)
    assert load_scenario("test2").world.resolved_backend() == "python"
    sc = load_scenario("test2", overrides={"world.backend": "compiled"})
    with pytest.raises(ScenarioError, match="needs numba"):
        sc.world.resolved_backend()


@needs_numba
def test_second_process_loads_kernels_from_the_cache() -> None:
    """After one run has compiled the kernels, a fresh interpreter compiles nothing."""
    _run("test2", "compiled", duration_s=5, seed=0)
    code = (
        "from rtsim.coupling import run_scenario\n"
        "from rtsim.world import compiled\n"
        "run_scenario('test2', duration_s=5, overrides={'world.backend': 'compiled'})\n"
        "from rtsim.control.kernels import rollout_kernels\n"
        "ks = (compiled.kernels(), rollout_kernels())\n"
        "ds = [d for k in ks for d in vars(k).values() if hasattr(d, 'stats')]\n"
        "print(sum(len(d.stats.cache_misses) for d in ds),"
        " sum(len(d.stats.cache_hits) for d in ds))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT
    )
    misses, hits = map(int, out.stdout.split())
    assert misses == 0 and hits >= 4
    assert math.isfinite(hits)


#: (adjust here on the rollout: the paper's predictor is its default since issue 33)
PLAN = {"adjust.policy": "plan", "adjust.predictor": "commands", "adjust.paper_predictor": False}
PAPER = {"adjust.policy": "adjust", "adjust.predictor": "paper"}  # the paper's own search


@needs_numba
def test_compiled_hypot_is_the_interpreters() -> None:
    """The rollout kernel computes hypot itself, as CPython does (checked at load too)."""
    ker = compiled.kernels()
    assert ker.exact_hypot
    rng = np.random.default_rng(17)
    pts = rng.uniform(-2000, 2000, (20000, 2)) * 10.0 ** rng.integers(-3, 4, (20000, 1))
    assert all(ker.hypot(x, y) == math.hypot(x, y) for x, y in pts.tolist())


@needs_numba
@pytest.mark.parametrize("scenario", ["test1", "test2"])
@pytest.mark.parametrize("policy", ["plan", "adjust"])
def test_rollout_policy_bit_identical(scenario: str, policy: str) -> None:
    """The plan policy and the paper's algorithm on the command-aware rollout: the compiled
    rollout and speed search give the Python ones' decisions and tables."""
    over = {**PLAN, "adjust.policy": policy}
    py = _run(scenario, "python", duration_s=60, seed=3, overrides=over)
    co = _run(scenario, "compiled", duration_s=60, seed=3, overrides=over)
    assert (co.windows["method"] == "numeric").any()  # the compiled search ran and found
    _same_run(py, co)


@needs_numba
def test_rollout_falls_back_without_an_exact_hypot(monkeypatch: pytest.MonkeyPatch) -> None:
    ker = compiled.kernels()
    py = _run("test2", "python", duration_s=20, seed=1, overrides=PLAN, record_jobs=False)
    monkeypatch.setattr(ker, "exact_hypot", False)
    co = _run("test2", "compiled", duration_s=20, seed=1, overrides=PLAN, record_jobs=False)
    _same_run(py, co)


@needs_numba
def test_a_users_python_predictor_runs_on_the_compiled_world() -> None:
    """The decision stays Python: a user's own predictor is called on either backend, with
    the same results."""
    from dataclasses import replace

    from rtsim.coupling import scenario_inputs

    calls = []

    def mine(f: Any, v_l: float) -> tuple[float, float, float]:
        calls.append(v_l)
        return f.v_f, f.theta, 0.0

    out = {}
    for backend in ("python", "compiled"):
        sc = load_scenario("test2", overrides={**PAPER, "world.backend": backend})
        inp = scenario_inputs(sc)
        inp = replace(inp, adjust={**inp.adjust, "predictor": mine, "paper_predictor": False})
        n0 = len(calls)
        out[backend] = run_scenario(inp, duration_s=40, seed=2)
        assert len(calls) > n0  # the user's predictor made the decisions
    _same_run(out["python"], out["compiled"])


@needs_numba
@pytest.mark.parametrize("policy", ["adjust", "margin", "noise-aware"])
def test_compiled_paper_search_bit_identical(policy: str) -> None:
    """The paper predictor's speed search runs compiled on the compiled world (Test 2's
    predictor): the same decisions, the same name in the summary."""
    from rtsim.control.compiled import PaperSearch

    paper = {"adjust.predictor": "paper"}
    py = _run(
        "test2", "python", duration_s=150, seed=4, policy=policy, record_jobs=False, overrides=paper
    )
    co = _run(
        "test2",
        "compiled",
        duration_s=150,
        seed=4,
        policy=policy,
        record_jobs=False,
        overrides=paper,
    )
    _same_run(py, co)
    assert co.summary["predictor"] == "paper" and co.summary["critical_windows"] > 20
    rng = np.random.default_rng(8)
    from rtsim.analysis.kinematics import Thresholds
    from rtsim.control.adjust import largest as _largest
    from rtsim.control.predict import min_bound_rows, predict_msb_rows, trusted_estimate

    thr = Thresholds(25.0, 0.005, 0.025, math.radians(5))
    ps = PaperSearch()
    for _ in range(300):
        fols = [
            trusted_estimate(
                float(rng.uniform(200, 400)),
                float(rng.uniform(2.5, 3.8)),
                float(rng.normal(0, 0.3)),
                float(rng.uniform(0, 40)),
                325.0,
            )
            for _ in range(int(rng.integers(1, 4)))
        ]
        om, need = float(rng.normal(0, 0.2)), float(rng.uniform(100, 400))
        grid = [30.0 - 30.0 / 64 * i for i in range(64)] + [
            30.0 / 64 * 0.5**j for j in range(1, 21)
        ]

        def ok(v: float, fols: Any = fols, om: float = om, need: float = need) -> bool:
            rows = predict_msb_rows(fols, v, lambda f, _v: (f.v_f, f.theta, om), thr)
            return min_bound_rows(rows)[0] >= need

        a, b = _largest(ok, grid), ps.largest(fols, om, thr, need, grid)
        assert (a is None and b is None) or (a is not None and b is not None and a.hex() == b.hex())


@needs_numba
def test_remainder_kernel_is_the_interpreters() -> None:
    """The rollout's |Δβ| uses CPython's math.remainder, carried by the kernels (numba has
    none): random pairs over many exponents, exact ties (odd and even multiples), NaN."""
    from rtsim.world import kernels as K

    rem = K.kernels().remainder  # the compiled build (K._remainder stays the Python source)
    rng = np.random.default_rng(5)
    x = rng.standard_normal(20000) * 10.0 ** rng.integers(-8, 9, 20000)
    y = np.abs(rng.standard_normal(20000)) * 10.0 ** rng.integers(-4, 5, 20000) + 1e-300
    pairs = list(zip(x.tolist(), y.tolist(), strict=True))
    two_pi = 2.0 * math.pi
    pairs += [(d, two_pi) for d in rng.uniform(-2 * two_pi, 2 * two_pi, 5000).tolist()]
    pairs += [((k + 0.5) * 2.0, 2.0) for k in range(-6, 7)]  # ties: to the even multiple
    pairs += [(-0.0, two_pi), (0.0, two_pi), (math.pi, two_pi), (-math.pi, two_pi)]
    for a, b in pairs:
        assert rem(a, b).hex() == math.remainder(a, b).hex(), (a, b)
    assert math.isnan(rem(math.nan, two_pi))


def _twin_states(name: str, windows: int, seed: int) -> list[Any]:
    """The same decision state on a python and a compiled world (driven alike), each with its
    own law and group class, and random sends still pending."""
    rng = np.random.default_rng(seed)
    w = 237.0
    offs = (130.0, 136.0)
    pending = tuple((float(windows * w + rng.uniform(-20.0, 5.0)),) for _ in offs)
    out = []
    for backend in ("python", "compiled"):
        sc = load_scenario(name, overrides={"world.backend": backend})
        world = World(sc.world, np.random.default_rng(seed))
        for j in range(windows):
            world.estimate(world.scan(j * w))
            for i, off in enumerate(offs, start=1):
                world.command(i, j * w + off)
        t_d = (windows - 1) * w + 210.0
        world.advance(t_d)
        out.append(world_state(world, t_d, windows * w, offs, w, pending))
    return out


@needs_numba
@pytest.mark.parametrize(
    ("name", "windows", "seed"),
    [("test2", 12, 0), ("test2", 100, 1), ("test1", 60, 2), ("test2", 400, 3)],
)
def test_compiled_rollout_and_plan_search_bit_identical(name: str, windows: int, seed: int) -> None:
    """One decision's rollouts, whole (the leader's ramp, the events in Python's order, the
    changes) and the plan policy's speed search, compiled against the Python rollout: the
    same changes and the same speed, bit for bit, for random targets, horizons and
    margins (the margins make some searches bisect, others find nothing)."""
    from rtsim.control.adjust import search_rollout
    from rtsim.control.compiled_rollout import CompiledRollout
    from rtsim.control.predict import min_bound_rows
    from rtsim.control.rollout import Rollout

    st_py, st_co = _twin_states(name, windows, seed)
    py, co = Rollout(st_py), Rollout(st_co)
    assert py._compiled is None and isinstance(co._compiled, CompiledRollout)
    rng = np.random.default_rng(seed)
    for v in [0.0, -1.0, 1e9, *rng.uniform(0.0, 30.0, 6).tolist()]:
        for lengths in [(237.0,), (237.0, 237.0), tuple(rng.uniform(50.0, 900.0, 3).tolist())]:
            assert _bits(co.changes(v, lengths)) == _bits(py.changes(v, lengths)), (v, lengths)
    w = st_py.w_sch
    methods = set()
    for keep in (1.0, 0.6):
        for horizon in (1, 2, 3):

            def worst(v: float, horizon: int = horizon, keep: float = keep) -> float:
                per = py.changes(v, (w,) * horizon)
                return keep * min(min_bound_rows(py.bounds(c, w))[0] for c in per)

            # w_sch (as the policy asks), a need that the scan's 4th speed meets, and one
            # that no speed meets (the least-bad speed)
            co.changes(0.625 * st_py.v_ld, (w,) * horizon)  # as worst() does on py's memo
            for need in (w * (1.0 - 1e-9), worst(0.625 * st_py.v_ld), 1e12):
                ref = search_rollout(worst, st_py.v_ld, need, 3.0)
                got = co.search(st_co.v_ld, keep, need, 3.0, horizon, w)
                assert got is not None
                assert _bits(list(got)) == _bits(list(ref)), (keep, horizon, need)
                methods.add(ref[1])
                # its rollouts joined the memo, as the Python search's did
                assert set(co._memo) | set(co._raw) == set(py._memo)
                assert co.count == py.count
    assert methods == {"numeric", "best"}  # both ends of the search were compared
    for key in list(co._raw):  # a memoised search rollout reads back as the Python one
        assert _bits(co.changes(*key)) == _bits(py.changes(*key))
    assert (
        py.search(st_py.v_ld, 1.0, w, 3.0, 2, w) is None
    )  # the Python rollout has no compiled search


@needs_numba
def test_compiled_plan_decision_bit_identical() -> None:
    """The plan policy's whole decision in one compiled call against the Python policy on
    the Python rollout, at decisions along a lap, for horizons 1–3, margins and caps that
    take each branch (V_Ld kept with a longer first window, a search that bisects, one that
    finds nothing); the memo after it holds the same rollouts."""
    from rtsim.control.policy import PlanPolicy, PolicyInput
    from rtsim.control.rollout import Rollout

    seen = set()
    for seed, (name, windows) in enumerate(
        [(n, k) for n in ("test1", "test2") for k in (12, 40, 100, 130, 200, 260)]
    ):
        st_py, st_co = _twin_states(name, windows, seed)
        for horizon in (1, 2, 3):
            for margin, cap, floor in itertools.product(
                (0.0, 0.3, 0.8), (237.0, 400.0, 1000.0), (0.1, 0.0)
            ):
                pol = PlanPolicy(windows=horizon, margin=margin)
                out = []
                for st in (st_py, st_co):
                    ro = Rollout(st)
                    ctx = PolicyInput(
                        (), st.v_ld, st.w_sch, st.thresholds, cap=cap, floor_frac=floor, rollout=ro
                    )
                    out.append((pol.decide(ctx), ro))
                (d_py, ro_py), (d_co, ro_co) = out
                assert ro_co._compiled is not None and ro_py._compiled is None
                assert _bits(list(d_co)) == _bits(list(d_py)), (
                    windows,
                    horizon,
                    margin,
                    cap,
                    floor,
                )
                assert set(ro_co._memo) | set(ro_co._raw) == set(ro_py._memo)
                assert ro_co.count == ro_py.count
                seen.add((d_py.method, d_py.w > st.w_sch))
        # compiled only where the policy's V_Ld and w_sch are the rollout's (else Python)
        ro = Rollout(st_co)
        assert ro.plan(st_co.v_ld, 1.0, 1.0, 1000.0, 3.0, 1, st_co.w_sch) is not None
        assert ro.plan(st_co.v_ld, 1.0, 1.0, 1000.0, 3.0, 1, 60.0) is None
        assert ro.plan(st_co.v_ld / 2, 1.0, 1.0, 1000.0, 3.0, 1, st_co.w_sch) is None
    assert {("none", True), ("numeric", False), ("best", False)} <= seen, seen  # every branch


@needs_numba
def test_plan_decision_rolls_out_an_unsearched_speed_in_python(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """When the kernel's search did not roll its chosen speed out (it reports feasibility
    NaN: a zero floor kept as the least-bad speed), Rollout.plan rolls it out in Python:
    the decision stays the Python policy's."""
    from rtsim.control.compiled_rollout import CompiledRollout
    from rtsim.control.policy import PlanPolicy, PolicyInput
    from rtsim.control.rollout import Rollout

    real = CompiledRollout.decide

    def unsearched(self: Any, *a: Any) -> Any:
        out, ran = real(self, *a)
        if out[2] == 0.0:  # V_Ld kept: nothing searched
            return out, ran
        return [*out[:4], math.nan, *out[5:]], ran  # (the rows after the numbers kept)

    monkeypatch.setattr(CompiledRollout, "decide", unsearched)
    st_py, st_co = _twin_states("test2", 100, 1)
    searched = 0
    for margin in (0.0, 0.3, 0.8):
        pol = PlanPolicy(windows=2, margin=margin)
        d = [
            pol.decide(PolicyInput((), st.v_ld, st.w_sch, st.thresholds, rollout=Rollout(st)))
            for st in (st_py, st_co)
        ]
        assert _bits(list(d[1])) == _bits(list(d[0])), margin
        searched += d[0].method != "none"
    assert searched  # the fallback ran


@needs_numba
def test_compiled_plan_contact_bound_bit_identical() -> None:
    """The plan's contact bound (rtsim.world.contact) in the compiled decision against the
    Python policy: with d_c around the followers' predicted closest approach the bound
    binds in some decisions (the leader slows or the decision changes against the bound
    off) and the two backends agree bit for bit; the closest approach each rollout carries
    is the same float in both."""
    import dataclasses

    from rtsim.control.policy import PlanPolicy, PolicyInput
    from rtsim.control.rollout import Rollout

    changed = 0
    for seed, (name, windows) in enumerate([("test2", 40), ("test2", 130), ("test1", 100)]):
        st_py, st_co = _twin_states(name, windows, seed)
        near = min(Rollout(st_py).closest(st_py.v_ld))
        assert near == min(Rollout(st_co).closest(st_co.v_ld))
        for factor, horizon, margin in itertools.product(
            (0.9, 0.999, 1.0005, 1.01, 1.3), (1, 2), (0.0, 0.3)
        ):
            d_c = factor * near
            out = []
            for st in (st_py, st_co):
                ro = Rollout(dataclasses.replace(st, contact_cm=d_c))
                ctx = PolicyInput((), st.v_ld, st.w_sch, st.thresholds, cap=1000.0, rollout=ro)
                out.append(PlanPolicy(windows=horizon, margin=margin).decide(ctx))
            assert _bits(list(out[1])) == _bits(list(out[0])), (name, factor, horizon, margin)
            off = PlanPolicy(windows=horizon, margin=margin, contact=False).decide(
                PolicyInput(
                    (), st_py.v_ld, st_py.w_sch, st_py.thresholds, cap=1000.0,
                    rollout=Rollout(dataclasses.replace(st_py, contact_cm=d_c)),
                )
            )  # fmt: skip
            changed += list(off) != list(out[0])
            if factor < 0.99 and margin == 0.0:  # far from contact: the bound does nothing
                assert list(off) == list(out[0])
    assert changed  # the bound bound somewhere


@needs_numba
def test_a_failing_first_window_ends_the_rollout() -> None:
    """A pass/fail question (``need`` finite) ends a compiled rollout at its first window's
    closing scan when that window alone already fails; that window's changes are the whole
    rollout's bit for bit, and one that does not fail there is the whole rollout. The search
    that finds nothing rolls its stopped scanned speeds out again whole (counted), so its
    least-bad speed is the Python search's; a stopped rollout read from the memo later is
    rolled out whole on the decision's state, the Python rollout's numbers."""
    from rtsim.control.adjust import ROLLOUT_GRID, search_rollout
    from rtsim.control.compiled_rollout import _Rest
    from rtsim.control.predict import min_bound_rows
    from rtsim.control.rollout import Rollout, rollouts_run

    ended = kept = rested = 0
    for seed, (name, windows) in enumerate([("test2", 12), ("test2", 130), ("test1", 100)]):
        st_py, st_co = _twin_states(name, windows, seed)
        py, co = Rollout(st_py), Rollout(st_co)
        ker, pack = co._compiled._ker, co._compiled.pack()
        w = st_co.w_sch
        d_c = 0.98 * min(py.closest(st_py.v_ld))
        for v in np.linspace(0.0, st_co.v_ld, 9).tolist():
            for nw, keep, contact in itertools.product((2, 3), (1.0, 0.7), (0.0, d_c)):
                lengths = np.full(nw, w)
                whole = np.empty((nw, co._compiled.n, 5))
                assert ker.rollout_changes(v, lengths, pack, whole, 1.0, -math.inf, 0.0) == nw
                first = py.changes(v, (w,) * nw)[0]
                m0 = min_bound_rows(py.bounds(first, w))[0]
                m0 = py.contact([first], w, contact, m0)
                for need in (0.5 * w, w, 2.0 * w):
                    out = np.empty_like(whole)
                    done = ker.rollout_changes(v, lengths, pack, out, keep, need, contact)
                    if keep * m0 < need:  # fails in its first window: ends there
                        assert done == 1
                        assert _bits(out[0].tolist()) == _bits(whole[0].tolist())
                        ended += 1
                    else:
                        assert done == nw
                        assert _bits(out.tolist()) == _bits(whole.tolist())
                        kept += 1

        def worst(v: float, py: Any = py, w: float = w) -> float:
            per = py.changes(v, (w, w))
            return min(min_bound_rows(py.bounds(c, w))[0] for c in per)

        before = rollouts_run()
        got = co.search(st_co.v_ld, 1.0, 1e12, 3.0, 2, w)  # nothing passes: the least bad
        # the scan's speeds and the floor (GRID), and stopped ones again (counted)
        assert rollouts_run() - before > ROLLOUT_GRID
        assert got is not None and _bits(list(got)) == _bits(
            list(search_rollout(worst, st_py.v_ld, 1e12, 3.0))
        )
        for keep in (1.0, 0.8, 0.6):
            co2 = Rollout(st_co)
            co2.search(st_co.v_ld, keep, w * (1.0 - 1e-9), 3.0, 2, w)
            rest = [k for k, raw in co2._raw.items() if isinstance(raw, _Rest)]
            for key in rest:
                assert _bits(co2.changes(*key)) == _bits(py.changes(*key))
            rested += len(rest)
    assert ended and kept and rested


@needs_numba
def test_a_speed_whose_leader_is_an_earlier_ones_is_not_rolled_out_again() -> None:
    """A leader far below V_Ld reaches none of the scan's first speeds within the horizon,
    so their leaders (arc length and speed at every event) are the same bit for bit, and so
    are the rollouts: the compiled search copies the earlier one instead of rolling it out
    (fewer rollouts run than the Python search's), and the speed, the memo's keys and its
    numbers stay the Python search's."""
    import dataclasses

    from rtsim.control.adjust import search_rollout
    from rtsim.control.predict import min_bound_rows
    from rtsim.control.rollout import Rollout, rollouts_run

    copied = 0
    for seed, (name, windows) in enumerate([("test2", 130), ("test1", 100)]):
        pair = _twin_states(name, windows, seed)
        st_py, st_co = (dataclasses.replace(st, leader_speed=0.2 * st.v_ld) for st in pair)
        w = st_py.w_sch
        for at in (0.5, 0.375):  # a need met from the scan's 4th (5th) speed on, if monotone
            py, co = Rollout(st_py), Rollout(st_co)

            def worst(v: float, py: Any = py, w: float = w) -> float:
                per = py.changes(v, (w, w))
                return min(min_bound_rows(py.bounds(c, w))[0] for c in per)

            need = worst(at * st_py.v_ld)
            co.changes(at * st_py.v_ld, (w, w))  # as worst() does on py's memo
            before = rollouts_run()
            ref = search_rollout(worst, st_py.v_ld, need, 3.0)
            n_py = rollouts_run() - before
            got = co.search(st_co.v_ld, 1.0, need, 3.0, 2, w)
            n_co = rollouts_run() - before - n_py
            assert got is not None and _bits(list(got)) == _bits(list(ref)), (name, at)
            assert set(co._memo) | set(co._raw) == set(py._memo)
            assert co.count == py.count
            for key in list(co._raw):
                assert _bits(co.changes(*key)) == _bits(py.changes(*key))
            copied += n_py - n_co
    assert copied > 0
