"""Follow-the-leader followers and the leader's speed ramps (issue 15 items 1, 2; SPEC §6).

Tolerances are stated where they are used; the numbers they bound were measured on seed 0
and hold with a margin of about 2x.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from rtsim.analysis.kinematics import beta_dot, relative_state, rho_dot
from rtsim.config.scenario import load_scenario
from rtsim.errors import ScenarioError
from rtsim.world import World, ftl, kernels
from rtsim.world.formation import in_line
from rtsim.world.laser import count_beams
from rtsim.world.leader import Leader
from rtsim.world.path import rounded_rectangle

#: Window chain offsets of the paper's set (ms): scan 106, Hough ≈ 10 for n = 2, then per
#: follower estimate + send = 3 (the order the coupling commands in).
SEND0, SEND_STEP = 116.0, 3.0


def _drive(world: World, windows: int, w: float) -> Iterator[dict]:
    """Fixed windows of ``w`` ms: scan, estimate, command each follower; yields one record
    per window, with the world at its last command."""
    for j in range(windows):
        t = j * w
        scan = world.scan(t)
        world.estimate(scan)
        for i in range(1, world.n + 1):
            world.command(i, t + SEND0 + i * SEND_STEP)
        yield {"t": t, "scan": scan, "s_l": world.leader.s}


# -- the leader's speed ramps ----------------------------------------------------------
def test_leader_ramp_by_hand() -> None:
    path = rounded_rectangle(800, 400, 200)
    ld = Leader(path, 30.0, accel_max=20.0, decel_max=50.0)
    ld.set_speed(10.0)  # 30 -> 10 at 50 cm/s²: 0.4 s, 8 cm
    assert ld.speed == 30.0 and ld.target_speed == 10.0
    ld.advance(0.1)
    assert ld.speed == pytest.approx(25.0) and ld.s == pytest.approx(2.75)
    ld.advance(1.0)  # 0.3 s more of ramp (5.25 cm), then 0.7 s at 10
    assert ld.speed == 10.0 and ld.s == pytest.approx(2.75 + 5.25 + 7.0)
    ld.set_speed(30.0)  # 10 -> 30 at 20 cm/s²: 1 s, 20 cm
    assert ld.speed_after(0.5) == pytest.approx(20.0)
    ld.advance(2.0)
    assert ld.speed == 30.0 and ld.s == pytest.approx(15.0 + 20.0 + 30.0)
    # infinite limits: the paper's step
    inst = Leader(path, 30.0)
    inst.set_speed(12.0)
    assert inst.speed == 12.0


def test_leader_limits_are_validated() -> None:
    with pytest.raises(ScenarioError, match=r"leader.decel_max: must be positive"):
        load_scenario("test1", overrides={"leader.decel_max": 0})
    with pytest.raises(
        ScenarioError,
        match=r"leader: unknown key 'accel' \(did you mean "
        r"'accel_max'\?\)",
    ):
        load_scenario("test1", overrides={"leader.accel": 10})


def test_leader_speed_never_changes_faster_than_its_limits_in_adjust(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """Every integration step of a coupled Test 2 run: |ΔV_L| ≤ a·Δt (a: accel or decel)."""
    from rtsim.coupling import run_scenario

    steps: list[tuple[float, float, float]] = []
    orig = Leader.advance

    def advance(self: Leader, dt: float) -> None:
        v0 = self.speed
        orig(self, dt)
        steps.append((dt, v0, self.speed))

    def observed(world: World, fn: Any, *args: Any) -> Any:
        # (the compiled world drives the leader inside its kernels, not by Leader.advance)
        v0, t0 = world.leader.speed, world.t_ms
        out = fn(*args)
        if world.t_ms > t0:
            steps.append(((world.t_ms - t0) / 1000.0, v0, world.leader.speed))
        return out

    world_advance, sender = World.advance, World.sender

    def send_of(self: World) -> Any:
        send = sender(self)
        return None if send is None else lambda k, t: observed(self, send, k, t)

    monkeypatch.setattr(Leader, "advance", advance)
    monkeypatch.setattr(World, "advance", lambda w, t: observed(w, world_advance, w, t))
    monkeypatch.setattr(World, "sender", send_of)
    res = run_scenario("test2", policy="adjust", duration_s=60, record_jobs=False)
    cfg = res.inputs.world
    arr = np.array(steps)
    dv = arr[:, 2] - arr[:, 1]
    assert (dv <= cfg.leader_accel_max * arr[:, 0] + 1e-9).all()
    assert (-dv <= cfg.leader_decel_max * arr[:, 0] + 1e-9).all()
    # the adjustment did slow the leader and let it speed up again (the ramps were used)
    assert arr[:, 2].min() < 0.8 * cfg.leader_speed and (dv > 0).sum() > 10
    s = res.summary
    assert s["leader_accel_max"] == cfg.leader_accel_max == 20.0
    assert s["leader_decel_max"] == cfg.leader_decel_max == 50.0
    assert s["formation_model"] == "follow-the-leader"


# -- follow-the-leader -----------------------------------------------------------------
@pytest.mark.parametrize("name", ["test1", "test2"])
def test_paper_tests_use_follow_the_leader(name: str) -> None:
    sc = load_scenario(name)
    assert sc.world.formation.model == "follow-the-leader"
    assert math.isfinite(sc.world.leader_accel_max) and math.isfinite(sc.world.leader_decel_max)
    for key in ("formation.model", "leader.accel_max", "leader.decel_max"):
        assert key in sc.assumptions


def test_formation_model_typo_is_an_error_with_a_hint() -> None:
    with pytest.raises(
        ScenarioError,
        match=r"test1.toml: formation.model: must be one of "
        r"follow-the-leader, l-psi or 'package\.module:Name', "
        r"got 'follow-the-lead' "
        r"\(did you mean 'follow-the-leader'\?\)",
    ):
        load_scenario("test1", overrides={"formation.model": "follow-the-lead"})


@pytest.mark.parametrize("sep", [325, 390])
@pytest.mark.parametrize("n", [1, 2, 3, 4, 7, 10])
def test_line_keeps_every_follower_visible_on_straights(n: int, sep: float) -> None:
    f = in_line(n, sep)
    assert f.model == "follow-the-leader"
    assert f.rho_d == tuple(sep * ((i + 1) // 2) for i in range(1, n + 1))
    beams = count_beams(f.xy(), 25.0)
    for rho, count in zip(f.rho_d, beams, strict=True):
        half = math.degrees(math.asin(25 / rho))
        assert count >= math.floor(2 * half / 0.5) - 1, (n, rho, count)
    # lateral offsets stay within about 1.5 m of the trace (the chevron needs up to 10 m)
    assert max(abs(o) for o in f.lateral) < 160
    if n <= 6:  # the paper's 180 ± 15 deg for the first rank
        assert abs(f.lateral[0]) == pytest.approx(sep * math.sin(math.radians(15)))


def _trace_error(world: World, k: int) -> tuple[float, str]:
    """Signed distance of follower index k from its offset trace, and the kind of the trace
    segment it is beside: the nearest of the path's points sampled every 0.5 cm within 1 m of
    the controller's last projection (read only), recomputed from the path's geometry."""
    ftl = world._ftl
    assert ftl is not None
    path = world.config.path
    x, y = world.followers.x[k], world.followers.y[k]
    o = ftl.lateral[k]
    centre = ftl._s_f[k] or 0.0
    best = (math.inf, 0.0)
    for s in np.arange(centre - 100.0, centre + 100.0, 0.5):
        px, py, h = path.pose(float(s))
        d = math.hypot(x - (px - o * math.sin(h)), y - (py + o * math.cos(h)))
        if d < best[0]:
            best = (d, float(s))
    px, py, h = path.pose(best[1])
    lat = -(x - px) * math.sin(h) + (y - py) * math.cos(h)
    return lat - o, path.segment_at(best[1])[0]


@pytest.mark.parametrize("name", ["test1", "test2"])
def test_on_straights_followers_hold_the_line_and_the_separation(name: str) -> None:
    """Windows of w_sch (237.4 ms): on straights, 2 s after the follower left a turn, it is
    within 3 cm of the leader's line plus its offset (measured 1.25 and 1.41 cm); in steady
    state (leader and follower 6 s, three time constants 1/k_ρ, past their turns) its
    separation is within 4 cm of ρ_d (measured 1.29 and 2.69 cm; T_ρ·ρ_d is 3.9 and
    3.25 cm); anywhere, turns included, within 8 cm (measured 1.3 and 5.1 cm: Test 2's
    inner follower, 36 cm from the turn's centre, arrives early and closes up by 5 cm,
    recovered at k_ρ = 0.5/s). Measured maxima are printed by ``-s``."""
    sc = load_scenario(name)
    world = World(sc.world, np.random.default_rng(0))
    rho_d = sc.world.formation.rho_d
    lat_err, sep_straight, sep_all = [], [], []
    last_turn = [-1e9] * world.n
    leader_turn = -1e9
    drive_s = {"test1": 200, "test2": 140}[name]  # the files' durations before until = "lap"
    for rec in _drive(world, int(drive_s * 1000 / 237.4), 237.4):
        scan, t = rec["scan"], rec["t"]
        if world.segment_at()[0] == "turn":
            leader_turn = t
        for k in range(world.n):
            err, kind = _trace_error(world, k)
            rho = math.hypot(*scan.truth[k])
            if kind == "turn":
                last_turn[k] = t
            if t > 5000:
                sep_all.append(abs(rho - rho_d[k]))
            if kind == "straight" and t - last_turn[k] > 2000 and t > 5000:
                lat_err.append(abs(err))
                if min(t - leader_turn, t - last_turn[k]) > 6000:  # steady state
                    sep_straight.append(abs(rho - rho_d[k]))
        assert not scan.lost.any()
    print(name, "lateral", max(lat_err), "sep steady", max(sep_straight), "sep all", max(sep_all))
    assert len(lat_err) > 300 and len(sep_straight) > 100
    assert max(lat_err) < 3.0
    assert max(sep_straight) < 4.0
    assert max(sep_all) < 8.0


def test_rho_dot_beta_dot_match_finite_differences_of_the_ftl_world() -> None:
    """Eq 17 and β̇ (SPEC §4) against central differences of the follow-the-leader world,
    through Test 2's first turn with a ramping leader."""
    sc = load_scenario("test2")
    world = World(dataclasses.replace(sc.world, start_s=500.0), np.random.default_rng(3))
    t, h, checked = 0.0, 0.5, 0
    for window in range(100):
        scan = world.scan(t)
        world.estimate(scan)
        for i in (1, 2):
            world.command(i, t + SEND0 + i * SEND_STEP)
        if window % 10 == 5:
            world.set_leader_speed(12.0 if window % 20 == 5 else 30.0, t + 130.0)
        for probe in (140.0, 200.0):
            tm = t + probe
            samples = []
            for tt in (tm - h, tm, tm + h):
                world.advance(tt)
                fol = world.followers
                samples.append(
                    [(world.leader.pose, fol.pose(k), fol.v[k]) for k in range(2)]
                    + [(world.leader.speed, world.leader.omega)]
                )
            v_l, w_l = samples[1][2]
            for k in range(2):
                (lp0, fp0, _), (lp1, fp1, vf), (lp2, fp2, _) = (s[k] for s in samples)
                if abs(samples[0][k][2] - samples[2][k][2]) > 1e-12:
                    continue  # a follower's speed ramp: the rates are not constant
                if abs(samples[0][2][0] - samples[2][2][0]) > 1e-12:
                    continue  # the leader's ramp
                r0, b0, _ = relative_state(lp0, fp0)
                r1, b1, th1 = relative_state(lp1, fp1)
                r2, b2, _ = relative_state(lp2, fp2)
                fd_rho = (r2 - r0) / (2 * h / 1000)
                fd_beta = math.remainder(b2 - b0, 2 * math.pi) / (2 * h / 1000)
                assert rho_dot(v_l, vf, b1, th1) == pytest.approx(fd_rho, abs=1e-4)
                assert beta_dot(v_l, vf, b1, th1, r1, w_l) == pytest.approx(fd_beta, abs=1e-6)
                checked += 1
        t += 240.0
    assert checked > 150


