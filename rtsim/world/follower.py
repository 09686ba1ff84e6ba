"""Followers: unicycles with speed, acceleration and turn-rate limits and actuation noise,
held in formation by l-ψ (separation–bearing) control (SPEC §6).

**Controller** (Desai, Ostrowski & Kumar 1998; Das et al. 2002). The controlled point P sits
``d`` ahead of the follower's axle, P = (x + d cos θ_F, y + d sin θ_F). With l, ψ the
distance and bearing of P in the leader's frame, the l-ψ controller imposes

    l̇ = k_ρ (l_d − l),   ψ̇ = k_β (ψ_d − ψ),

which Desai et al. obtain in closed form. rtsim computes the same law without its 1/cos γ
singularity: the required velocity of P in the leader frame, l̇ e_l + l ψ̇ e_ψ, plus the
frame's own motion (V_L, 0) + ω_L × r_P, is turned into the world frame and inverted through
Ṗ = v (cos θ, sin θ) + d ω (−sin θ, cos θ):  v = Ṗ·(cos θ, sin θ),  ω = Ṗ·(−sin θ, cos θ)/d.
Without saturation or noise the closed loop is exactly the one above.

The slot (ρ_d, β_d) is the **axle** position the formulas of SPEC §4 use; the control
point's target is that slot moved ``d`` along the follower's steady-formation heading for
the leader's current path curvature κ (which the leader knows), so that the axle sits
exactly at (ρ_d, β_d) on straights and in steady turns.

**Actuation.** A command (v, ω) is saturated (|v| ≤ max_speed, |ω| ≤ max_turn_rate), then
realised with noise drawn once per command, v + N(0, speed_noise²), ω + N(0, turn_noise²),
and held until the next command (SPEC §6: followers have no sensors of their own). The
wheel speed follows the realised command at most ``max_accel`` cm/s²; the turn rate is
immediate. Drawing the noise per command keeps the truth independent of the step size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rtsim.world._check import non_negative, positive
from rtsim.world.unicycle import arc_step, ramp

__all__ = ["FollowerParams", "FollowerGroup", "lpsi_command", "control_targets"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class FollowerParams:
    """Physical and control parameters shared by all followers.

    radius r_F (cm); max_speed (cm/s); max_accel (cm/s²); max_turn_rate (rad/s, inf = none);
    control_offset d (cm, > 0); gain_rho k_ρ and gain_beta k_β (1/s); speed_noise (cm/s) and
    turn_noise (rad/s): standard deviations of the actuation error per command.

    The offset d must not be too small for the command hold w: the control point's heading
    loop has time constant d/V_F, and a command held for w overshoots (and the formation
    breaks up) once V_F·w/d approaches 2; d = 30 cm keeps Test 2's outer follower
    (V_F ≈ 94 cm/s) stable at w ≈ 240 ms, d = 10 cm does not.
    """

    radius: float = 25.0
    max_speed: float = 150.0
    max_accel: float = 100.0
    max_turn_rate: float = math.inf
    control_offset: float = 30.0
    gain_rho: float = 0.5
    gain_beta: float = 0.5
    speed_noise: float = 0.5
    turn_noise: float = 0.005

    def __post_init__(self) -> None:
        for key in ("radius", "max_speed", "control_offset", "gain_rho", "gain_beta"):
            object.__setattr__(self, key, positive(f"follower.{key}", getattr(self, key)))
        for key in ("max_accel", "max_turn_rate"):
            object.__setattr__(self, key, positive(f"follower.{key}", getattr(self, key),
                                                   allow_inf=True))
        for key in ("speed_noise", "turn_noise"):
            object.__setattr__(self, key, non_negative(f"follower.{key}", getattr(self, key)))


def control_targets(
    rho_d: Array, beta_d: Array, d: float, kappa: float = 0.0
) -> tuple[Array, Array]:
    """(l_d, ψ_d) of the control point for axle slots (ρ_d, β_d) on a path of curvature κ.

    In steady formation the follower's heading relative to the leader is the direction of
    its velocity, (1 − κ ρ sin β, κ ρ cos β) per unit V_L (SPEC §6), so the control point
    sits ``d`` along that direction from the slot; then the axle itself is on (ρ_d, β_d),
    on straights (direction (1, 0)) and in steady turns alike.
    """
    hx = 1.0 - kappa * rho_d * np.sin(beta_d)
    hy = kappa * rho_d * np.cos(beta_d)
    hn = np.hypot(hx, hy)
    hn = np.where(hn > 0.0, hn, 1.0)
    px = rho_d * np.cos(beta_d) + d * hx / hn
    py = rho_d * np.sin(beta_d) + d * hy / hn
    return np.hypot(px, py), np.arctan2(py, px)


def lpsi_command(
    leader: tuple[float, float, float],
    v_l: float,
    omega_l: float,
    x: Array,
    y: Array,
    th: Array,
    l_d: Array,
    psi_d: Array,
    p: FollowerParams,
) -> tuple[Array, Array]:
    """l-ψ control law (unsaturated): (v, ω) for followers at (x, y, θ), vectorised.

    ``leader`` is the leader's pose (x, y, heading), ``v_l`` its speed, ``omega_l`` its
    turn rate; (l_d, ψ_d) the control point's targets from :func:`control_targets`.
    """
    xl, yl, hl = leader
    d = p.control_offset
    c, s = math.cos(hl), math.sin(hl)
    cth, sth = np.cos(th), np.sin(th)
    # control point in the leader frame
    wx = x + d * cth - xl
    wy = y + d * sth - yl
    rx = c * wx + s * wy
    ry = -s * wx + c * wy
    ll = np.hypot(rx, ry)
    psi = np.arctan2(ry, rx)
    dl = p.gain_rho * (l_d - ll)
    dpsi = p.gain_beta * (np.mod(psi_d - psi + math.pi, 2 * math.pi) - math.pi)
    el_x, el_y = rx / ll, ry / ll
    # velocity of P in the leader frame: frame motion + wanted relative motion
    vx = v_l - omega_l * ry + dl * el_x - ll * dpsi * el_y
    vy = omega_l * rx + dl * el_y + ll * dpsi * el_x
    # to the world frame
    gx = c * vx - s * vy
    gy = s * vx + c * vy
    v = gx * cth + gy * sth
    w = (-gx * sth + gy * cth) / d
    return v, w


class FollowerGroup:
    """The true state of n followers, integrated with held, noisy, limited commands.

    Arrays (length n, index i−1 for follower i): ``x``, ``y``, ``th`` (unwrapped heading),
    ``v`` (actual wheel speed), ``cmd_v``/``cmd_w`` (realised commands being held),
    ``odometer`` (distance travelled, cm).
    """

    def __init__(self, x: Array, y: Array, th: Array, v: Array, params: FollowerParams) -> None:
        self.p = params
        self.x = np.array(x, dtype=float)
        self.y = np.array(y, dtype=float)
        self.th = np.array(th, dtype=float)
        self.v = np.array(v, dtype=float)
        self.cmd_v = self.v.copy()
        self.cmd_w = np.zeros_like(self.v)
        self.odometer = np.zeros_like(self.v)

    @property
    def n(self) -> int:
        return int(self.x.shape[0])

    def saturate(self, v: Array | float, w: Array | float) -> tuple[Array, Array]:
        """Clip a command to the speed and turn-rate limits."""
        p = self.p
        return (np.clip(v, -p.max_speed, p.max_speed),
                np.clip(w, -p.max_turn_rate, p.max_turn_rate))

    def apply(self, k: int, v: float, w: float, rng: np.random.Generator) -> tuple[float, float]:
        """Hold command (v, ω) for follower index ``k`` (0-based), with actuation noise.

        Two normal draws per call, always (reproducible whatever the noise level).
        Returns the realised (v, ω).
        """
        nv, nw = rng.standard_normal(2)
        sv, sw = self.saturate(v + self.p.speed_noise * nv, w + self.p.turn_noise * nw)
        self.cmd_v[k] = float(sv)
        self.cmd_w[k] = float(sw)
        return float(sv), float(sw)

    def ramping(self) -> bool:
        """Whether any wheel speed still differs from its held command."""
        return bool(np.any(self.v != self.cmd_v))

    def step(self, dt: float) -> None:
        """Integrate ``dt`` seconds: speed ramp (exact mean speed), then the exact arc."""
        v1, vm = ramp(self.v, self.cmd_v, self.p.max_accel, dt)
        self.x, self.y, self.th = arc_step(self.x, self.y, self.th, vm, self.cmd_w, dt)
        self.odometer += np.abs(vm) * dt
        self.v = v1
