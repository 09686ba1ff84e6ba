"""One filterpy ``ExtendedKalmanFilter`` per follower: pose (x, y, θ) in the world frame (SPEC §6).

**Predict** with the follower's unicycle model and the command the leader sent, held over
the interval (the leader knows the acceleration limit, so the speed used is the mean of
the expected ramp toward the command). With chord c = v·dt·sinc(ω dt/2) and mid-heading
m = θ + ω dt/2 the model is x' = x + c cos m, y' = y + c sin m, θ' = θ + ω dt, and

    F = ∂f/∂(x, y, θ) = [[1, 0, −c sin m], [0, 1, c cos m], [0, 0, 1]],
    G = ∂f/∂(v, ω) ≈ [[dt·s cos m, −(dt/2) c sin m], [dt·s sin m, (dt/2) c cos m], [0, dt]]

(s = sinc term; G drops the second-order change of the chord with ω). The process noise is
Q = G diag(σ_v², σ_ω²) Gᵀ + dt·diag(q_p², q_p², q_θ²): the actuation noise per command plus
a small random walk for what the model leaves out (the exact speed ramp, integration).

**Update** with the measured position (the Hough fix turned into the world frame with the
leader's own pose): h(x) = (x, y), H = [[1, 0, 0], [0, 1, 0]], R = σ_m² I.

The leader predicts once per held command piece between two scans (at most two pieces per
window: before and after that window's send), not per integration step: the arc model is
exact for a held command, so finer predicts would only cost time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from filterpy.kalman import ExtendedKalmanFilter
from numpy.typing import NDArray

from rtsim.world._check import non_negative, positive

__all__ = ["EkfParams", "FollowerEKF", "H_POSITION"]

#: Measurement Jacobian of the position fix.
H_POSITION = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


@dataclass(frozen=True)
class EkfParams:
    """Noise model of the leader's filters.

    measurement_noise σ_m (cm, floored at 0.01 so that R stays invertible); speed_noise σ_v
    (cm/s) and turn_noise σ_ω (rad/s): assumed actuation error per command; position_drift
    q_p (cm/√s) and heading_drift q_θ (rad/√s): model-error random walk; init_position_sd
    (cm) and init_heading_sd (rad): the error of the initial estimate (drawn, and used as P0).
    """

    measurement_noise: float = 1.0
    speed_noise: float = 0.5
    turn_noise: float = 0.005
    position_drift: float = 0.5
    heading_drift: float = 0.005
    init_position_sd: float = 1.0
    init_heading_sd: float = math.radians(2.0)

    def __post_init__(self) -> None:
        for key in ("measurement_noise", "speed_noise", "turn_noise", "position_drift",
                    "heading_drift", "init_position_sd", "init_heading_sd"):
            object.__setattr__(self, key, non_negative(f"ekf.{key}", getattr(self, key)))
        positive("ekf.measurement_noise", max(self.measurement_noise, 0.01))


def _hx(x: NDArray[np.float64]) -> NDArray[np.float64]:
    return x[:2]


def _hjac(x: NDArray[np.float64]) -> NDArray[np.float64]:
    return H_POSITION


class _ArcEKF(ExtendedKalmanFilter):  # type: ignore[misc]
    """filterpy's EKF with the unicycle arc as the state transition (u = (v, ω, dt))."""

    def predict_x(self, u: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        v, w, dt = u
        th = float(self.x[2, 0])
        dth = w * dt
        m = th + 0.5 * dth
        c = v * dt * (math.sin(0.5 * dth) / (0.5 * dth) if dth != 0.0 else 1.0)
        self.x[0, 0] += c * math.cos(m)
        self.x[1, 0] += c * math.sin(m)
        self.x[2, 0] = th + dth


class FollowerEKF:
    """The leader's estimate of one follower's pose; wraps a filterpy ExtendedKalmanFilter."""

    def __init__(self, pose: tuple[float, float, float], params: EkfParams) -> None:
        self.params = params
        kf = _ArcEKF(dim_x=3, dim_z=2)
        kf.x = np.array([[pose[0]], [pose[1]], [pose[2]]], dtype=float)
        kf.P = np.diag([max(params.init_position_sd, 0.01) ** 2] * 2
                       + [max(params.init_heading_sd, 1e-4) ** 2])
        kf.R = np.eye(2) * max(params.measurement_noise, 0.01) ** 2
        self.kf = kf

    @property
    def pose(self) -> tuple[float, float, float]:
        x = self.kf.x
        return float(x[0, 0]), float(x[1, 0]), float(x[2, 0])

    @property
    def P(self) -> NDArray[np.float64]:
        return self.kf.P

    def predict(self, v: float, w: float, dt: float) -> None:
        """Propagate over ``dt`` s holding speed ``v`` (cm/s) and turn rate ``w`` (rad/s)."""
        if dt <= 0.0:
            return
        p = self.params
        th = float(self.kf.x[2, 0])
        dth = w * dt
        m = th + 0.5 * dth
        sinc = math.sin(0.5 * dth) / (0.5 * dth) if dth != 0.0 else 1.0
        c = v * dt * sinc
        cm, sm = math.cos(m), math.sin(m)
        self.kf.F = np.array([[1.0, 0.0, -c * sm], [0.0, 1.0, c * cm], [0.0, 0.0, 1.0]])
        G = np.array([[dt * sinc * cm, -0.5 * dt * c * sm],
                      [dt * sinc * sm, 0.5 * dt * c * cm],
                      [0.0, dt]])
        Q = G @ np.diag([p.speed_noise ** 2, p.turn_noise ** 2]) @ G.T
        Q += dt * np.diag([p.position_drift ** 2, p.position_drift ** 2, p.heading_drift ** 2])
        self.kf.Q = Q
        self.kf.predict(u=(v, w, dt))

    def update(self, z: tuple[float, float]) -> None:
        """Correct with a measured world position ``z`` (cm)."""
        self.kf.update(np.array([[z[0]], [z[1]]]), _hjac, _hx)

    def reset_position(self, z: tuple[float, float]) -> None:
        """Re-acquisition: jump to the measured position (P of position = R), keep the heading."""
        self.kf.x[0, 0], self.kf.x[1, 0] = z
        P = self.kf.P
        P[0:2, :] = 0.0
        P[:, 0:2] = 0.0
        P[0:2, 0:2] = self.kf.R