@pytest.mark.parametrize("n", range(1, 11))
def test_test1_geometry_every_lost_track_is_the_sensor_or_the_localization_bound(n: int) -> None:
    """n = 1..10 in Test 1's geometry (its file, n followers in line), fixed windows of w_sch(n)
    at V_Ld (as validate's counted-beams runs): no track is lost while the follower returns at
    least min_points beams *and* moved less than r_H − 3 cm in the leader's frame since the
    previous scan. Lost tracks with too few beams are the sensor's limit (hidden behind a
    nearer follower in a turn, or out of the laser's view); lost tracks with enough beams are
    followers far behind the turning leader that swept more than r_H in its frame
    (ρ·ω_L·w ≈ 24 cm at ρ = 780 cm, w = 250 ms): the localization bound broken at a fixed
    window, not a tracking fault. Measured (250 windows, seed 0; printed by ``-s``): none at
    n ≤ 2; n = 3: 45 sensor-limited (all hidden in turns) + 2 moved; n = 10: 896 (758 of them
    ahead of the leader's axis, outside the laser's half-plane: a 20 m line wraps around the
    4 m wide rectangle) + 231 moved."""
    from rtsim.analysis.bounds import window_bounds

    # the line as it was measured: no clearance (ten followers do not fit 15 cm), the start
    # as given
    sc = load_scenario(
        "test1",
        overrides={
            "formation.followers": n,
            "formation.clearance": 0,
            "leader.start_on": "given",
        },
    )
    ts = sc.load_taskset()
    assert ts.window is not None
    w = window_bounds(ts).w_sch
    world = World(sc.world, np.random.default_rng(0))
    r_H, min_points = sc.world.thresholds.r_H, sc.world.sensing.min_points
    sensor = moved = confused = 0
    for rec in _drive(world, 250, w):
        scan = rec["scan"]
        disp = scan.changes["displacement"]
        for k in np.flatnonzero(scan.lost):
            if scan.points[k] < min_points:
                sensor += 1
            elif scan.cause[k] == "neighbour":  # (the hough model: a neighbour's points)
                confused += 1
            else:
                assert disp[k] > r_H - 3.0, (rec["t"], k + 1, disp[k])
                moved += 1
    print(f"n={n}: lost {sensor} (sensor's limit) + {moved} (moved > r_H) + {confused} (neighbour)")
    if n <= 2:
        assert sensor == moved == confused == 0


