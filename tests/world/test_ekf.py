"""The per-follower EKF: Jacobians against finite differences, heading convergence on a straight."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtsim.world import EkfParams, FollowerEKF, SensingParams, World, WorldConfig, chevron
from rtsim.world import rounded_rectangle as rr
from rtsim.world.ekf import FastFollowerEKF

HEADING_TOL_DEG = 2.0  # the stated threshold
SETTLE_WINDOWS = 20  # reached within this many windows from a 10° initial error, and kept


def test_state_jacobian_matches_finite_differences() -> None:
    ekf = FollowerEKF((10.0, -4.0, 0.7), EkfParams())
    v, w, dt = 60.0, 0.4, 0.24
    ekf.predict(v, w, dt)
    F = ekf.kf.F.copy()
    x0 = np.array([10.0, -4.0, 0.7])
    num = np.zeros((3, 3))
    eps = 1e-6
    for j in range(3):
        cols = []
        for sgn in (+1, -1):
            e = FollowerEKF(tuple(x0 + sgn * eps * np.eye(3)[j]), EkfParams())
            e.kf.predict_x((v, w, dt))
            cols.append(e.kf.x[:, 0].copy())
        num[:, j] = (cols[0] - cols[1]) / (2 * eps)
    assert F == pytest.approx(num, abs=1e-6)
    # the mean follows the exact arc: radius v/w around the centre
    xc, yc = 10.0 - (v / w) * math.sin(0.7), -4.0 + (v / w) * math.cos(0.7)
    x, y, th = ekf.pose
    assert math.hypot(x - xc, y - yc) == pytest.approx(v / w, abs=1e-9)
    assert th == pytest.approx(0.7 + w * dt)


def test_update_pulls_towards_measurement_and_shrinks_covariance() -> None:
    ekf = FollowerEKF((0.0, 0.0, 0.0), EkfParams(init_position_sd=5.0, measurement_noise=5.0))
    p0 = ekf.P[0, 0]
    ekf.update((10.0, 0.0))
    # equal prior and measurement variance: the posterior is the midpoint, half the variance
    assert ekf.pose[0] == pytest.approx(5.0)
    assert ekf.P[0, 0] == pytest.approx(p0 / 2)


def _straight_run(
    noise: float, seed: int, backend: str = "fast", windows: int = 120
) -> list[float]:
    path = rr(20000, 0, 200)  # a 200 m straight first
    cfg = WorldConfig(
        path,
        25.0,
        chevron(2, 390),
        sensing=SensingParams(position_noise=noise),
        ekf=EkfParams(backend=backend),
    )
    world = World(cfg, np.random.default_rng(seed))
    for f in world.filters:
        x, y, th = f.pose
        P = f.P.copy()
        P[2, 2] = math.radians(10.0) ** 2
        f.set_state((x, y, th + math.radians(10.0)), P)
    errs: list[float] = []
    t = 0.0
    for _ in range(windows):
        scan = world.scan(t)
        world.estimate(scan)
        errs.append(
            max(
                abs(
                    math.degrees(
                        math.remainder(
                            world.filters[k].pose[2] - world.followers.th[k], 2 * math.pi
                        )
                    )
                )
                for k in range(2)
            )
        )
        world.command(1, t + 110.0)
        world.command(2, t + 113.0)
        t += 240.0
    assert world.segment_at()[0] == "straight"
    return errs


@pytest.mark.parametrize("noise", [0.0, 1.0])
@pytest.mark.parametrize(("seed", "backend"), [(0, "fast"), (1, "fast"), (2, "filterpy")])
def test_heading_converges_on_a_straight_run(noise: float, seed: int, backend: str) -> None:
    """From a 10° heading error, with default actuation noise and position noise 0 or 1 cm,
    the heading error falls below 2° within 20 windows (4.8 s) and stays there (120 windows)."""
    errs = _straight_run(noise, seed, backend)
    assert errs[0] > 5.0  # it did start far off
    assert max(errs[SETTLE_WINDOWS:]) < HEADING_TOL_DEG


def test_fast_filter_equals_filterpy() -> None:
    """The plain-float filter does filterpy's algebra: same states and covariances."""
    rng = np.random.default_rng(5)
    params = EkfParams(measurement_noise=1.5, speed_noise=0.8, turn_noise=0.01)
    ref = FollowerEKF((3.0, -2.0, 0.4), params)
    fast = FastFollowerEKF((3.0, -2.0, 0.4), params)
    for step in range(60):
        v, w, dt = 20 + 40 * rng.random(), rng.normal(0, 0.3), 0.05 + 0.3 * rng.random()
        ref.predict(v, w, dt)
        fast.predict(v, w, dt)
        z = (ref.pose[0] + rng.normal(0, 2), ref.pose[1] + rng.normal(0, 2))
        if step % 17 == 16:
            ref.reset_position(z)
            fast.reset_position(z)
        else:
            ref.update(z)
            fast.update(z)
        assert fast.pose == pytest.approx(ref.pose, abs=1e-9)
        assert fast.P == pytest.approx(ref.P, abs=1e-9)


def test_worlds_with_either_backend_agree() -> None:
    def run(backend: str) -> dict:
        cfg = WorldConfig(rr(600, 400, 200), 25.0, chevron(2, 390), ekf=EkfParams(backend=backend))
        world = World(cfg, np.random.default_rng(11))
        t = 0.0
        for _ in range(300):
            world.estimate(world.scan(t))
            world.command(1, t + 110.0)
            world.command(2, t + 113.0)
            t += 240.0
        return world.state()

    a, b = run("fast"), run("filterpy")
    assert a["estimate"]["x"] == pytest.approx(b["estimate"]["x"], abs=1e-6)
    assert a["truth"]["heading"] == pytest.approx(b["truth"]["heading"], abs=1e-6)
