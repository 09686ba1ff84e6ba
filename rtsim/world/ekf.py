"""The leader's extended Kalman filter of each follower's pose (x, y, θ): predict with the
followers' motion model's ``process`` (`rtsim.world.motionmodels`) and the command held,
update with the Hough fix (docs/model/world.md, "Estimation"). `FollowerEKF` wraps
filterpy's ``ExtendedKalmanFilter`` (the reference); `FastFollowerEKF` does the same algebra
on plain floats, several times cheaper (tested equal to 1e-9); ``EkfParams.backend``
chooses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from rtsim.errors import ScenarioError
from rtsim.io.limits import Range
from rtsim.world._check import NOISE, in_ranges, spec
from rtsim.world.jit import kernel, specialise
from rtsim.world.motion import arc, chord, ramp

__all__ = [
    "EKF_BACKENDS",
    "EkfParams",
    "FollowerEKF",
    "FastFollowerEKF",
    "H_POSITION",
    "command_process",
    "ekf_apply",
    "ekf_command",
    "ekf_predict",
    "ekf_update",
    "make_filter",
    "process",
]

#: Measurement Jacobian of the position fix.
H_POSITION = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
#: ``[ekf] backend``: plain floats (``fast``) or filterpy's filter (the reference).
EKF_BACKENDS: tuple[str, ...] = ("filterpy", "fast")
_CM = Range("", 0, 1e4, "cm", NOISE)
_RAD = Range("", 0, 100, "rad", NOISE)


@dataclass(frozen=True)
class EkfParams:
    """Noise model of the leader's filters.

    measurement_noise σ_m (cm, floored at 0.01 so that R stays invertible); speed_noise σ_v
    (cm/s) and turn_noise σ_ω (rad/s): assumed actuation error per command; position_drift
    q_p (cm/√s) and heading_drift q_θ (rad/√s): model-error random walk; init_position_sd
    (cm) and init_heading_sd (rad): the error of the initial estimate (drawn, and used as P0);
    backend: "fast" (plain floats, the default for speed) or "filterpy" (the reference).
    """

    measurement_noise: float = spec(1.0, _CM)
    speed_noise: float = spec(0.5, Range("", 0, 1e4, "cm/s", NOISE))
    turn_noise: float = spec(0.005, Range("", 0, 100, "rad/s", NOISE))
    position_drift: float = spec(0.5, _CM)
    heading_drift: float = spec(0.005, _RAD)
    init_position_sd: float = spec(1.0, _CM)
    init_heading_sd: float = spec(math.radians(2.0), _RAD)
    backend: Literal["filterpy", "fast"] = "fast"

    def __post_init__(self) -> None:
        if self.backend not in EKF_BACKENDS:
            raise ScenarioError(f"ekf.backend: must be 'filterpy' or 'fast', got {self.backend!r}")
        in_ranges(self, "ekf")


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
            #: a motion model's pose increments for the next predict (`predict_command`)
            move: tuple[float, float, float] | None = None

            def predict_x(self, u: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
                x = self.x
                if self.move is None:
                    v, w, dt = u
                    x[0, 0], x[1, 0], x[2, 0] = arc(
                        float(x[0, 0]), float(x[1, 0]), float(x[2, 0]), v, w, dt
                    )
                    return
                (dx, dy, dth), self.move = self.move, None
                x[0, 0], x[1, 0], x[2, 0] = (
                    float(x[0, 0]) + dx,
                    float(x[1, 0]) + dy,
                    float(x[2, 0]) + dth,
                )

        _ARC_EKF = _ArcEKF
    return _ARC_EKF


class FollowerEKF:
    """The leader's estimate of one follower's pose; wraps a filterpy ExtendedKalmanFilter.
    ``motion``: the motion model `predict_command` predicts with
    (`rtsim.world.motionmodels.MotionModel`; None: the unicycle)."""

    def __init__(
        self, pose: tuple[float, float, float], params: EkfParams, motion: Any = None
    ) -> None:
        self.params = params
        self._process = command_process if motion is None else motion.process
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

    @property
    def heading_var(self) -> float:
        """P_θθ (rad²): the heading estimate's variance."""
        return float(self.kf.P[2, 2])

    def set_state(self, pose: tuple[float, float, float], P: NDArray[np.float64]) -> None:
        """Overwrite the estimate and its covariance (tests, re-initialisation)."""
        self.kf.x = np.array([[pose[0]], [pose[1]], [pose[2]]], dtype=float)
        self.kf.P = np.array(P, dtype=float)

    def predict(self, v: float, w: float, dt: float) -> None:
        """Propagate over ``dt`` s holding speed ``v`` (cm/s) and turn rate ``w`` (rad/s)."""
        if dt <= 0.0:
            return
        _, _, _, a, b, *q = process(float(self.kf.x[2, 0]), v, w, dt, *_squares(self.params))
        self.kf.F = np.array([[1.0, 0.0, a], [0.0, 1.0, b], [0.0, 0.0, 1.0]])
        self.kf.Q = np.array([[q[0], q[1], q[2]], [q[1], q[3], q[4]], [q[2], q[4], q[5]]])
        self.kf.predict(u=(v, w, dt))

    def predict_command(
        self, v: float, w: float, vc: float, wc: float, a: float, dt: float
    ) -> tuple[float, float]:
        """Propagate over ``dt`` s holding the command (v_c, ω_c) from expected speed ``v`` and
        turn rate ``w`` with the motion model's ``process`` (acceleration limit ``a``);
        returns the expected speed and turn rate after."""
        if dt <= 0.0:
            return v, w
        th = float(self.kf.x[2, 0])
        dx, dy, dth, fa, fb, *q, v, w = self._process(
            th, v, w, vc, wc, a, dt, *_squares(self.params)
        )
        self.kf.F = np.array([[1.0, 0.0, fa], [0.0, 1.0, fb], [0.0, 0.0, 1.0]])
        self.kf.Q = np.array([[q[0], q[1], q[2]], [q[1], q[3], q[4]], [q[2], q[4], q[5]]])
        self.kf.move = (dx, dy, dth)
        self.kf.predict()
        return v, w

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


