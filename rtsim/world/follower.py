"""Followers: unicycles with speed, acceleration and turn-rate limits and actuation noise,
held in formation by l-ψ (separation–bearing) control (docs/model/world.md).

**Controller** (Desai, Ostrowski & Kumar 1998; Das et al. 2002). The controlled point P sits
``d`` ahead of the follower's axle, P = (x + d cos θ_F, y + d sin θ_F). With l, ψ the
distance and bearing of P in the leader's frame, the l-ψ controller imposes

    l̇ = k_ρ (l_d − l),   ψ̇ = k_β (ψ_d − ψ),

which Desai et al. obtain in closed form. rtsim computes the same law without its 1/cos γ
singularity: the required velocity of P in the leader frame, l̇ e_l + l ψ̇ e_ψ, plus the
frame's own motion (V_L, 0) + ω_L × r_P, is turned into the world frame and inverted through
Ṗ = v (cos θ, sin θ) + d ω (−sin θ, cos θ):  v = Ṗ·(cos θ, sin θ),  ω = Ṗ·(−sin θ, cos θ)/d.
Without saturation or noise the closed loop is exactly the one above.

The slot (ρ_d, β_d) is the **axle** position the formulas of docs/model/upper-bounds.md use; the
control
point's target is that slot moved ``d`` along the follower's steady-formation heading for
the leader's current path curvature κ (which the leader knows), so that the axle sits
exactly at (ρ_d, β_d) on straights and in steady turns.

**Actuation.** A command (v, ω) is saturated (|v| ≤ max_speed, |ω| ≤ max_turn_rate), then
realised with noise drawn once per command, v + N(0, speed_noise²), ω + N(0, turn_noise²),
and held until the next command (docs/model/world.md: followers have no sensors of their own). The
wheel speed follows the realised command at most ``max_accel`` cm/s²; the turn rate is
immediate. Drawing the noise per command keeps the truth independent of the step size.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rtsim.io.limits import Range
from rtsim.world._check import NOISE, in_ranges, spec
from rtsim.world.motion import actuated, clip
from rtsim.world.motionmodels import MotionModel, motion_model

__all__ = [
    "FollowerParams",
    "FollowerGroup",
    "lpsi_command",
    "control_targets",
]

Array = NDArray[np.float64]

_GAIN = Range("", 0, 1e3, "1/s", "a controller gain", lo_open=True)


def _cm(hi: float, why: str) -> Range:
    return Range("", 0, hi, "cm", why, lo_open=True)


@dataclass(frozen=True)
class FollowerParams:
    """Physical and control parameters shared by all followers.

    radius r_F (cm); max_speed (cm/s); max_accel (cm/s²); max_turn_rate (rad/s, inf = none);
    control_offset d (cm, > 0); gain_rho k_ρ and gain_beta k_β (1/s); speed_noise (cm/s) and
    turn_noise (rad/s): standard deviations of the actuation error per command; lookahead ℓ
    (cm): pure pursuit's look-ahead along the trace in follow-the-leader
    (`rtsim.world.ftl`, which also uses gain_rho on the along-track separation error);
    motion_model: how the robots move under a held command, a name in
    `rtsim.world.motionmodels.MOTION_MODELS` (the truth, the leader's belief and EKF, the
    rollout and the leader's ramp all use it).

    The offset d must not be too small for the command hold w: the control point's heading
    loop has time constant d/V_F, and a command held for w overshoots (and the formation
    breaks up) once V_F·w/d approaches 2; d = 30 cm keeps Test 2's outer follower
    (V_F ≈ 94 cm/s) stable at w ≈ 240 ms, d = 10 cm does not.
    """

    radius: float = spec(25.0, _cm(1e3, "a robot of at most 10 m"))
    max_speed: float = spec(150.0, Range("", 0, 1000, "cm/s", "as leader.speed", lo_open=True))
    max_accel: float = spec(100.0, Range("", 0, 1e5, "cm/s²", "at most 100 g", lo_open=True))
    max_turn_rate: float = spec(
        math.inf, Range("", 0, 1e3, "rad/s", "inf: no limit", lo_open=True, inf=True)
    )
    control_offset: float = spec(30.0, _cm(1e3, "a control point within 10 m"))
    gain_rho: float = spec(0.5, _GAIN)
    gain_beta: float = spec(0.5, _GAIN)
    speed_noise: float = spec(0.5, Range("", 0, 1e3, "cm/s", NOISE))
    turn_noise: float = spec(0.005, Range("", 0, 100, "rad/s", NOISE))
    lookahead: float = spec(40.0, _cm(1e4, "pure pursuit's look-ahead, within 100 m"))
    motion_model: str = "unicycle"

    def __post_init__(self) -> None:
        motion_model(self.motion_model)  # (an unknown name: one line naming the key)
        in_ranges(self, "follower")


def control_targets(
    rho_d: Array, beta_d: Array, d: float, kappa: float = 0.0
) -> tuple[Array, Array]:
    """(l_d, ψ_d) of the control point for axle slots (ρ_d, β_d) on a path of curvature κ.

    In steady formation the follower's heading relative to the leader is the direction of
    its velocity, (1 − κ ρ sin β, κ ρ cos β) per unit V_L (docs/model/world.md), so the control
    point
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


def _mod(xp: Any, a: Any) -> Any:
    return np.mod(a, 2 * math.pi) if xp is np else a % (2 * math.pi)


def lpsi_command(
    leader: tuple[float, float, float],
    v_l: float,
    omega_l: float,
    x: Any,
    y: Any,
    th: Any,
    l_d: Any,
    psi_d: Any,
    p: FollowerParams,
) -> tuple[Any, Any]:
    """l-ψ control law (unsaturated): (v, ω) for followers at (x, y, θ).

    ``leader`` is the leader's pose (x, y, heading), ``v_l`` its speed, ``omega_l`` its
    turn rate; (l_d, ψ_d) the control point's targets from `control_targets`.
    Floats use ``math``; NumPy arrays are vectorised (the same expressions).
    """
    xp: Any = np if isinstance(x, np.ndarray) else math
    xl, yl, hl = leader
    d = p.control_offset
    c, s = math.cos(hl), math.sin(hl)
    cth, sth = xp.cos(th), xp.sin(th)
    # control point in the leader frame
    wx = x + d * cth - xl
    wy = y + d * sth - yl
    rx = c * wx + s * wy
    ry = -s * wx + c * wy
    ll = xp.hypot(rx, ry)
    psi = xp.atan2(ry, rx) if xp is math else np.arctan2(ry, rx)
    dl = p.gain_rho * (l_d - ll)
    dpsi = p.gain_beta * (_mod(xp, psi_d - psi + math.pi) - math.pi)
    el_x, el_y = rx / ll, ry / ll
    # velocity of P in the leader frame: frame motion + wanted relative motion
    vx = v_l - omega_l * ry + dl * el_x - ll * dpsi * el_y
    vy = omega_l * rx + dl * el_y + ll * dpsi * el_x
    # to the world frame
    gx = c * vx - s * vy
    gy = s * vx + c * vy
    return gx * cth + gy * sth, (-gx * sth + gy * cth) / d


class FollowerGroup:
    """The true state of n followers, integrated with held, noisy, limited commands.

    Per follower k = i − 1 (plain lists, each follower integrated lazily up to its own
    time ``t[k]`` in ms): ``x``, ``y``, ``th`` (unwrapped heading), ``v`` (actual wheel
    speed), ``w`` (actual turn rate: the motion model's; the unicycle's is its command's),
    ``cmd_v``/``cmd_w`` (realised commands being held), ``odometer`` (cm travelled).
    """

    def __init__(
        self, x: Any, y: Any, th: Any, v: Any, params: FollowerParams, t_ms: float = 0.0
    ) -> None:
        self.p = params
        self.x = [float(a) for a in x]
        self.y = [float(a) for a in y]
        self.th = [float(a) for a in th]
        self.v = [float(a) for a in v]
        self.cmd_v = list(self.v)
        self.cmd_w = [0.0] * len(self.x)
        self.w = [0.0] * len(self.x)
        self.odometer = [0.0] * len(self.x)
        self.t = [float(t_ms)] * len(self.x)
        self._all = tuple(range(len(self.x)))  # (every follower's index, for advance_all)
        self.motion: MotionModel = motion_model(params.motion_model)
        self._advance = self._kernel(self.motion)

    @staticmethod
    def _kernel(motion: MotionModel) -> Any:
        """The integration: the motion model's ``advance`` (compiled in the compiled
        backend's subclass)."""
        return motion.advance

    @property
    def n(self) -> int:
        return len(self.x)

    @property
    def rollout_group(self) -> type[FollowerGroup]:
        """The group the Python rollout plays commands ahead on: one of this class."""
        return type(self)

    def saturate(self, v: float, w: float) -> tuple[float, float]:
        """Clip a command to the speed and turn-rate limits."""
        p = self.p
        return clip(v, p.max_speed), clip(w, p.max_turn_rate)

    def apply(self, k: int, v: float, w: float, rng: np.random.Generator) -> tuple[float, float]:
        """Hold command (v, ω) for follower index ``k`` (0-based), with actuation noise.

        Two normal draws per call, always (reproducible whatever the noise level).
        Returns the realised (v, ω).
        """
        nv, nw = rng.standard_normal(2).tolist()
        return self.apply_drawn(k, v, w, nv, nw)

    def apply_drawn(self, k: int, v: float, w: float, nv: float, nw: float) -> tuple[float, float]:
        """`apply` with its two standard-normal draws (``nv``, ``nw``) given."""
        p = self.p
        sv, sw = actuated(v, w, nv, nw, p.speed_noise, p.turn_noise, p.max_speed, p.max_turn_rate)
        self.cmd_v[k] = sv
        self.cmd_w[k] = sw
        return sv, sw

    def pose(self, k: int) -> tuple[float, float, float]:
        return self.x[k], self.y[k], self.th[k]

    def truth(self) -> tuple[list[float], list[float], list[float], list[float]]:
        """Copies of the positions x, y, the headings θ and the speeds (lists of floats)."""
        return list(self.x), list(self.y), list(self.th), list(self.v)

    @property
    def xy(self) -> tuple[Any, Any]:
        """The positions (x, y), each a sequence of floats as the group keeps it (the lists
        themselves: read, do not write)."""
        return self.x, self.y

    def advance(self, k: int, t_ms: float, step_ms: float) -> None:
        """Integrate follower index ``k`` to ``t_ms`` (the motion model's ``advance``; the
        unicycle's `rtsim.world.motion.follower_advance`: exact arcs at the ramp's mean
        speed)."""
        self._advance_each((k,), t_ms, step_ms)

    def advance_all(self, t_ms: float, step_ms: float) -> None:
        """`advance` every follower to ``t_ms``."""
        self._advance_each(self._all, t_ms, step_ms)

    def _advance_each(self, ks: Iterable[int], t_ms: float, step_ms: float) -> None:
        """`advance` followers ``ks`` to ``t_ms`` (one loop: no call per follower)."""
        t, fn, a = self.t, self._advance, self.p.max_accel
        x, y, th, v, w, odo = self.x, self.y, self.th, self.v, self.w, self.odometer
        cmd_v, cmd_w = self.cmd_v, self.cmd_w
        for k in ks:
            t0 = t[k]
            if t_ms <= t0:
                continue
            x[k], y[k], th[k], v[k], w[k], odo[k] = fn(
                x[k], y[k], th[k], v[k], w[k], cmd_v[k], cmd_w[k], a, odo[k], t0, t_ms, step_ms
            )
            t[k] = t_ms
