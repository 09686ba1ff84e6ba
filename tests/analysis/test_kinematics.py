"""Tests of rtsim.analysis.kinematics: Eq 17, β̇, the MSBs (Eqs 19–21, bearing), formation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtsim.analysis.kinematics import (
    BOUND_KINDS,
    Thresholds,
    beta_dot,
    follower_msbs,
    formation_velocity,
    msb_bearing,
    msb_localization,
    msb_localization_full,
    msb_path_diversion,
    msb_separation,
    relative_state,
    rho_dot,
    slack,
    wrap_angle,
    wrap_positive,
)
from rtsim.errors import InputError

DEG = math.pi / 180.0


# ---------------------------------------------------------------- independent world helpers


def _move(pose: tuple[float, float, float], v: float, omega: float, t: float, steps: int):
    """Plain explicit-Euler integration of a unicycle (not the formulas under test)."""
    x, y, h = pose
    dt = t / steps
    for _ in range(steps):
        x += v * math.cos(h) * dt
        y += v * math.sin(h) * dt
        h += omega * dt
    return x, y, h


def _rho_phi(leader, follower):
    """Distance and world angle of the leader→follower vector, computed in the test."""
    dx, dy = follower[0] - leader[0], follower[1] - leader[1]
    return math.hypot(dx, dy), math.atan2(dy, dx)


def _place(leader, rho, beta, theta):
    xl, yl, hl = leader
    return (xl + rho * math.cos(hl + beta), yl + rho * math.sin(hl + beta), hl - theta)


def _finite_differences(leader, follower, v_l, w_l, v_f, w_f, h=1e-3, steps=400):
    """Central differences of ρ and β (β = φ − θ_L) over ±h of two integrated unicycles."""
    lp = _move(leader, v_l, w_l, h, steps)
    fp = _move(follower, v_f, w_f, h, steps)
    lm = _move(leader, -v_l, -w_l, h, steps)  # backwards in time
    fm = _move(follower, -v_f, -w_f, h, steps)
    rp, php = _rho_phi(lp, fp)
    rm, phm = _rho_phi(lm, fm)
    dphi = math.remainder(php - phm, 2 * math.pi)
    dbeta = dphi - (lp[2] - lm[2])
    return (rp - rm) / (2 * h), dbeta / (2 * h)


# ---------------------------------------------------------------- ρ̇ and β̇


def test_rates_match_finite_differences_of_integrated_unicycles():
    rng = np.random.default_rng(20240501)
    signs_rho, signs_beta = set(), set()
    for _ in range(40):
        v_l = rng.uniform(5, 40)
        v_f = rng.uniform(5, 80)
        w_l = rng.uniform(-0.4, 0.4)
        w_f = rng.uniform(-0.4, 0.4)
        rho = rng.uniform(150, 450)
        beta = rng.uniform(0, 2 * math.pi)
        theta = rng.uniform(-math.pi, math.pi)
        leader = (rng.uniform(-500, 500), rng.uniform(-500, 500), rng.uniform(-math.pi, math.pi))
        follower = _place(leader, rho, beta, theta)
        fd_rho, fd_beta = _finite_differences(leader, follower, v_l, w_l, v_f, w_f)
        got_rho = rho_dot(v_l, v_f, beta, theta)
        got_beta = beta_dot(v_l, v_f, beta, theta, rho, w_l)
        assert got_rho == pytest.approx(fd_rho, rel=1e-4, abs=1e-4)
        assert got_beta == pytest.approx(fd_beta, rel=1e-4, abs=1e-6)
        signs_rho.add(got_rho > 0)
        signs_beta.add(got_beta > 0)
    assert signs_rho == {True, False} and signs_beta == {True, False}


def test_rates_broadcast_over_arrays_like_scalars():
    rng = np.random.default_rng(3)
    args = [
        rng.uniform(1, 30, 7),
        rng.uniform(1, 30, 7),
        rng.uniform(0, 6, 7),
        rng.uniform(-3, 3, 7),
    ]
    rho, w = rng.uniform(100, 400, 7), rng.uniform(-0.3, 0.3, 7)
    arr_r = rho_dot(*args)
    arr_b = beta_dot(*args, rho, w)
    for i in range(7):
        sc = [float(a[i]) for a in args]
        assert arr_r[i] == pytest.approx(rho_dot(*sc), rel=1e-12)
        assert arr_b[i] == pytest.approx(beta_dot(*sc, float(rho[i]), float(w[i])), rel=1e-12)


def test_relative_state_round_trip_and_wrapping():
    rng = np.random.default_rng(11)
    for _ in range(50):
        leader = (rng.uniform(-100, 100), rng.uniform(-100, 100), rng.uniform(-10, 10))
        rho, beta, theta = rng.uniform(1, 500), rng.uniform(0, 2 * math.pi), rng.uniform(-3, 3)
        rho2, beta2, theta2 = relative_state(leader, _place(leader, rho, beta, theta))
        assert 0 <= beta2 < 2 * math.pi and -math.pi < theta2 <= math.pi
        assert rho2 == pytest.approx(rho)
        assert beta2 == pytest.approx(beta, abs=1e-9)
        assert theta2 == pytest.approx(theta, abs=1e-9)


def test_relative_state_by_hand():
    # Leader at origin heading north; follower 300 cm due south, heading east.
    rho, beta, theta = relative_state((0.0, 0.0, math.pi / 2), (0.0, -300.0, 0.0))
    assert rho == pytest.approx(300.0)
    assert beta == pytest.approx(math.pi)  # directly behind
    assert theta == pytest.approx(math.pi / 2)
    # Behind and to the right of an east-heading leader: β = 180° + 45°.
    _, beta, theta = relative_state((0.0, 0.0, 0.0), (-10.0, -10.0, 3 * math.pi / 2))
    assert beta == pytest.approx(225 * DEG)
    assert theta == pytest.approx(math.pi / 2)  # 0 − 270° wraps to +90°


@pytest.mark.parametrize(
    "a, expected",
    [
        (math.pi, math.pi),
        (-math.pi, math.pi),
        (3 * math.pi, math.pi),
        (0.5, 0.5),
        (-7.0, -7.0 + 2 * math.pi),
    ],
)
def test_wrap_angle(a, expected):
    assert wrap_angle(a) == pytest.approx(expected)
    assert float(wrap_angle(np.array([a, a]))[0]) == pytest.approx(expected)


@pytest.mark.parametrize(
    "a, expected", [(-0.5, 2 * math.pi - 0.5), (2 * math.pi, 0.0), (7.0, 7.0 - 2 * math.pi)]
)
def test_wrap_positive(a, expected):
    assert wrap_positive(a) == pytest.approx(expected)
    assert float(wrap_positive(np.array([a]))[0]) == pytest.approx(expected)


# ---------------------------------------------------------------- the paper's max |ρ̇| claim


def _grid(lo_t, hi_t, lo_b, hi_b, n=1441):
    t = np.linspace(lo_t * DEG, hi_t * DEG, n)
    b = np.linspace(lo_b * DEG, hi_b * DEG, n)
    return np.meshgrid(t, b, indexing="ij")


@pytest.mark.parametrize("v_l, v_f", [(25.0, 25.0), (25.0, 60.0), (30.0, 10.0)])
def test_max_rho_dot_heading_within_90deg(v_l, v_f):
    """θ ∈ [−90°, 90°], β ∈ [90°, 270°]: max |ρ̇| = √(V_F² + V_L²) at θ = ∓90°, β = 180° ∓ atan."""
    T, B = _grid(-90, 90, 90, 270)
    f = np.abs(rho_dot(v_l, v_f, B, T))
    expected = math.hypot(v_f, v_l)
    assert f.max() <= expected * (1 + 1e-12)
    assert f.max() == pytest.approx(expected, rel=1e-5)
    i, j = np.unravel_index(np.argmax(f), f.shape)
    a = math.atan(v_f / v_l)
    claimed = [(-math.pi / 2, math.pi - a), (math.pi / 2, math.pi + a)]
    dist = min(math.hypot(T[i, j] - t, B[i, j] - b) for t, b in claimed)
    assert dist < 1.0 * DEG
    for t, b in claimed:  # both paired points reach the maximum exactly
        assert abs(rho_dot(v_l, v_f, b, t)) == pytest.approx(expected, rel=1e-12)
    # the unpaired signs (θ = +90°, β = 180° − atan) do not
    assert abs(rho_dot(v_l, v_f, math.pi - a, math.pi / 2)) < expected * 0.999


@pytest.mark.parametrize("v_l, v_f", [(25.0, 25.0), (25.0, 60.0), (30.0, 10.0)])
def test_max_rho_dot_over_the_papers_theta_range(v_l, v_f):
    """θ ∈ [90°, 270°] (the paper's range): max = V_F + V_L at β = θ = 180°."""
    T, B = _grid(90, 270, 90, 270)
    f = np.abs(rho_dot(v_l, v_f, B, T))
    assert f.max() == pytest.approx(v_f + v_l, rel=1e-9)
    i, j = np.unravel_index(np.argmax(f), f.shape)
    assert T[i, j] == pytest.approx(math.pi, abs=0.5 * DEG)
    assert B[i, j] == pytest.approx(math.pi, abs=0.5 * DEG)
    assert f.max() > math.hypot(v_f, v_l) * 1.1  # the paper's √ is not the maximum here


# ---------------------------------------------------------------- bounds, by hand


def test_msbs_by_hand():
    assert msb_localization(10.0, 25.0) == pytest.approx(2500.0)  # 25 cm / 10 cm/s = 2.5 s
    assert msb_localization(-10.0, 25.0) == pytest.approx(2500.0)
    assert msb_separation(-3.9, 0.01, 390.0) == pytest.approx(1000.0)  # 3.9 cm / 3.9 cm/s
    assert msb_path_diversion(25.0, 0.025, 390.0) == pytest.approx(390.0)  # 9.75/25 s
    assert msb_bearing(-0.5, 0.1) == pytest.approx(200.0)  # 0.1 rad / 0.5 rad/s
    assert msb_localization_full(3.0, 0.02, 200.0, 25.0) == pytest.approx(5000.0)  # |(3,4)| = 5


def test_msbs_infinite_on_zero_denominator():
    assert msb_localization(0.0, 25.0) == math.inf
    assert msb_separation(0.0, 0.01, 390.0) == math.inf
    assert msb_path_diversion(0.0, 0.025, 390.0) == math.inf
    assert msb_bearing(0.0, 0.1) == math.inf
    assert msb_localization_full(0.0, 0.0, 300.0, 25.0) == math.inf
    arr = msb_localization(np.array([0.0, 5.0, -2.5]), 25.0)
    assert (
        arr[0] == math.inf and arr[1] == pytest.approx(5000.0) and arr[2] == pytest.approx(10000.0)
    )


def test_follower_msbs_by_hand():
    thr = Thresholds(r_H=25.0, T_rho=0.01, T_eps=0.025, T_beta=0.1)
    # β = 120°, θ = −30°: cos(θ+β) = 0, so ρ̇ = −V_L cos 120° = 12.5 cm/s.
    m = follower_msbs(25.0, 0.05, 40.0, 390.0, 120 * DEG, -30 * DEG, 390.0, thr)
    assert set(m) == set(BOUND_KINDS)
    assert m["localization"] == pytest.approx(2000.0)  # 25/12.5 s
    assert m["separation"] == pytest.approx(1000 * 3.9 / 12.5)
    assert m["path_diversion"] == pytest.approx(1000 * 9.75 / 40.0)
    bdot = (25 * math.sin(120 * DEG) - 40 * 1.0) / 390 - 0.05
    assert m["bearing"] == pytest.approx(1000 * 0.1 / abs(bdot))
    full = follower_msbs(
        25.0,
        0.05,
        40.0,
        390.0,
        120 * DEG,
        -30 * DEG,
        390.0,
        Thresholds(25.0, 0.01, 0.025, 0.1, localization="full"),
    )
    assert full["localization"] == pytest.approx(1000 * 25 / math.hypot(12.5, 390 * bdot))
    # Straight line, exact formation behind: ρ̇ = 0, only ω_L moves β.
    m = follower_msbs(25.0, 0.125, 25.0, 390.0, math.pi, 0.0, 390.0, thr)
    assert m["localization"] == math.inf and m["separation"] == math.inf
    assert m["bearing"] == pytest.approx(800.0)


def test_slack_is_signed_eq22():
    assert slack(300.0, 237.4) == pytest.approx(62.6)
    assert slack(150.0, 237.4) == pytest.approx(-87.4)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(r_H=-1.0, T_rho=0.01, T_eps=0.025, T_beta=0.1), "r_H"),
        (dict(r_H=25.0, T_rho=0.0, T_eps=0.025, T_beta=0.1), "T_rho"),
        (dict(r_H=25.0, T_rho=0.01, T_eps=math.nan, T_beta=0.1), "T_eps"),
        (dict(r_H=25.0, T_rho=0.01, T_eps=0.025, T_beta=math.inf), "T_beta"),
        (dict(r_H=True, T_rho=0.01, T_eps=0.025, T_beta=0.1), "r_H"),
        (dict(r_H=25.0, T_rho=0.01, T_eps=0.025, T_beta=0.1, localization="both"), "localization"),
    ],
)
def test_thresholds_validated(kwargs, match):
    with pytest.raises(InputError, match=match):
        Thresholds(**kwargs)