def test_the_python_law_runs_the_kernel_sources() -> None:
    """One source per equation (issue 31): the Python law's reference, command, projection
    and point are the kernel sources' code (their twins differ only in the hypot and the
    segment lookup they call), and the compiled entries are built from the same functions."""
    twins = {
        ftl._PY_REFERENCE: ftl.ftl_reference,
        ftl._PY_COMMAND: ftl.ftl_command,
        ftl._PY_PROJECT: ftl.ftl_project,
        ftl._PY_POINT: ftl.trace_point,
    }
    for twin, source in twins.items():
        assert twin.__code__ is source.__code__
    law = ftl.TraceFollower(rounded_rectangle(800, 400, 120), [325.0], [0.0], 0.5, 40.0)
    assert (law._reference, law._command, law._project) == (
        ftl._PY_REFERENCE,
        ftl._PY_COMMAND,
        ftl._PY_PROJECT,
    )
    built = {**kernels.ENTRIES, **kernels.LAZY_ENTRIES}  # (the command: at its first call)
    for name in ("ftl_command", "ftl_reference", "ftl_project"):
        assert built[name] is getattr(ftl, name)


def test_compiled_trace_points_match_python_across_laps() -> None:
    """`path_segment` takes s mod lap without the fmod within one lap either side of 0: the
    compiled trace points equal the Python law's (``%`` and ``bisect``) bit for bit at arc
    lengths inside a lap, behind its start, at and beyond its end, at ±0, a hair below 0
    (where s + lap rounds to the lap) and on segment boundaries."""
    from rtsim.world.compiled import CompiledTraceFollower  # lazy: numba on import

    path = rounded_rectangle(800, 400, 120)
    args = (path, [325.0, 650.0], [0.0, 40.0], 0.5, 40.0)
    fast, slow = CompiledTraceFollower(*args), ftl.TraceFollower(*args)
    assert fast.compiled
    lap = path.lap_length
    starts = list(path._s0)
    rng = np.random.default_rng(36)
    ss = [0.0, -0.0, 5e-324, -5e-324, -1e-300, lap, -lap, 2 * lap, -2 * lap, 1e9, -1e9]
    ss += [lap - 1e-12, -lap + 1e-12, *starts, *(-lap + b for b in starts)]
    ss += [*(b + lap for b in starts), *rng.uniform(-3 * lap, 3 * lap, 400)]
    for s in ss:
        for k in (0, 1):
            got, want = fast.point(k, float(s)), slow.point(k, float(s))
            assert got == want, (s, k, got, want)
