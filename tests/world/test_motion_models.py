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


# -- the bounds: what reads the motion model (rtsim.analysis.kinematics) ---------------------


def test_the_rates_read_no_motion_model(turnlag: Any) -> None:
    """ρ̇ (Eq 17) and β̇ are the relative velocity of two points moving along their headings:
    a follower moved by the turn-lag model, whatever its lagging turn rate, changes ρ and β
    over 1 ms at the rates the formulas give from (V_L, V_F, β, θ) alone (a first-order
    difference: within 1e-3 of the rate's scale)."""
    from rtsim.analysis.kinematics import beta_dot, relative_state, rho_dot
    from rtsim.world.motion import arc

    dt, v_l, v_f = 1e-3, 30.0, 25.0
    leader = (0.0, 0.0, 0.2)
    for w_lag in (-1.0, 0.0, 0.7):  # the follower's actual turn rate, its command 0.3 rad/s
        for pose in ((-80.0, -20.0, 0.5), (-60.0, 45.0, -0.3)):
            rho, beta, theta = relative_state(leader, pose)
            x, y, th, _, _, _ = turnlag.lag_step(*pose, v_f, w_lag, v_f, 0.3, 100.0, dt)
            lead = arc(*leader, v_l, 0.0, dt)
            rho1, beta1, _ = relative_state(lead, (x, y, th))
            assert (rho1 - rho) / dt == pytest.approx(rho_dot(v_l, v_f, beta, theta), abs=0.05)
            got = math.remainder(beta1 - beta, 2 * math.pi) / dt
            assert got == pytest.approx(beta_dot(v_l, v_f, beta, theta, rho, 0.0), abs=1e-3)


def test_a_lag_turns_no_further_on_a_turn_error_than_the_unicycle(turnlag: Any) -> None:
    """The one bound quantity a model supplies, its turn error: the turn-lag keeps the
    unicycle's (σ_θ = σ_ω·t), and rightly — a lag's turn-rate error averages the commands'
    errors, so random histories of command errors (σ_ω each, a new command every 50–300 ms)
    turn it less, and one error held from long before the window turns it exactly as far."""
    from rtsim.analysis.kinematics import unicycle_turn_error

    assert turnlag.TURN_LAG.turn_error is unicycle_turn_error
    rng = np.random.default_rng(7)
    sd, t_win = 0.3, 0.4

    def drift(w0: float, pieces: list[tuple[float, float]]) -> float:
        th, w = 0.0, w0
        for wc, dt in pieces:
            _, _, th, _, w, _ = turnlag.lag_step(0.0, 0.0, th, 30.0, w, 30.0, wc, 100.0, dt)
        return th

    errors = []
    for _ in range(3000):
        # two seconds of commands before the window opens: the turn-rate error it carries in
        w0, t = 0.0, -2.0
        while True:
            dt = rng.uniform(0.05, 0.3)
            wc = rng.normal(0.0, sd)
            if t + dt >= 0.0:
                break
            _, _, _, _, w0, _ = turnlag.lag_step(0.0, 0.0, 0.0, 30.0, w0, 30.0, wc, 100.0, dt)
            t += dt
        if t < 0.0:  # the command held when the window opens
            _, _, _, _, w0, _ = turnlag.lag_step(0.0, 0.0, 0.0, 30.0, w0, 30.0, wc, 100.0, -t)
        pieces = [(wc, min(t + dt, t_win))]  # ... held on, then new commands
        t += dt
        while t < t_win:
            dt = min(rng.uniform(0.05, 0.3), t_win - t)
            pieces.append((rng.normal(0.0, sd), dt))
            t += dt
        errors.append(drift(w0, pieces))
    assert float(np.std(errors)) < 0.8 * unicycle_turn_error(sd, t_win)[0]
    held = drift(sd, [(sd, t_win)])  # one error held since long before: the unicycle's
    assert held == pytest.approx(unicycle_turn_error(sd, t_win)[0], rel=1e-12)


