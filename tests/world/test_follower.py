"""Followers in the world: Eq 17 against finite differences, steady turns (SPEC §4, §6)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtsim.analysis.kinematics import beta_dot, relative_state, rho_dot
from rtsim.world import (
    EkfParams,
    FollowerParams,
    LeaderPath,
    SensingParams,
    Turn,
    World,
    WorldConfig,
    chevron,
    rounded_rectangle,
)
from rtsim.world.formation import Formation
from rtsim.world.motion import arc, clip, leader_travel, ramp, speed_ramp

QUIET_EKF = EkfParams(init_position_sd=0.0, init_heading_sd=0.0)
QUIET_SENSING = SensingParams(position_noise=0.0)


def quiet_follower(**kw: float) -> FollowerParams:
    return FollowerParams(speed_noise=0.0, turn_noise=0.0, **kw)


def test_arc_step_matches_fine_euler() -> None:
    x, y, th = arc(1.0, 2.0, 0.3, 40.0, 0.7, 1.5)
    xe, ye, te, n = 1.0, 2.0, 0.3, 200_000
    h = 1.5 / n
    for _ in range(n):
        xe += 40 * math.cos(te + 0.35 * h) * h  # midpoint in heading
        ye += 40 * math.sin(te + 0.35 * h) * h
        te += 0.7 * h
    assert (x, y, th) == pytest.approx((xe, ye, te), abs=1e-6)
    # a straight step (ω = 0) is the plain line
    assert arc(1.0, 2.0, 0.3, 40.0, 0.0, 1.5) == pytest.approx(
        (1.0 + 60.0 * math.cos(0.3), 2.0 + 60.0 * math.sin(0.3), 0.3)
    )


def test_ramp_mean_speed_by_hand() -> None:
    v1, vm = ramp(10.0, 30.0, 100.0, 0.5)
    # reaches 30 after 0.2 s: distance 0.2·20 + 0.3·30 = 13 cm over 0.5 s
    assert v1 == 30.0 and vm == pytest.approx(26.0)
    v1, vm = ramp(10.0, 30.0, 100.0, 0.1)
    assert v1 == pytest.approx(20.0) and vm == pytest.approx(15.0)
    assert ramp(10.0, 30.0, math.inf, 0.1) == (30.0, pytest.approx(30.0))  # no limit: at once
    assert ramp(30.0, 10.0, 100.0, 0.1) == (pytest.approx(20.0), pytest.approx(25.0))


def test_leader_and_follower_read_the_one_ramp() -> None:
    """The leader's arc length is the followers' ramp's distance (mean speed × dt, by hand
    as above), at ``accel`` speeding up and ``decel`` slowing down; dt ≤ 0 drives nothing."""
    assert leader_travel(10.0, 30.0, 100.0, 1.0, 0.5) == (30.0, pytest.approx(13.0))
    assert leader_travel(30.0, 10.0, 1.0, 100.0, 0.1) == (pytest.approx(20.0), pytest.approx(2.5))
    assert leader_travel(10.0, 30.0, 1.0, 100.0, 0.5) == (10.5, pytest.approx(5.125))
    assert leader_travel(20.0, 20.0, 1.0, 1.0, 0.5) == (20.0, 10.0)
    assert leader_travel(10.0, 30.0, 100.0, 100.0, 0.0) == (10.0, 0.0)
    assert ramp(10.0, 30.0, 100.0, 0.0) == (10.0, 10.0)
    for v0, vt, a, dt in ((10.0, 30.0, 100.0, 0.5), (30.0, 10.0, 100.0, 0.1), (5.0, 7.0, 3.0, 0.3)):
        v1, d, vm = speed_ramp(v0, vt, a, dt)
        assert (v1, vm) == ramp(v0, vt, a, dt) and (v1, d) == leader_travel(v0, vt, a, a, dt)
        assert d == pytest.approx(vm * dt, rel=1e-15)


def test_clip_is_pythons_min_max() -> None:
    """The saturation both backends run: min(max(v, −lim), lim), NaN and ties included."""
    rng = np.random.default_rng(4)
    values = [*rng.normal(0.0, 200.0, 2000).tolist(), 150.0, -150.0, 0.0, -0.0, math.nan]
    for lim in (150.0, 3.0, math.inf, 0.0):
        for v in values:
            want = min(max(v, -lim), lim)
            assert str(clip(v, lim)) == str(want), (v, lim)


def _turning_world(rng_seed: int = 3) -> World:
    path = rounded_rectangle(300, 300, 150)
    cfg = WorldConfig(
        path, 25.0, chevron(2, 390), follower=FollowerParams(), step_ms=10.0, start_s=250.0
    )
    return World(cfg, np.random.default_rng(rng_seed))


def test_rho_dot_beta_dot_match_finite_differences_of_the_world() -> None:
    """Eq 17 and β̇ (SPEC §4) against central differences of poses the world integrated,
    through a turn entry with commands that differ from steady formation and speed ramps."""
    world = _turning_world()
    t, h = 0.0, 0.5
    checked = 0
    for window in range(40):  # the leader enters a turn at s = 300
        world.command(1, t + 1.0)
        world.command(2, t + 2.0)
        if window % 7 == 3:  # shake follower 2: speed step and turn
            world.advance(t + 2.0)
            world.followers.cmd_v[1] += 15.0
            world.followers.cmd_w[1] -= 0.2
        for probe in (40.0, 120.0, 200.0):
            tm = t + probe
            samples = []
            for tt in (tm - h, tm, tm + h):
                world.advance(tt)
                fol = world.followers
                samples.append(
                    [
                        (world.leader.pose, (fol.x[k], fol.y[k], fol.th[k]), fol.v[k])
                        for k in range(2)
                    ]
                    + [(world.leader.speed, world.leader.omega)]
                )
            v_l, w_l = samples[1][2]
            for k in range(2):
                (lp0, fp0, _), (lp1, fp1, vf), (lp2, fp2, _) = (s[k] for s in samples)
                r0, b0, _ = relative_state(lp0, fp0)
                r1, b1, th1 = relative_state(lp1, fp1)
                r2, b2, _ = relative_state(lp2, fp2)
                fd_rho = (r2 - r0) / (2 * h / 1000)
                fd_beta = math.remainder(b2 - b0, 2 * math.pi) / (2 * h / 1000)
                # speed must be constant across the probe: skip instants inside a ramp
                if abs(world.followers.v[k] - world.followers.cmd_v[k]) > 1e-9:
                    continue
                assert rho_dot(v_l, vf, b1, th1) == pytest.approx(fd_rho, abs=1e-4)
                assert beta_dot(v_l, vf, b1, th1, r1, w_l) == pytest.approx(fd_beta, abs=1e-6)
                checked += 1
        t += 240.0
    assert checked > 150
    # the run did exercise the rates
    assert world.leader.segment()[0] == "turn"


@pytest.mark.parametrize(
    ("v_l", "r_t", "rho_d", "ratio"),
    [(25.0, 200.0, 390.0, 2.41), (30.0, 120.0, 325.0, 3.12)],
)
def test_steady_turn_follower_speed(v_l: float, r_t: float, rho_d: float, ratio: float) -> None:
    """In a steady left turn the outer follower (β = 195°) moves at SPEC §6's
    V_F = V_L·√(1 + (ρ/r)² − 2(ρ/r) sin β) (2.41·V_L Test 1, 3.12·V_L Test 2), ρ̇ = β̇ = 0."""
    path = LeaderPath([Turn("left", r_t, 2 * math.pi)])
    cfg = WorldConfig(
        path,
        v_l,
        chevron(2, rho_d),
        follower=quiet_follower(gain_rho=1.0, gain_beta=1.0),
        sensing=QUIET_SENSING,
        ekf=QUIET_EKF,
    )
    world = World(cfg, np.random.default_rng(0))
    fol = world.followers
    for k, f in enumerate(world.filters):  # knock both followers out of formation
        fol.x[k] += 8.0
        fol.y[k] -= 5.0
        fol.th[k] += 0.05
        f.set_state(fol.pose(k), f.P)
    t = 0.0
    for _ in range(150):  # 36 s of 240 ms windows
        scan = world.scan(t)
        world.estimate(scan)
        world.command(1, t + 110.0)
        world.command(2, t + 113.0)
        t += 240.0
    world.advance(t)
    q = rho_d / r_t
    outer = v_l * math.sqrt(1 + q * q - 2 * q * math.sin(math.radians(195)))
    inner = v_l * math.sqrt(1 + q * q - 2 * q * math.sin(math.radians(165)))
    assert outer / v_l == pytest.approx(ratio, abs=0.005)
    rho1, beta1, theta1, vf1 = world.relative(1)
    rho2, beta2, theta2, vf2 = world.relative(2)
    assert rho1 == pytest.approx(rho_d, abs=0.05)
    assert math.degrees(beta1) == pytest.approx(195, abs=0.01)
    assert vf1 == pytest.approx(outer, rel=1e-3)
    assert vf2 == pytest.approx(inner, rel=1e-3)
    w_l = v_l / r_t
    for rho, beta, theta, vf in ((rho1, beta1, theta1, vf1), (rho2, beta2, theta2, vf2)):
        assert abs(rho_dot(v_l, vf, beta, theta)) < 0.05  # cm/s
        assert abs(beta_dot(v_l, vf, beta, theta, rho, w_l)) < 2e-4  # rad/s


def test_formation_validation() -> None:
    from rtsim.errors import ScenarioError

    f = chevron(4, 390)
    assert f.rho_d == (390, 390, 780, 780)
    # the second pair turns outward so that the laser still sees it (formation.py)
    assert [round(math.degrees(b)) for b in f.beta_d] == [195, 165, 202, 158]
    with pytest.raises(ScenarioError, match=r"followers 1 and 2 .*\(on top of each other\)"):
        Formation((300.0, 300.0), (math.pi, math.pi + 0.1)).check_spacing(25)
    with pytest.raises(ScenarioError, match=r"slot\[1\].beta_d: must be in \[90, 270\]"):
        Formation((300.0,), (0.5,))
    with pytest.raises(ScenarioError, match=r"slot\[2\].rho_d: must be positive"):
        Formation((300.0, -1.0), (math.pi, math.pi))
    with pytest.raises(ScenarioError, match="on top of each other"):
        WorldConfig(rounded_rectangle(100, 100, 50), 25.0, chevron(2, 60, 0.1))
