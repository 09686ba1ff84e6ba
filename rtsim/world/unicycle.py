"""Unicycle kinematics, vectorised over robots: ẋ = v cos θ, ẏ = v sin θ, θ̇ = ω.

For a speed v and turn rate ω held over dt the motion is an exact circular arc:

    x' = x + v·dt·sinc-form,  i.e.  x' = x + (v/ω)(sin(θ+ω dt) − sin θ),
    y' = y − (v/ω)(cos(θ+ω dt) − cos θ),  θ' = θ + ω dt,

which tends to the straight line as ω → 0 (handled without division by zero).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["arc_step", "ramp"]

Array = NDArray[np.float64]

_SMALL = 1e-9


def arc_step(
    x: Array, y: Array, th: Array, v: Array, w: Array, dt: float | Array
) -> tuple[Array, Array, Array]:
    """Poses after holding (v, ω) for ``dt`` seconds (exact arc); arrays broadcast."""
    dth = w * dt
    th1 = th + dth
    # chord of the arc: length v·dt·sinc(dth/2), direction θ + dth/2 (exact, no 1/ω)
    chord = v * dt * np.sinc(dth / (2 * np.pi))
    mid = th + 0.5 * dth
    return x + chord * np.cos(mid), y + chord * np.sin(mid), th1


def ramp(v0: Array, vc: Array, a_max: float, dt: float) -> tuple[Array, Array]:
    """Speed after ``dt`` s moving from ``v0`` toward ``vc`` at most ``a_max`` cm/s², and the
    mean speed over the interval (exact for the ramp-then-hold profile)."""
    v0 = np.asarray(v0, dtype=float)
    vc = np.asarray(vc, dtype=float) + 0.0 * v0
    if dt <= 0:
        return v0.copy(), v0.copy()
    if not np.isfinite(a_max):
        return vc.copy(), vc.copy()
    dv = vc - v0
    tau = np.abs(dv) / a_max  # time to reach the command
    reach = tau <= dt
    v1 = np.where(reach, vc, v0 + np.sign(dv) * (a_max * dt))
    t_r = np.minimum(tau, dt)  # ramp (v0 → v1), then hold vc
    mean = ((v0 + v1) * 0.5 * t_r + np.where(reach, vc * (dt - t_r), 0.0)) / dt
    return v1, mean