@kernel
def process(
    th: float, v: float, w: float, dt: float, sv2: float, sw2: float, qp2: float, qh2: float
) -> tuple[float, ...]:
    """One predict's model (module docstring) at heading θ: (c cos m, c sin m, Δθ, F[0,2],
    F[1,2], then Q's q00 q01 q02 q11 q12 q22) with ``sv2``, ``sw2``, ``qp2``, ``qh2`` the
    squared σ_v, σ_ω, q_p, q_θ."""
    dth, c, m, sinc = chord(th, v, w, dt)
    cm, sm = math.cos(m), math.sin(m)
    a, b = -c * sm, c * cm
    g00, g01 = dt * sinc * cm, 0.5 * dt * a
    g10, g11 = dt * sinc * sm, 0.5 * dt * b
    qp = dt * qp2
    # G diag(σ_v², σ_ω²) Gᵀ + dt diag(q_p², q_p², q_θ²), with G[2] = (0, dt)
    return (
        c * cm,
        c * sm,
        dth,
        a,
        b,
        g00 * g00 * sv2 + g01 * g01 * sw2 + qp,
        g00 * g10 * sv2 + g01 * g11 * sw2,
        g01 * dt * sw2,
        g10 * g10 * sv2 + g11 * g11 * sw2 + qp,
        g11 * dt * sw2,
        dt * dt * sw2 + dt * qh2,
    )


@kernel
def ekf_apply(
    x0: float, x1: float, x2: float, p00: float, p01: float, p02: float, p11: float, p12: float,
    p22: float, dx: float, dy: float, dth: float, a: float, b: float, q00: float, q01: float,
    q02: float, q11: float, q12: float, q22: float,
) -> tuple[float, float, float, float, float, float, float, float, float]:  # fmt: skip
    """A predict's mean and covariance from its model (`process`'s increments, F's two
    non-zeros ``a``, ``b`` and Q): (x, y, θ, P00, P01, P02, P11, P12, P22) after F P Fᵀ + Q with
    F = I + a e0 e2ᵀ + b e1 e2ᵀ."""
    return (
        x0 + dx,
        x1 + dy,
        x2 + dth,
        p00 + 2 * a * p02 + a * a * p22 + q00,
        p01 + a * p12 + b * p02 + a * b * p22 + q01,
        p02 + a * p22 + q02,
        p11 + 2 * b * p12 + b * b * p22 + q11,
        p12 + b * p22 + q12,
        p22 + q22,
    )