def test_the_bounds_read_a_models_turn_error(turnlag: Any) -> None:
    """A model whose turn error is twice the unicycle's (a turn actuator with twice the
    command's error) gets the predicted-centre bound and the noise-aware padding of a
    unicycle with twice the turn noise: through the scenario's thresholds and through
    PolicyInput. The bound's bisection, given the unicycle's own error, is its closed form."""
    from rtsim.analysis.kinematics import (
        Thresholds,
        msb_localization_predicted,
        unicycle_turn_error,
    )
    from rtsim.control.policy import PolicyInput, pad_rows
    from rtsim.control.predict import FollowerEstimate

    def doubled(sd: float, t: float) -> tuple[float, float]:
        return unicycle_turn_error(2.0 * sd, t)

    kw = {"fix_sd": 1.0, "heading_sd": 0.03, "speed_sd": 0.5, "turn_sd": 0.2, "v_max": 60.0}
    closed = msb_localization_predicted(25.0, **kw)
    assert msb_localization_predicted(
        25.0, **kw, turn_error=lambda s, t: unicycle_turn_error(s, t)
    ) == pytest.approx(closed, rel=1e-10)
    twice = msb_localization_predicted(25.0, **{**kw, "turn_sd": 0.4})
    assert twice < closed
    assert msb_localization_predicted(25.0, **kw, turn_error=doubled) == pytest.approx(
        twice, rel=1e-10
    )
    MOTION_MODELS.register("wobbly", replace(turnlag.TURN_LAG, name="wobbly", turn_error=doubled))
    try:
        thr = {
            m: load_scenario("test1", overrides={"follower.motion_model": m}).world.thresholds
            for m in ("unicycle", "turn-lag", "wobbly")
        }
        sd = load_scenario("test1").world.follower.turn_noise
        over = {"follower.turn_noise_deg": math.degrees(2.0 * sd)}
        loud = load_scenario("test1", overrides=over)
    finally:
        del MOTION_MODELS["wobbly"]
    assert thr["turn-lag"].predicted_ms == thr["unicycle"].predicted_ms  # (its error: the same)
    assert thr["wobbly"].predicted_ms == pytest.approx(loud.world.thresholds.predicted_ms, rel=1e-9)
    assert thr["wobbly"].predicted_ms < thr["unicycle"].predicted_ms
    f = FollowerEstimate(rho=100.0, beta=math.pi, theta=0.05, v_f=30.0, rho_d=100.0)
    t = Thresholds(25.0, 0.01, 0.025, 0.1)
    base = {"followers": [f], "v_ld": 30.0, "w_sch": 250.0, "thresholds": t}
    rows = [(1000.0, 800.0, 600.0, 900.0)]
    noise = {"speed_noise": 0.5, "pose_sd": ((1.0, 0.02),)}
    padded = {
        name: pad_rows(rows, [f], PolicyInput(**base, **noise, **extra), 30.0, 2.0)[0]  # type: ignore[arg-type]
        for name, extra in (
            ("uni", {"turn_noise": 0.2}),
            ("wobbly", {"turn_noise": 0.2, "turn_error": doubled}),
            ("loud", {"turn_noise": 0.4}),
        )
    }
    assert padded["wobbly"] == pytest.approx(padded["loud"], rel=1e-12)
    assert padded["wobbly"][1] < padded["uni"][1]


def test_the_predicted_bound_holds_in_a_turn_lag_run(turnlag: Any) -> None:
    """Never optimistic: a turn-lag world (test1, turn noise 20°/s) scanned every
    predicted-centre bound's worth of ms (362 ms) for 30 s keeps every follower within r_H
    of its predicted window centre at every scan (18.9 cm at most, measured; the unicycle's
    18.7 cm)."""
    over = {"follower.motion_model": "turn-lag", "follower.turn_noise_deg": 20.0}
    cfg = load_scenario("test1", overrides={**over, "world.backend": "python"}).world
    w = cfg.thresholds.predicted_ms
    assert cfg.localization.centre == "predicted" and 300.0 < w < 400.0
    world = World(cfg, np.random.default_rng(3))
    worst = 0.0
    for j in range(int(30000 / w)):
        scan = world.scan(j * w)
        if j:
            for (tx, ty), (cx, cy) in zip(scan.truth, scan.centre, strict=True):
                worst = max(worst, math.hypot(tx - cx, ty - cy))
        world.estimate(scan)
        for i in range(1, world.n + 1):
            world.command(i, j * w + 130.0 + 3 * i)
    assert 10.0 < worst <= cfg.thresholds.r_H, worst


@pytest.mark.skipif(not compiled.available(), reason="numba is not importable")
def test_the_compiled_estimates_carry_the_turn_lag_bit_for_bit(turnlag: Any) -> None:
    """The compiled world's estimates (one array, `rtsim.world.estimates`' kernels built with
    the model's parts) give the Python world's filters, beliefs and expected turn rates bit
    for bit on a turn-lag world with its noise."""
    seen = []
    for backend in ("python", "compiled"):
        over = {"follower.motion_model": "turn-lag", "world.backend": backend}
        world = World(load_scenario("test2", overrides=over).world, np.random.default_rng(4))
        out = []
        for j in range(40):
            t = j * 237.0
            world.estimate(world.scan(t))
            for i, off in enumerate((130.0, 136.0), start=1):
                world.command(i, t + off)
            t_d = t + 210.0
            world.advance(t_d)
            out.append(
                [
                    [f.pose for f in world.filters],
                    [f.P.ravel().tolist() for f in world.filters],
                    world.estimates_at(t_d),
                    world.expected_turn_rates(t_d),
                    world.estimate_rows(t_d),
                ]
            )
        seen.append(repr(out))
    assert seen[0] == seen[1]
