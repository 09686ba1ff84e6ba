"""Leader–follower kinematics and the motion-and-sensing bounds (paper §3.2,
docs/model/upper-bounds.md, docs/model/world.md).

Conventions (l-ψ kinematics, Desai/Das), all in the **leader's frame**:

- ρ: distance from the leader's axle point to the follower's axle point (cm);
- β: bearing of the follower, counter-clockwise from the leader's heading, in [0, 2π)
  (trailing followers have β ∈ [π/2, 3π/2]);
- θ = θ_L − θ_F: the leader's heading minus the follower's, in (−π, π];
- V_L, V_F: speeds (cm/s); ω_L: the leader's turn rate (rad/s, positive = left turn).

The rate functions and bounds accept Python/NumPy scalars (fast ``math`` path) or NumPy
arrays (broadcast with ``numpy``). Every bound is returned in **milliseconds**: a bound such
as r_H [cm] / |ρ̇| [cm/s] is in seconds and is multiplied by 1000. A zero denominator gives
an infinite bound.

**Motion models** (`rtsim.world.motionmodels`). The rates ρ̇ (Eq 17) and β̇, hence Eqs
19–21 and the bearing bound, are the relative velocity of two points that move along their
headings at V_L and V_F: they read the state at one instant, not how it evolves, so they
hold for every motion model (each moves a robot along its heading; the model decides how
v, θ and ω change, which the bounds take at their estimates). The one quantity that reads
the model is how far a turn-rate error turns a robot over a window: `TurnError`, which
a model supplies (the predicted-centre bound `msb_localization_predicted` and the
``noise-aware`` policy's padding read it).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from rtsim._numbers import is_real
from rtsim.errors import InputError

__all__ = [
    "R_H_DEFAULT",
    "BOUND_KINDS",
    "LocalizationKind",
    "Thresholds",
    "TurnError",
    "beta_dot",
    "follower_msbs",
    "formation_velocity",
    "msb_bearing",
    "msb_localization",
    "msb_localization_full",
    "msb_localization_predicted",
    "msb_path_diversion",
    "msb_separation",
    "relative_state",
    "relative_states",
    "relative_states_of",
    "rho_dot",
    "scalar_msbs",
    "unicycle_turn_error",
    "slack",
    "wrap_angle",
    "wrap_positive",
]

#: The four motion-and-sensing bounds, in the order rtsim reports them.
BOUND_KINDS: tuple[str, ...] = ("localization", "separation", "path_diversion", "bearing")

LocalizationKind = Literal["radial", "full", "predicted"]
#: The decision's localization bound: Eq 19 (radial), the full displacement, or the bound on
#: what a predicted window centre leaves (`msb_localization_predicted`).
LOCALIZATION_KINDS: tuple[str, ...] = ("radial", "full", "predicted")

_TWO_PI = 2.0 * math.pi


def _xp(*args: Any) -> Any:
    """``numpy`` when any argument is a non-scalar array, else ``math`` (fast scalars)."""
    for a in args:
        if a.__class__ is not float and isinstance(a, np.ndarray) and a.ndim > 0:
            return np
    return math


def wrap_angle(a: Any) -> Any:
    """Wrap an angle (rad) to (−π, π]."""
    if a.__class__ is not float and _xp(a) is np:  # (the float path's operations, each)
        w = np.fmod(a + math.pi, _TWO_PI)
        w = np.where(w < 0.0, w + _TWO_PI, w) - math.pi
        return np.where(w == -math.pi, math.pi, w)
    w = math.fmod(float(a) + math.pi, _TWO_PI)
    if w < 0.0:
        w += _TWO_PI
    w -= math.pi
    return math.pi if w == -math.pi else w


def wrap_positive(a: Any) -> Any:
    """Wrap an angle (rad) to [0, 2π)."""
    if a.__class__ is not float and _xp(a) is np:  # (the float path's operations, each)
        w = np.fmod(a, _TWO_PI)
        w = np.where(w < 0.0, w + _TWO_PI, w)
        return np.where(w >= _TWO_PI, 0.0, w)
    w = math.fmod(float(a), _TWO_PI)
    if w < 0.0:
        w += _TWO_PI
    return 0.0 if w >= _TWO_PI else w


# --------------------------------------------------------------------------- rates


def rho_dot(v_l: Any, v_f: Any, beta: Any, theta: Any) -> Any:
    """Separation rate, Eq 17: ρ̇ = V_F cos(θ + β) − V_L cos β (cm/s)."""
    xp = _xp(v_l, v_f, beta, theta)
    return v_f * xp.cos(theta + beta) - v_l * xp.cos(beta)


def beta_dot(v_l: Any, v_f: Any, beta: Any, theta: Any, rho: Any, omega_l: Any) -> Any:
    """Bearing rate: β̇ = (V_L sin β − V_F sin(β + θ)) / ρ − ω_L (rad/s),
    docs/model/upper-bounds.md."""
    xp = _xp(v_l, v_f, beta, theta, rho, omega_l)
    return (v_l * xp.sin(beta) - v_f * xp.sin(beta + theta)) / rho - omega_l


def relative_state(
    leader_pose: tuple[float, float, float], follower_pose: tuple[float, float, float]
) -> tuple[float, float, float]:
    """(ρ, β, θ) of a follower from world poses (x, y, heading) in cm, cm, rad.

    β = atan2(Δy, Δx) − θ_L wrapped to [0, 2π); θ = θ_L − θ_F wrapped to (−π, π].
    A follower on the leader's axle point (ρ = 0) gets β = 0.
    """
    xl, yl, hl = leader_pose
    xf, yf, hf = follower_pose
    dx, dy = xf - xl, yf - yl
    rho = math.hypot(dx, dy)
    beta = wrap_positive(math.atan2(dy, dx) - hl) if rho > 0.0 else 0.0
    return rho, beta, wrap_angle(hl - hf)


def relative_states(
    leader_poses: Sequence[tuple[float, float, float]],
    follower_poses: Sequence[tuple[float, float, float]],
) -> tuple[list[float], list[float], list[float]]:
    """`relative_state` of each pair (leader pose, follower pose), as the lists (ρ, β, θ):
    the same operations on the same floats pair by pair (equal bit for bit: tests), with
    the loops in C (`relative_states_of` on the poses' columns)."""
    if not follower_poses:
        return [], [], []
    lp = np.array(leader_poses, dtype=float)
    fp = np.array(follower_poses, dtype=float)
    rho, beta, theta = relative_states_of(
        lp[:, 0], lp[:, 1], lp[:, 2], fp[:, 0], fp[:, 1], fp[:, 2]
    )
    return rho.tolist(), beta.tolist(), theta.tolist()


def relative_states_of(
    xl: NDArray[np.float64],
    yl: NDArray[np.float64],
    hl: NDArray[np.float64],
    xf: NDArray[np.float64],
    yf: NDArray[np.float64],
    hf: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """`relative_state` of each pair, from the leaders' and the followers' poses as float64
    arrays (x, y, heading each; equal lengths), as arrays (ρ, β, θ): the differences by
    numpy (the same IEEE subtraction as Python's), ρ and the bearing by ``math.hypot`` and
    ``math.atan2`` on them as Python floats, the wraps on arrays (with the float path's
    operations: `fmod`, then 2π added to a negative remainder)."""
    dx = (xf - xl).tolist()
    dy = (yf - yl).tolist()
    m = len(dx)
    rho = np.fromiter(map(math.hypot, dx, dy), float, m)
    a = np.fromiter(map(math.atan2, dy, dx), float, m) - hl
    beta = np.where(rho > 0.0, wrap_positive(a), 0.0)
    theta = wrap_angle(hl - hf)
    return rho, beta, theta


def formation_velocity(v_l: Any, omega_l: Any, rho: Any, beta: Any) -> tuple[Any, Any]:
    """Steady-formation follower speed V_F and θ (docs/model/world.md).

    In steady formation the follower moves with the leader's frame: its velocity is the
    leader's velocity plus ω_L × r, r = ρ(cos β, sin β) its axle point in the leader's frame,
    i.e. (V_L − ω_L ρ sin β, ω_L ρ cos β) in that frame. Hence
    V_F = √(V_L² − 2 V_L ω_L ρ sin β + ω_L² ρ²) and θ = θ_L − θ_F = −atan2(ω_L ρ cos β,
    V_L − ω_L ρ sin β) ∈ (−π, π] (θ = 0 when V_F = 0). With these, ρ̇ = β̇ = 0.
    """
    xp = _xp(v_l, omega_l, rho, beta)
    vx = v_l - omega_l * rho * xp.sin(beta)
    vy = omega_l * rho * xp.cos(beta)
    v_f = xp.hypot(vx, vy)
    return v_f, wrap_angle(-xp.atan2(vy, vx) if xp is math else -np.arctan2(vy, vx))


# --------------------------------------------------------------------------- bounds


def _ratio_ms(num: Any, den: Any) -> Any:
    """1000·num/|den| (s → ms), ``inf`` where den == 0."""
    if _xp(num, den) is np:
        den = np.abs(np.asarray(den, dtype=float))
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.where(den > 0.0, 1000.0 * np.asarray(num, dtype=float) / den, math.inf)
        return out
    d = abs(float(den))
    return math.inf if d == 0.0 else 1000.0 * float(num) / d


def msb_localization(rho_dot: Any, r_H: Any) -> Any:
    """Localization bound, Eq 19 (the paper's radial form): w ≤ r_H / |ρ̇| (ms)."""
    return _ratio_ms(r_H, rho_dot)


def msb_localization_full(rho_dot: Any, beta_dot: Any, rho: Any, r_H: Any) -> Any:
    """Full-displacement localization bound: w ≤ r_H / √(ρ̇² + ρ²β̇²) (ms),
    docs/model/upper-bounds.md.

    Eq 14→15 drops the tangential displacement ρ·Δβ; this bound keeps it.
    """
    xp = _xp(rho_dot, beta_dot, rho, r_H)
    return _ratio_ms(r_H, xp.hypot(rho_dot, rho * beta_dot))


#: A motion model's turn error (``MotionModel.turn_error``): ``(σ_ω, t) → (σ_θ, σ_∫θ)``, the
#: standard deviations (bounds on them, for any timing of commands) of a robot's heading
#: error t s after a turn-rate actuation error of standard deviation σ_ω (rad/s) starts to
#: act, and of that heading error's integral over the t s (rad·s).
TurnError = Callable[[float, float], tuple[float, float]]


def unicycle_turn_error(turn_sd: float, t: float) -> tuple[float, float]:
    """The unicycle's `TurnError`: its turn rate takes the command at once, so one
    command's error σ_ω held for t s turns it by σ_ω·t, and the integral is ½·σ_ω·t².

    It bounds every model whose turn-rate error is a weighted average of the commands'
    errors with non-negative weights summing to at most 1 (a first-order lag,
    docs/howto/motion-model.md): the heading error is then a sum of command errors with
    non-negative coefficients summing to at most t, whose standard deviation is at most
    σ_ω·t, reached when one error is held from before the window to its end (a command
    lost, or sent after the window)."""
    return turn_sd * t, 0.5 * turn_sd * t * t


def msb_localization_predicted(
    r_H: float,
    *,
    fix_sd: float,
    heading_sd: float,
    speed_sd: float,
    turn_sd: float,
    v_max: float,
    k: float = 3.0,
    leader_error: float = 0.0,
    turn_error: TurnError = unicycle_turn_error,
) -> float:
    """The localization bound when the Hough window is centred at the follower's predicted
    position (ms; docs/localization.md): the largest w with

        k·(√2·σ_fix + √2·σ_fix + V·σ_θ·w + σ_v·w + V·σ_∫θ(w)) + e_L ≤ r_H,

    the follower's departure from its predicted motion — the estimate's position error at
    the last scan (about one fix's, √2·σ_fix as a 2-D radius), its heading error carried
    over the window at speed V = ``v_max``, the speed error σ_v held over the window, the
    turn error's drift V·σ_∫θ(w) (``turn_error``, the motion model's: ½·σ_ω·w² for the
    unicycle, `unicycle_turn_error`) — plus this scan's fix error, each at ``k``
    standard deviations, and ``leader_error`` (cm), the leader's own dead-reckoning error
    over the window. 0 when even w = 0 leaves no room (r_H too small for the noise). The
    unicycle's is solved in closed form, another model's by bisection (its departure grows
    with w)."""
    room = (r_H - leader_error) / k - 2.0 * math.sqrt(2.0) * fix_sd
    if room <= 0.0:
        return 0.0
    b = v_max * heading_sd + speed_sd
    if turn_error is not unicycle_turn_error:
        return 1000.0 * _largest_within(lambda t: b * t + v_max * turn_error(turn_sd, t)[1], room)
    a = 0.5 * v_max * turn_sd
    if a == 0.0:
        return math.inf if b == 0.0 else 1000.0 * room / b
    return 1000.0 * (-b + math.sqrt(b * b + 4.0 * a * room)) / (2.0 * a)


def _largest_within(grow: Callable[[float], float], room: float, t_max: float = 1e6) -> float:
    """The largest t (s) with ``grow(t)`` ≤ ``room``, for ``grow`` non-decreasing from
    grow(0) = 0 (the lower end of the last bisection bracket, to 1e-12 relative; ``inf``
    when even ``t_max`` fits)."""
    hi = 1e-3
    while grow(hi) <= room:
        hi *= 2.0
        if hi > t_max:
            return math.inf
    lo = 0.0
    while hi - lo > 1e-12 * hi:
        mid = 0.5 * (lo + hi)
        if grow(mid) <= room:
            lo = mid
        else:
            hi = mid
    return lo


def msb_separation(rho_dot: Any, T_rho: Any, rho_d: Any) -> Any:
    """Separation bound, Eq 20: w ≤ T_ρ ρ_d / |ρ̇| (ms)."""
    return _ratio_ms(T_rho * rho_d, rho_dot)


def msb_path_diversion(v_f: Any, T_eps: Any, rho_d: Any) -> Any:
    """Path-diversion bound, Eq 21: w ≤ T_ε ρ_d / V_F (ms)."""
    return _ratio_ms(T_eps * rho_d, v_f)


def msb_bearing(beta_dot: Any, T_beta: Any) -> Any:
    """Bearing bound (implied by Eq 23; the paper's text lost it): w ≤ T_β / |β̇| (ms)."""
    return _ratio_ms(T_beta, beta_dot)


def slack(msb_min: float, w_sch: float) -> float:
    """The paper's slack, Eq 22: t_slack = min MSB − w_sch (ms; negative when overloaded).

    The ``slack`` column of ``windows.csv`` is the slack actually granted, max(0, w − w_sch),
    which is 0 in the critical region; this function is the paper's signed quantity.
    """
    return msb_min - w_sch


#: The Hough window radius r_H (cm) when nothing gives one: the paper's r_F = 25 cm. The one
#: default of ``[sensing] r_H`` (a coupled run's one r_H, docs/scenarios.md) and of the
#: world's `DEFAULT_THRESHOLDS`.
R_H_DEFAULT = 25.0


@dataclass(frozen=True)
class Thresholds:
    """Thresholds of the four bounds (docs/model/upper-bounds.md).

    r_H: Hough window radius (cm, the paper takes r_F = 25); T_rho, T_eps: fractions of the
    desired separation ρ_d; T_beta: bearing change per window (rad); localization:
    ``"radial"`` (Eq 19, the paper's), ``"full"`` (radial and tangential displacement) or
    ``"predicted"`` (``predicted_ms``, the bound a predicted window centre leaves).
    """

    r_H: float
    T_rho: float
    T_eps: float
    T_beta: float
    localization: LocalizationKind = "radial"
    #: with ``localization = "predicted"``: the bound (ms) on what the predicted window
    #: centre leaves (`msb_localization_predicted`), the same for every follower
    predicted_ms: float = math.inf

    def __post_init__(self) -> None:
        for name in ("r_H", "T_rho", "T_eps", "T_beta"):
            value = getattr(self, name)
            if not is_real(value):
                raise InputError(f"Thresholds: {name} must be a number, got {value!r}")
            if not (math.isfinite(value) and value > 0.0):
                raise InputError(f"Thresholds: {name} must be positive and finite, got {value!r}")
            object.__setattr__(self, name, float(value))
        if self.localization not in LOCALIZATION_KINDS:
            raise InputError(
                f"Thresholds: localization must be one of "
                f"{', '.join(LOCALIZATION_KINDS)}, got {self.localization!r}"
            )
        if not (is_real(self.predicted_ms) and self.predicted_ms >= 0.0):
            raise InputError(
                f"Thresholds: predicted_ms must be a non-negative number, got {self.predicted_ms!r}"
            )


def scalar_msbs(
    v_l: float,
    omega_l: float,
    v_f: float,
    rho: float,
    beta: float,
    theta: float,
    rho_d: float,
    thr: Thresholds,
) -> tuple[float, float, float, float]:
    """[`follower_msbs`][rtsim.analysis.kinematics.follower_msbs] for scalars, as a tuple in
    `BOUND_KINDS` order (the hot
    path of the coupled run: no dict, no array checks; the same operations)."""
    rd = v_f * math.cos(theta + beta) - v_l * math.cos(beta)
    bd = (v_l * math.sin(beta) - v_f * math.sin(beta + theta)) / rho - omega_l
    ard, abd, avf = abs(float(rd)), abs(float(bd)), abs(float(v_f))
    if thr.localization == "radial":
        loc = math.inf if ard == 0.0 else 1000.0 * thr.r_H / ard
    elif thr.localization == "predicted":
        loc = thr.predicted_ms
    else:
        loc = msb_localization_full(rd, bd, rho, thr.r_H)
    return (
        loc,
        math.inf if ard == 0.0 else 1000.0 * float(thr.T_rho * rho_d) / ard,
        math.inf if avf == 0.0 else 1000.0 * float(thr.T_eps * rho_d) / avf,
        math.inf if abd == 0.0 else 1000.0 * thr.T_beta / abd,
    )


def follower_msbs(
    v_l: float,
    omega_l: float,
    v_f: float,
    rho: float,
    beta: float,
    theta: float,
    rho_d: float,
    thr: Thresholds,
) -> dict[str, float]:
    """The four bounds of one follower (ms), keyed as `BOUND_KINDS`.

    ``localization`` is Eq 19 or the full form, as ``thr.localization`` says.
    """
    if _xp(v_l, omega_l, v_f, rho, beta, theta, rho_d) is math:  # scalar fast path, same ops
        s_loc, sep, path, bear = scalar_msbs(v_l, omega_l, v_f, rho, beta, theta, rho_d, thr)
        return {"localization": s_loc, "separation": sep, "path_diversion": path, "bearing": bear}
    rd = rho_dot(v_l, v_f, beta, theta)
    bd = beta_dot(v_l, v_f, beta, theta, rho, omega_l)
    loc: Any
    if thr.localization == "radial":
        loc = msb_localization(rd, thr.r_H)
    elif thr.localization == "predicted":
        shape = np.broadcast(rd, bd, rho).shape  # the shape the full bound would have
        loc = np.full(shape, thr.predicted_ms) if shape else thr.predicted_ms
    else:
        loc = msb_localization_full(rd, bd, rho, thr.r_H)
    return {
        "localization": loc,
        "separation": msb_separation(rd, thr.T_rho, rho_d),
        "path_diversion": msb_path_diversion(v_f, thr.T_eps, rho_d),
        "bearing": msb_bearing(bd, thr.T_beta),
    }