@kernel
def ekf_predict(
    x0: float, x1: float, x2: float, p00: float, p01: float, p02: float, p11: float, p12: float,
    p22: float, v: float, w: float, dt: float, sv2: float, sw2: float, qp2: float, qh2: float,
) -> tuple[float, float, float, float, float, float, float, float, float]:  # fmt: skip
    """The predict on floats holding (v, ω) exactly: `process`, then `ekf_apply`."""
    dx, dy, dth, a, b, q00, q01, q02, q11, q12, q22 = process(x2, v, w, dt, sv2, sw2, qp2, qh2)
    return ekf_apply(
        x0, x1, x2, p00, p01, p02, p11, p12, p22, dx, dy, dth, a, b, q00, q01, q02, q11, q12, q22
    )


@kernel
def command_process(
    th: float, v: float, w: float, vc: float, wc: float, a: float, dt: float, sv2: float,
    sw2: float, qp2: float, qh2: float,
) -> tuple[float, ...]:  # fmt: skip
    """The unicycle's predict model for a held command (v_c, ω_c) from expected speed ``v``
    (its turn rate ``w`` is not read: it turns at once): `process` at the mean speed of
    the expected ramp (`rtsim.world.motion.ramp`, limit ``a``), then the speed and turn rate
    after dt: `process`'s 11 values, v, ω."""
    v1, vm = ramp(v, vc, a, dt)
    dx, dy, dth, fa, fb, q00, q01, q02, q11, q12, q22 = process(th, vm, wc, dt, sv2, sw2, qp2, qh2)
    return dx, dy, dth, fa, fb, q00, q01, q02, q11, q12, q22, v1, wc


@kernel
def ekf_command(
    x0: float, x1: float, x2: float, p00: float, p01: float, p02: float, p11: float, p12: float,
    p22: float, v: float, w: float, vc: float, wc: float, a: float, dt: float, sv2: float,
    sw2: float, qp2: float, qh2: float,
) -> tuple[float, ...]:  # fmt: skip
    """The predict of a held command (v_c, ω_c) from expected speed ``v`` and turn rate ``w``:
    the motion model's predict model (`command_process` for the unicycle; another model's in
    its variant, `rtsim.world.motionmodels`), then `ekf_apply`: (x, y, θ, P00, P01, P02,
    P11, P12, P22, v, ω)."""
    dx, dy, dth, fa, fb, q00, q01, q02, q11, q12, q22, v1, w1 = command_process(
        x2, v, w, vc, wc, a, dt, sv2, sw2, qp2, qh2
    )
    n0, n1, n2, n3, n4, n5, n6, n7, n8 = ekf_apply(
        x0, x1, x2, p00, p01, p02, p11, p12, p22, dx, dy, dth, fa, fb, q00, q01, q02, q11, q12, q22
    )
    return n0, n1, n2, n3, n4, n5, n6, n7, n8, v1, w1


@kernel
def ekf_update(
    x0: float, x1: float, x2: float, p00: float, p01: float, p02: float, p10: float, p11: float,
    p12: float, p20: float, p21: float, p22: float, r: float, z0: float, z1: float,
) -> tuple[float, ...]:  # fmt: skip
    """The update on floats with H = [I₂ 0], R = r I: (x, y, θ, then P − K H P row by row, 9
    entries); filterpy's Joseph form is the same matrix for this optimal gain."""
    s00, s01, s11 = p00 + r, p01, p11 + r
    det = s00 * s11 - s01 * s01
    i00, i01, i11 = s11 / det, -s01 / det, s00 / det
    # K = P Hᵀ S⁻¹ (3×2), row j = (P[j][0] i00 + P[j][1] i01, P[j][0] i01 + P[j][1] i11)
    k00, k01 = p00 * i00 + p01 * i01, p00 * i01 + p01 * i11
    k10, k11 = p10 * i00 + p11 * i01, p10 * i01 + p11 * i11
    k20, k21 = p20 * i00 + p21 * i01, p20 * i01 + p21 * i11
    y0, y1 = z0 - x0, z1 - x1
    return (
        x0 + (k00 * y0 + k01 * y1),
        x1 + (k10 * y0 + k11 * y1),
        x2 + (k20 * y0 + k21 * y1),
        p00 - k00 * p00 - k01 * p10,
        p01 - k00 * p01 - k01 * p11,
        p02 - k00 * p02 - k01 * p12,
        p10 - k10 * p00 - k11 * p10,
        p11 - k10 * p01 - k11 * p11,
        p12 - k10 * p02 - k11 * p12,
        p20 - k20 * p00 - k21 * p10,
        p21 - k20 * p01 - k21 * p11,
        p22 - k20 * p02 - k21 * p12,
    )