# ---------------------------------------------------------------- steady formation


@pytest.mark.parametrize(
    "v_l, r_t, rho, ratio",
    [(25.0, 200.0, 390.0, 2.41), (30.0, 120.0, 325.0, 3.12)],  # SPEC §6: Test 1, Test 2
)
def test_formation_speed_of_outer_follower(v_l, r_t, rho, ratio):
    omega = v_l / r_t  # left turn
    v_f, _ = formation_velocity(v_l, omega, rho, 195 * DEG)  # right side = outer
    q = rho / r_t
    hand = v_l * math.sqrt(1 + q * q + 2 * q * math.sin(15 * DEG))
    assert v_f == pytest.approx(hand, rel=1e-12)
    assert v_f / v_l == pytest.approx(ratio, abs=0.005)
    # mirror: a right turn makes the left follower the outer one
    v_f2, _ = formation_velocity(v_l, -omega, rho, 165 * DEG)
    assert v_f2 == pytest.approx(v_f, rel=1e-12)
    inner, _ = formation_velocity(v_l, omega, rho, 165 * DEG)
    assert inner < v_f


@pytest.mark.parametrize("beta_deg", [165.0, 195.0, 180.0, 100.0, 260.0])
@pytest.mark.parametrize("omega", [0.125, -0.25, 0.0])
def test_steady_formation_keeps_relative_state(beta_deg, omega):
    v_l, rho, beta = 25.0, 390.0, beta_deg * DEG
    v_f, theta = formation_velocity(v_l, omega, rho, beta)
    assert rho_dot(v_l, v_f, beta, theta) == pytest.approx(0.0, abs=1e-9)
    assert beta_dot(v_l, v_f, beta, theta, rho, omega) == pytest.approx(0.0, abs=1e-12)
    # independent check: integrate both unicycles (same turn rate) for 2 s
    leader = (0.0, 0.0, 0.3)
    follower = _place(leader, rho, beta, theta)
    lp = _move(leader, v_l, omega, 2.0, 4000)
    fp = _move(follower, v_f, omega, 2.0, 4000)
    r2, phi2 = _rho_phi(lp, fp)
    assert r2 == pytest.approx(rho, rel=1e-4)
    assert math.remainder(phi2 - lp[2] - beta, 2 * math.pi) == pytest.approx(0.0, abs=1e-4)


def test_formation_velocity_straight_and_arrays():
    v_f, theta = formation_velocity(25.0, 0.0, 390.0, 2.0)
    assert v_f == pytest.approx(25.0) and theta == pytest.approx(0.0)
    vs, ths = formation_velocity(25.0, 0.125, np.array([390.0, 325.0]), np.array([2.9, 3.4]))
    for k, (r, b) in enumerate([(390.0, 2.9), (325.0, 3.4)]):
        v1, t1 = formation_velocity(25.0, 0.125, r, b)
        assert vs[k] == pytest.approx(v1) and ths[k] == pytest.approx(t1)
