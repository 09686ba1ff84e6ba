"""One filterpy ``ExtendedKalmanFilter`` per follower: pose (x, y, θ) in the world frame
(docs/model/world.md).

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

Two interchangeable implementations: [`FollowerEKF`][rtsim.world.ekf.FollowerEKF] wraps filterpy's
``ExtendedKalmanFilter`` (the reference), `FastFollowerEKF` does the same algebra
on plain floats (P = F P Fᵀ + Q with this F's two non-zeros; update P − K H P with
H = [I₂ 0], which equals filterpy's Joseph form for the optimal gain), several times
cheaper; a test checks that both agree to 1e-9.
``EkfParams.backend`` chooses ("filterpy" or "fast").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from rtsim.errors import ScenarioError
from rtsim.world._check import non_negative, positive

__all__ = ["EkfParams", "FollowerEKF", "FastFollowerEKF", "H_POSITION", "make_filter"]

#: Measurement Jacobian of the position fix.
H_POSITION = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


@dataclass(frozen=True)
class EkfParams:
    """Noise model of the leader's filters.

    measurement_noise σ_m (cm, floored at 0.01 so that R stays invertible); speed_noise σ_v
    (cm/s) and turn_noise σ_ω (rad/s): assumed actuation error per command; position_drift
    q_p (cm/√s) and heading_drift q_θ (rad/√s): model-error random walk; init_position_sd
    (cm) and init_heading_sd (rad): the error of the initial estimate (drawn, and used as P0);
    backend: "fast" (plain floats, the default for speed) or "filterpy" (the reference).
    """

    measurement_noise: float = 1.0
    speed_noise: float = 0.5
    turn_noise: float = 0.005
    position_drift: float = 0.5
    heading_drift: float = 0.005
    init_position_sd: float = 1.0
    init_heading_sd: float = math.radians(2.0)
    backend: Literal["filterpy", "fast"] = "fast"

    def __post_init__(self) -> None:
        if self.backend not in ("filterpy", "fast"):
            raise ScenarioError(f"ekf.backend: must be 'filterpy' or 'fast', got {self.backend!r}")
        for key in (
            "measurement_noise",
            "speed_noise",
            "turn_noise",
            "position_drift",
            "heading_drift",
            "init_position_sd",
            "init_heading_sd",
        ):
            object.__setattr__(self, key, non_negative(f"ekf.{key}", getattr(self, key)))
        positive("ekf.measurement_noise", max(self.measurement_noise, 0.01))


def _hx(x: NDArray[np.float64]) -> NDArray[np.float64]:
    return x[:2]


def _hjac(x: NDArray[np.float64]) -> NDArray[np.float64]:
    return H_POSITION


_ARC_EKF: type | None = None


def _arc_ekf_class() -> type:
    """filterpy's EKF with the unicycle arc as the state transition (u = (v, ω, dt)).

    Built on first use: filterpy (and the scipy it imports, ~1–3 s) is loaded only when a
    filterpy-backend filter is created, not by ``import rtsim.world``.
    """
    global _ARC_EKF
    if _ARC_EKF is None:
        from filterpy.kalman import ExtendedKalmanFilter

        class _ArcEKF(ExtendedKalmanFilter):  # type: ignore[misc]
            def predict_x(self, u: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
                v, w, dt = u
                th = float(self.x[2, 0])
                dth = w * dt
                m = th + 0.5 * dth
                c = v * dt * (math.sin(0.5 * dth) / (0.5 * dth) if dth != 0.0 else 1.0)
                self.x[0, 0] += c * math.cos(m)
                self.x[1, 0] += c * math.sin(m)
                self.x[2, 0] = th + dth

        _ARC_EKF = _ArcEKF
    return _ARC_EKF


class FollowerEKF:
    """The leader's estimate of one follower's pose; wraps a filterpy ExtendedKalmanFilter."""

    def __init__(self, pose: tuple[float, float, float], params: EkfParams) -> None:
        self.params = params
        kf: Any = _arc_ekf_class()(dim_x=3, dim_z=2)
        kf.x = np.array([[pose[0]], [pose[1]], [pose[2]]], dtype=float)
        kf.P = np.diag(
            [max(params.init_position_sd, 0.01) ** 2] * 2 + [max(params.init_heading_sd, 1e-4) ** 2]
        )
        kf.R = np.eye(2) * max(params.measurement_noise, 0.01) ** 2
        self.kf = kf

    @property
    def pose(self) -> tuple[float, float, float]:
        x = self.kf.x
        return float(x[0, 0]), float(x[1, 0]), float(x[2, 0])

    @property
    def P(self) -> NDArray[np.float64]:
        return self.kf.P

    def set_state(self, pose: tuple[float, float, float], P: NDArray[np.float64]) -> None:
        """Overwrite the estimate and its covariance (tests, re-initialisation)."""
        self.kf.x = np.array([[pose[0]], [pose[1]], [pose[2]]], dtype=float)
        self.kf.P = np.array(P, dtype=float)

    def predict(self, v: float, w: float, dt: float) -> None:
        """Propagate over ``dt`` s holding speed ``v`` (cm/s) and turn rate ``w`` (rad/s)."""
        if dt <= 0.0:
            return
        c, m, a, b, dth, q = _process(self.params, v, w, dt, float(self.kf.x[2, 0]))
        self.kf.F = np.array([[1.0, 0.0, a], [0.0, 1.0, b], [0.0, 0.0, 1.0]])
        self.kf.Q = np.array([[q[0], q[1], q[2]], [q[1], q[3], q[4]], [q[2], q[4], q[5]]])
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


def _process(
    p: EkfParams, v: float, w: float, dt: float, th: float
) -> tuple[float, float, float, float, float, tuple[float, ...]]:
    """(c, m, a, b, dth, Q entries q00 q01 q02 q11 q12 q22) for one predict."""
    dth = w * dt
    m = th + 0.5 * dth
    sinc = math.sin(0.5 * dth) / (0.5 * dth) if dth != 0.0 else 1.0
    c = v * dt * sinc
    cm, sm = math.cos(m), math.sin(m)
    a, b = -c * sm, c * cm  # F[0,2], F[1,2]
    sv2, sw2 = p.speed_noise**2, p.turn_noise**2
    g00, g01 = dt * sinc * cm, 0.5 * dt * a
    g10, g11 = dt * sinc * sm, 0.5 * dt * b
    g21 = dt
    qp, qh = dt * p.position_drift**2, dt * p.heading_drift**2
    q = (
        g00 * g00 * sv2 + g01 * g01 * sw2 + qp,
        g00 * g10 * sv2 + g01 * g11 * sw2,
        g01 * g21 * sw2,
        g10 * g10 * sv2 + g11 * g11 * sw2 + qp,
        g11 * g21 * sw2,
        g21 * g21 * sw2 + qh,
    )
    return c, m, a, b, dth, q


class FastFollowerEKF:
    """The same filter as [`FollowerEKF`][rtsim.world.ekf.FollowerEKF] on plain floats (state x,
    symmetric P)."""

    def __init__(self, pose: tuple[float, float, float], params: EkfParams) -> None:
        self.params = params
        self.x = [float(pose[0]), float(pose[1]), float(pose[2])]
        sp = max(params.init_position_sd, 0.01) ** 2
        self._p = [
            [sp, 0.0, 0.0],
            [0.0, sp, 0.0],
            [0.0, 0.0, max(params.init_heading_sd, 1e-4) ** 2],
        ]
        self.r = max(params.measurement_noise, 0.01) ** 2
        # σ_v², σ_ω², q_p², q_θ² of _process, squared once
        self._noise = (
            params.speed_noise**2,
            params.turn_noise**2,
            params.position_drift**2,
            params.heading_drift**2,
        )

    @property
    def pose(self) -> tuple[float, float, float]:
        return self.x[0], self.x[1], self.x[2]

    @property
    def P(self) -> NDArray[np.float64]:
        return np.array(self._p)

    def set_state(self, pose: tuple[float, float, float], P: NDArray[np.float64]) -> None:
        self.x = [float(pose[0]), float(pose[1]), float(pose[2])]
        self._p = [[float(P[i][j]) for j in range(3)] for i in range(3)]

    def predict(self, v: float, w: float, dt: float) -> None:
        if dt <= 0.0:
            return
        x = self.x
        # _process inlined (the same expressions, cos m and sin m computed once)
        dth = w * dt
        m = x[2] + 0.5 * dth
        sinc = math.sin(0.5 * dth) / (0.5 * dth) if dth != 0.0 else 1.0
        c = v * dt * sinc
        cm, sm = math.cos(m), math.sin(m)
        a, b = -c * sm, c * cm
        sv2, sw2, qp2, qh2 = self._noise
        g00, g01 = dt * sinc * cm, 0.5 * dt * a
        g10, g11 = dt * sinc * sm, 0.5 * dt * b
        qp = dt * qp2
        x[0] += c * cm
        x[1] += c * sm
        x[2] += dth
        (p00, p01, p02), (_, p11, p12), (_, _, p22) = self._p
        # F P Fᵀ with F = I + a e0 e2ᵀ + b e1 e2ᵀ, plus Q (g21 = dt)
        n00 = p00 + 2 * a * p02 + a * a * p22 + (g00 * g00 * sv2 + g01 * g01 * sw2 + qp)
        n01 = p01 + a * p12 + b * p02 + a * b * p22 + (g00 * g10 * sv2 + g01 * g11 * sw2)
        n02 = p02 + a * p22 + g01 * dt * sw2
        n11 = p11 + 2 * b * p12 + b * b * p22 + (g10 * g10 * sv2 + g11 * g11 * sw2 + qp)
        n12 = p12 + b * p22 + g11 * dt * sw2
        n22 = p22 + (dt * dt * sw2 + dt * qh2)
        self._p = [[n00, n01, n02], [n01, n11, n12], [n02, n12, n22]]

    def update(self, z: tuple[float, float]) -> None:
        x, r = self.x, self.r
        p0, p1, p2 = self._p
        p00, p01, p02 = p0
        p10, p11, p12 = p1
        p20, p21, p22 = p2
        s00, s01, s11 = p00 + r, p01, p11 + r
        det = s00 * s11 - s01 * s01
        i00, i01, i11 = s11 / det, -s01 / det, s00 / det
        # K = P Hᵀ S⁻¹ (3×2), row j = (P[j][0] i00 + P[j][1] i01, P[j][0] i01 + P[j][1] i11)
        k00, k01 = p00 * i00 + p01 * i01, p00 * i01 + p01 * i11
        k10, k11 = p10 * i00 + p11 * i01, p10 * i01 + p11 * i11
        k20, k21 = p20 * i00 + p21 * i01, p20 * i01 + p21 * i11
        y0, y1 = z[0] - x[0], z[1] - x[1]
        x[0] += k00 * y0 + k01 * y1
        x[1] += k10 * y0 + k11 * y1
        x[2] += k20 * y0 + k21 * y1
        # P − K (H P): filterpy's Joseph form is the same matrix for this optimal gain
        self._p = [
            [p00 - k00 * p00 - k01 * p10, p01 - k00 * p01 - k01 * p11, p02 - k00 * p02 - k01 * p12],
            [p10 - k10 * p00 - k11 * p10, p11 - k10 * p01 - k11 * p11, p12 - k10 * p02 - k11 * p12],
            [p20 - k20 * p00 - k21 * p10, p21 - k20 * p01 - k21 * p11, p22 - k20 * p02 - k21 * p12],
        ]

    def reset_position(self, z: tuple[float, float]) -> None:
        self.x[0], self.x[1] = float(z[0]), float(z[1])
        P = self._p
        for i in range(3):
            for j in range(3):
                if i < 2 or j < 2:
                    P[i][j] = 0.0
        P[0][0] = P[1][1] = self.r


def make_filter(
    pose: tuple[float, float, float], params: EkfParams
) -> FollowerEKF | FastFollowerEKF:
    """The filter ``params.backend`` names."""
    if params.backend == "filterpy":
        return FollowerEKF(pose, params)
    return FastFollowerEKF(pose, params)