def _squares(p: EkfParams) -> tuple[float, float, float, float]:
    """σ_v², σ_ω², q_p², q_θ²: `process`'s noise arguments."""
    return p.speed_noise**2, p.turn_noise**2, p.position_drift**2, p.heading_drift**2


class FastFollowerEKF:
    """The same filter as [`FollowerEKF`][rtsim.world.ekf.FollowerEKF] on plain floats (state x,
    P as its nine entries row by row, ``_q``):
    `ekf_predict` and `ekf_update` (compiled in the compiled backend's
    subclass)."""

    _predict = staticmethod(ekf_predict)
    _update = staticmethod(ekf_update)

    def __init__(
        self, pose: tuple[float, float, float], params: EkfParams, motion: Any = None
    ) -> None:
        self.params = params
        self._command = self._command_kernel(motion)
        self.x = [float(pose[0]), float(pose[1]), float(pose[2])]
        sp = max(params.init_position_sd, 0.01) ** 2
        sh = max(params.init_heading_sd, 1e-4) ** 2
        self._q: tuple[float, ...] = (sp, 0.0, 0.0, 0.0, sp, 0.0, 0.0, 0.0, sh)
        self.r = max(params.measurement_noise, 0.01) ** 2
        self._noise = _squares(params)

    @property
    def pose(self) -> tuple[float, float, float]:
        x = self.x
        return x[0], x[1], x[2]

    @property
    def P(self) -> NDArray[np.float64]:
        return np.array(self._q).reshape(3, 3)

    @property
    def _p(self) -> list[list[float]]:
        """P as three rows (lists)."""
        q = self._q
        return [list(q[0:3]), list(q[3:6]), list(q[6:9])]

    @property
    def heading_var(self) -> float:
        """P_θθ (rad²): the heading estimate's variance."""
        return self._q[8]

    def set_state(self, pose: tuple[float, float, float], P: NDArray[np.float64]) -> None:
        self.x = [float(pose[0]), float(pose[1]), float(pose[2])]
        self._q = tuple(float(P[i][j]) for i in range(3) for j in range(3))

    def predict(self, v: float, w: float, dt: float) -> None:
        if dt <= 0.0:
            return
        x, q = self.x, self._q
        x[0], x[1], x[2], n00, n01, n02, n11, n12, n22 = self._predict(
            x[0], x[1], x[2], q[0], q[1], q[2], q[4], q[5], q[8], v, w, dt, *self._noise
        )
        self._q = (n00, n01, n02, n01, n11, n12, n02, n12, n22)

    @staticmethod
    def _command_kernel(motion: Any) -> Any:
        """`ekf_command` for ``motion`` (None: the unicycle), as Python (compiled in the
        compiled backend's subclass)."""
        return ekf_command if motion is None else specialise(ekf_command, motion.subs)

    def predict_command(
        self, v: float, w: float, vc: float, wc: float, a: float, dt: float
    ) -> tuple[float, float]:
        """`FollowerEKF.predict_command` on floats (`ekf_command`)."""
        if dt <= 0.0:
            return v, w
        x, q = self.x, self._q
        x[0], x[1], x[2], n00, n01, n02, n11, n12, n22, v, w = self._command(
            x[0], x[1], x[2], q[0], q[1], q[2], q[4], q[5], q[8], v, w, vc, wc, a, dt, *self._noise
        )
        self._q = (n00, n01, n02, n01, n11, n12, n02, n12, n22)
        return v, w

    def update(self, z: tuple[float, float]) -> None:
        x = self.x
        r = self._update(x[0], x[1], x[2], *self._q, self.r, float(z[0]), float(z[1]))
        x[0], x[1], x[2] = r[0], r[1], r[2]
        self._q = r[3:]

    def reset_position(self, z: tuple[float, float]) -> None:
        self.x[0], self.x[1] = float(z[0]), float(z[1])
        r = self.r
        self._q = (r, 0.0, 0.0, 0.0, r, 0.0, 0.0, 0.0, self._q[8])


def make_filter(
    pose: tuple[float, float, float], params: EkfParams, motion: Any = None
) -> FollowerEKF | FastFollowerEKF:
    """The filter ``params.backend`` names, predicting with motion model ``motion``."""
    if params.backend == "filterpy":
        return FollowerEKF(pose, params, motion)
    return FastFollowerEKF(pose, params, motion)
