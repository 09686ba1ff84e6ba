"""Motion models as plug-ins (rtsim.world.motionmodels): a model is refused unless it has
every part, and the how-to's turn-lag model (docs/howto/motion-model.md, imported from the
page itself) reaches every consumer — the world on both backends, the leader's belief, the
EKF and the controller's rollout — checked against the closed form of a first-order lag
and against the world it predicts."""

from __future__ import annotations

import importlib
import math
import re
import sys
from dataclasses import replace
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest
from rollout_states import world_state

from rtsim.config.scenario import load_scenario
from rtsim.control.rollout import Rollout
from rtsim.errors import InputError, ScenarioError
from rtsim.world import World, compiled
from rtsim.world.ekf import EkfParams, FastFollowerEKF, FollowerEKF
from rtsim.world.follower import FollowerGroup, FollowerParams
from rtsim.world.jit import kernel
from rtsim.world.motionmodels import MOTION_MODELS, UNICYCLE, MotionModel

PAGE = Path(__file__).resolve().parents[2] / "docs" / "howto" / "motion-model.md"
needs_numba = pytest.mark.skipif(not compiled.available(), reason="numba is not importable")


@pytest.fixture(scope="module")
def turnlag(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """The how-to's ``turnlag.py``, written from the page and imported; registered as
    ``turn-lag`` while the module's tests run."""
    code = next(
        b for b in re.findall(r"```python\n(.*?)\n```", PAGE.read_text("utf-8"), re.S)
        if b.startswith("# turnlag.py")
    )  # fmt: skip
    d = tmp_path_factory.mktemp("howto")
    (d / "turnlag.py").write_text(code, encoding="utf-8")
    sys.path.insert(0, str(d))
    try:
        mod: ModuleType = importlib.import_module("turnlag")
    finally:
        sys.path.remove(str(d))
    MOTION_MODELS.register("turn-lag", mod.TURN_LAG)
    yield mod
    del MOTION_MODELS["turn-lag"]
    sys.modules.pop("turnlag", None)


def _lag(w0: float, wc: float, dt: float, tau: float) -> tuple[float, float]:
    """ω(dt) and ∫ω over dt of ω̇ = (ω_c − ω)/τ from ω(0) = w0 (independent closed form)."""
    return wc + (w0 - wc) * math.exp(-dt / tau), wc * dt + (w0 - wc) * tau * (
        1.0 - math.exp(-dt / tau)
    )


# -- a model cannot be half-wired -----------------------------------------------------------


@kernel
def _three(a: float, b: float, c: float) -> float:
    return a + b + c


def test_a_model_needs_every_part() -> None:
    parts = {p: getattr(UNICYCLE, p) for p in ("advance", "step", "process", "leader")}
    for missing in parts:
        given = {k: v for k, v in parts.items() if k != missing}
        with pytest.raises(InputError, match=rf"'half': {missing} \(.*\) is missing"):
            MotionModel("half", **given)
    with pytest.raises(InputError, match="step .* not a kernel source"):
        MotionModel("plain", **{**parts, "step": lambda *a: a})
    with pytest.raises(InputError, match="leader .* takes 3 arguments, not 5"):
        MotionModel("short", **{**parts, "leader": _three})
    with pytest.raises(InputError, match="not a MotionModel"):
        MOTION_MODELS.register("bad", parts)  # type: ignore[arg-type]
    with pytest.raises(ScenarioError, match="follower.motion_model: .*did you mean 'unicycle'"):
        FollowerParams(motion_model="unicycel")
    assert UNICYCLE.subs == ()


# -- the turn-lag model reaches every consumer -------------------------------------------------


def test_turn_lag_step_and_ekf_follow_the_closed_form(turnlag: Any) -> None:
    """The belief's step and the EKF (fast, filterpy and compiled) carry the lag: heading
    and turn rate after a held command as the closed form; the unicycle's do not turn."""
    tau = turnlag.TAU
    w0, wc, dt = 0.5, -0.2, 0.3
    w1, dth = _lag(w0, wc, dt, tau)
    _, _, th, _, w, _ = turnlag.lag_step(0.0, 0.0, 0.1, 30.0, w0, 30.0, wc, 100.0, dt)
    assert (th - 0.1, w) == pytest.approx((dth, w1), abs=1e-12)
    params = EkfParams()
    filters = [FastFollowerEKF((1.0, 2.0, 0.1), params, turnlag.TURN_LAG)]
    filters.append(FollowerEKF((1.0, 2.0, 0.1), params, turnlag.TURN_LAG))
    if compiled.available():
        filters.append(compiled.CompiledFollowerEKF((1.0, 2.0, 0.1), params, turnlag.TURN_LAG))
    uni = FastFollowerEKF((1.0, 2.0, 0.1), params)
    assert uni.predict_command(30.0, w0, 30.0, wc, 100.0, dt) == (30.0, wc)
    assert uni.pose[2] == pytest.approx(0.1 + wc * dt)
    for f in filters:
        assert f.predict_command(30.0, w0, 30.0, wc, 100.0, dt) == pytest.approx((30.0, w1))
        assert f.pose[2] - 0.1 == pytest.approx(dth, abs=1e-12)
        assert f.P == pytest.approx(filters[0].P, abs=1e-9)
    if compiled.available():  # the compiled predict is the Python one, bit for bit
        assert filters[2].pose == filters[0].pose and filters[2].P.tolist() == filters[0].P.tolist()


def test_turn_lag_truth_follows_the_closed_form(turnlag: Any) -> None:
    """The world's followers (both backends) integrate the lag: the heading after 400 ms
    holding ω_c from ω0 is the closed form (a constant speed: the arcs of the substeps
    add the exact heading change)."""
    p = FollowerParams(motion_model="turn-lag")
    groups = [FollowerGroup([0.0], [0.0], [0.3], [40.0], p)]
    if compiled.available():
        groups.append(compiled.CompiledFollowerGroup([0.0], [0.0], [0.3], [40.0], p))
    w1, dth = _lag(0.6, 0.1, 0.4, turnlag.TAU)
    for g in groups:
        g.w, g.cmd_v, g.cmd_w = [0.6], [40.0], [0.1]
        g.advance(0, 400.0, 10.0)
        assert (g.th[0] - 0.3, g.w[0]) == pytest.approx((dth, w1), abs=1e-12)
        assert g.odometer[0] == pytest.approx(16.0)
    assert [g.x for g in groups[1:]] == [groups[0].x] * (len(groups) - 1)


def _run(model: str, backend: str) -> Any:
    from rtsim.coupling import run_scenario

    over = {"follower.motion_model": model, "world.backend": backend}
    return run_scenario("test1", overrides=over, duration_s=30, seed=2, record_jobs=False)


@needs_numba
def test_turn_lag_runs_the_same_on_both_backends(turnlag: Any) -> None:
    """A coupled run on the rollout (test1's plan policy): the compiled world, EKF and
    rollout with the model's parts give the Python run bit for bit, and not the unicycle's."""
    py, co = _run("turn-lag", "python"), _run("turn-lag", "compiled")
    assert py.windows.equals(co.windows)
    assert (py.windows["method"] == "numeric").any()  # the rollout's search decided
    uni = _run("unicycle", "python")
    assert not uni.windows["f1_heading"].equals(py.windows["f1_heading"])


QUIET = {
    "follower.speed_noise": 0.0,
    "follower.turn_noise_deg": 0.0,
    "sensing.position_noise": 0.0,
    "localization.model": "gaussian",
    "ekf.init_position_sd": 0.0,
    "ekf.init_heading_sd_deg": 0.0,
}


@pytest.mark.parametrize("backend", ["python", "compiled"])
def test_the_rollout_predicts_the_turn_lag_world(turnlag: Any, backend: str) -> None:
    """A noise-free turn-lag world (test2, follower 1 entering its first turn, its turn
    rate still lagging the command), decided at 210 ms into a window: the rollout on the
    turn-lag model predicts the displacements the world then shows (within 1e-4 cm,
    measured; as tests/control/test_rollout.py for the unicycle), the same state rolled out
    as a unicycle misses them by 0.07 cm. The compiled world rolls out compiled."""
    if backend == "compiled" and not compiled.available():
        pytest.skip("numba is not importable")
    over = {**QUIET, "follower.motion_model": "turn-lag", "world.backend": backend}
    world = World(load_scenario("test2", overrides=over).world, np.random.default_rng(1))
    w, offsets, windows = 237.0, (130.0, 136.0), 107
    for j in range(windows):
        t = j * w
        world.estimate(world.scan(t))
        for i, off in enumerate(offsets, start=1):
            world.command(i, t + off)
    t_d = (windows - 1) * w + 210.0
    world.advance(t_d)
    state = replace(
        world_state(world, t_d, windows * w, offsets, w), turns=tuple(world.followers.w)
    )
    assert state.turns != tuple(world.followers.cmd_w)  # the lag is under way
    # the leader's belief carries it too (exact fixes: its estimate is the truth)
    assert world.expected_turn_rates(t_d) == pytest.approx(state.turns, abs=1e-9)
    ro = Rollout(state)
    assert (ro._compiled is not None) == (backend == "compiled")
    lagged = ro.changes(30.0, [w, w])
    flat = Rollout(replace(state, params=replace(state.params, motion_model="unicycle")))
    straight = flat.changes(30.0, [w, w])
    seen = []
    for j in range(windows, windows + 3):
        scan = world.scan(j * w)
        seen.append(scan.changes["displacement"])
        world.estimate(scan)
        for i, off in enumerate(offsets, start=1):
            world.command(i, j * w + off)
    err = [max(abs(p[k][0] - seen[j + 1][k]) for j, p in enumerate(pred) for k in range(2))
           for pred in (lagged, straight)]  # fmt: skip
    assert err[0] < 0.01 < err[1], err


# -- the substitution that builds a kernel for a model (rtsim.world.jit) ----------------------


@kernel
def _double(x: float) -> float:
    return 2.0 * x


@kernel
def _triple(x: float) -> float:
    return 3.0 * x


@kernel
def _caller(x: float) -> float:
    return _double(x) + 1.0


@kernel
def _outer(x: float) -> float:
    return _caller(x) * 10.0


def test_a_substitution_reaches_through_the_callers() -> None:
    """`specialise` (Python) and `build` (compiled) with (callee, replacement): every kernel
    on the way calls the replacement; the sources stay as they are; the source key moves
    only for kernels that reach the callee."""
    from rtsim.world import jit

    subs = ((_double, _triple),)
    assert jit.specialise(_outer, subs)(2.0) == 70.0 and _outer(2.0) == 50.0
    assert jit.specialise(_triple, subs) is _triple  # (nothing to replace)
    assert jit.source_key(_outer, subs) != jit.source_key(_outer)
    assert jit.source_key(_triple, subs) == jit.source_key(_triple)
    if compiled.available():
        assert jit.build(_outer, subs)(2.0) == 70.0 and jit.build(_outer)(2.0) == 50.0
        assert jit.build(_triple, subs) is jit.build(_triple)  # shared
