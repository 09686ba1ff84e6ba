"""The unicycle's motion, written once: the exact arc and the speed ramp that the followers and
the leader share (docs/model/world.md).

Each function is plain Python on floats and a kernel source (`rtsim.world.jit.kernel`):
the ``python`` backend calls it as it is, the ``compiled`` backend's kernels call the same
function compiled by numba, so both backends run these expressions in this order.

**Exact arc.** Holding speed v and turn rate ω for dt seconds moves the unicycle
(ẋ = v cos θ, ẏ = v sin θ, θ̇ = ω) along a circular arc whose chord has length
c = v·dt·sin(Δθ/2)/(Δθ/2) (1 when Δθ = 0) and direction m = θ + Δθ/2, Δθ = ω·dt:

    x' = x + c cos m,   y' = y + c sin m,   θ' = θ + Δθ.

**Speed ramp.** The speed moves from v₀ toward a held target v_t at most a cm/s² (a = inf:
at once). With τ = |v_t − v₀|/a, it reaches v_t when τ ≤ dt and the distance driven over dt
is the exact integral of that ramp-then-hold profile, d = (v₀ + v_t)/2·τ + v_t·(dt − τ),
the mean speed d/dt; otherwise it ends at v₁ = v₀ ± a·dt with mean speed (v₀ + v₁)/2 and
d = that mean times dt (`speed_ramp`, written once). A follower reads the mean speed
(`ramp`), the leader the distance along its path, its limit ``accel`` when speeding up and
``decel`` when slowing down (`leader_travel`).
"""

from __future__ import annotations

import math
from typing import Any

from rtsim.world.ftl import path_pose
from rtsim.world.jit import kernel

__all__ = [
    "actuated",
    "arc",
    "belief_step",
    "chord",
    "clip",
    "follower_advance",
    "GROUP_ROWS",
    "group_advance",
    "world_advance",
    "leader_travel",
    "ramp",
    "ramp_arc",
    "speed_ramp",
]


@kernel
def chord(th: float, v: float, w: float, dt: float) -> tuple[float, float, float, float]:
    """The exact arc's (Δθ, chord c, mid-heading m, sinc term s = sin(Δθ/2)/(Δθ/2))."""
    dth = w * dt
    s = math.sin(0.5 * dth) / (0.5 * dth) if dth != 0.0 else 1.0
    return dth, v * dt * s, th + 0.5 * dth, s


@kernel
def arc(x: float, y: float, th: float, v: float, w: float, dt: float) -> tuple[float, float, float]:
    """The pose after holding (v, ω) for ``dt`` s: the exact arc (module docstring)."""
    dth, c, m, _ = chord(th, v, w, dt)
    return x + c * math.cos(m), y + c * math.sin(m), th + dth


@kernel
def speed_ramp(v0: float, vt: float, a: float, dt: float) -> tuple[float, float, float]:
    """The speed ramp toward ``vt`` at most ``a`` cm/s² over ``dt`` s: (speed after dt,
    distance driven, mean speed) (module docstring)."""
    if dt <= 0.0:
        return v0, v0 * dt, v0
    dv = vt - v0
    if a == math.inf or abs(dv) <= a * dt:
        tau = 0.0 if a == math.inf else abs(dv) / a
        d = 0.5 * (v0 + vt) * tau + vt * (dt - tau)
        return vt, d, d / dt
    v1 = v0 + math.copysign(a * dt, dv)
    vm = 0.5 * (v0 + v1)
    return v1, vm * dt, vm


@kernel
def ramp(v0: float, vc: float, a: float, dt: float) -> tuple[float, float]:
    """A follower's `speed_ramp` toward ``vc``: (speed after dt, mean speed over dt)."""
    v1, _, vm = speed_ramp(v0, vc, a, dt)
    return v1, vm


@kernel
def ramp_arc(
    x: float, y: float, th: float, v: float, w: float, vc: float, wc: float, a: float, dt: float
) -> tuple[float, float, float, float, float, float]:
    """One step of a held command (v_c, ω_c): `ramp`, then `arc` at the ramp's mean speed:
    (x, y, heading, speed after dt, turn rate after dt, mean speed). The unicycle turns at
    once: the turn rate ``w`` it held before is not read, the one after is ω_c."""
    v, vm = ramp(v, vc, a, dt)
    x, y, th = arc(x, y, th, vm, wc, dt)
    return x, y, th, v, wc, vm


@kernel
def belief_step(
    x: float, y: float, th: float, v: float, w: float, vc: float, wc: float, a: float, dt: float
) -> tuple[float, float, float, float, float, float]:
    """`ramp_arc` as an entry of its own (its callers inline it): one held command piece of
    the leader's belief, which the compiled world calls for each piece it carries an estimate
    over (another motion model's ``step`` in its variant, `rtsim.world.motionmodels`)."""
    return ramp_arc(x, y, th, v, w, vc, wc, a, dt)


@kernel
def follower_advance(
    x: float, y: float, th: float, v: float, w: float, vc: float, wc: float, a: float, odo: float,
    t0: float, t_ms: float, step_ms: float,
) -> tuple[float, float, float, float, float, float]:  # fmt: skip
    """A follower holding (v_c, ω_c) integrated from ``t0`` to ``t_ms`` (ms): the exact arc at
    the ramp's mean speed, in steps of at most ``step_ms`` while the ramp lasts longer than
    one step (a shorter ramp is folded into one arc; the heading–speed coupling it ignores is
    below 1e-3 cm for a command's speed change): (x, y, θ, speed, turn rate, odometer)."""
    while t_ms - t0 > 1e-12:
        # the ramp ends within a step (`speed_ramp`'s test; a·dt rounded as ever: bit-identical)
        short = v == vc or abs(vc - v) <= a * step_ms / 1000.0
        h = t_ms - t0 if short else min(step_ms, t_ms - t0)
        dt = h / 1000.0
        x, y, th, v, w, vm = ramp_arc(x, y, th, v, w, vc, wc, a, dt)
        odo += abs(vm) * dt
        t0 += h
    return x, y, th, v, w, odo


#: the rows of a follower group's state array (one column per follower), the compiled
#: backend's truth (`rtsim.world.compiled.FollowerArrays`): x, y, odometer first (the
#: scan's and the truth log's reads, one view), then θ, speed, turn rate, the realised
#: command held and the time (ms) each follower has been integrated to
GROUP_ROWS = ("x", "y", "odometer", "th", "v", "w", "cmd_v", "cmd_w", "t")
GX, GY, GODO, GTH, GV, GW, GCV, GCW, GT = range(len(GROUP_ROWS))


@kernel
def group_advance(S: Any, lo: int, hi: int, t_ms: float, step_ms: float, a: float) -> None:
    """Followers ``lo`` to ``hi`` − 1 of the group state ``S`` (`GROUP_ROWS`) each integrated
    to ``t_ms`` with the command it holds (`follower_advance`, acceleration limit ``a``)
    unless it is there already: `rtsim.world.follower.FollowerGroup`'s loop on its lists,
    on the array in one call."""
    for k in range(lo, hi):
        t0 = S[GT, k]
        if t_ms <= t0:
            continue
        S[GX, k], S[GY, k], S[GTH, k], S[GV, k], S[GW, k], S[GODO, k] = follower_advance(
            S[GX, k], S[GY, k], S[GTH, k], S[GV, k], S[GW, k], S[GCV, k], S[GCW, k], a,
            S[GODO, k], t0, t_ms, step_ms,
        )  # fmt: skip
        S[GT, k] = t_ms


@kernel
def leader_travel(
    v0: float, vt: float, accel: float, decel: float, dt: float
) -> tuple[float, float]:
    """The leader's `speed_ramp` toward its target ``vt``, at ``accel`` speeding up and
    ``decel`` slowing down: (speed after dt, arc length driven)."""
    v1, d, _ = speed_ramp(v0, vt, accel if vt > v0 else decel, dt)
    return v1, d


@kernel
def world_advance(
    S: Any, n: int, t_ms: float, step_ms: float, a: float, v0: float, vt: float, accel: float,
    decel: float, dt: float, s: float, G: Any,
) -> tuple[float, float, float, float, float]:  # fmt: skip
    """`rtsim.world.world.World.advance` in one call: the ``n`` followers of the group state
    ``S`` to ``t_ms`` (`group_advance`), then the leader at arc length ``s`` driven ``dt`` s
    from speed ``v0`` toward ``vt`` (`leader_travel`, `rtsim.world.leader.Leader.advance`)
    on the path ``G`` (the law's geometry, of which `rtsim.world.ftl.path_pose` reads the
    path: `rtsim.world.path.LeaderPath.arrays`): (its speed after, its arc length, its
    pose there)."""
    group_advance(S, 0, n, t_ms, step_ms, a)
    v1, ds = leader_travel(v0, vt, accel, decel, dt)
    s1 = s + ds
    x, y, h = path_pose(G, s1)
    return v1, s1, x, y, h


@kernel
def clip(v: float, lim: float) -> float:
    """``min(max(v, −lim), lim)``, a command's saturation, with Python's choice among equal
    values and its NaN rule (the value itself), written out so that numba compiles the same."""
    m = v
    if -lim > m:
        m = -lim
    if lim < m:
        m = lim
    return m


@kernel
def actuated(
    v: float, w: float, nv: float, nw: float, sv: float, sw: float, v_max: float, w_max: float
) -> tuple[float, float]:
    """The command (v, ω) a follower realises: its actuation noise, standard normals ``nv``,
    ``nw`` times the scales ``sv``, ``sw``, added and the sum saturated to ``v_max``,
    ``w_max`` (`clip`)."""
    return clip(v + sv * nv, v_max), clip(w + sw * nw, w_max)
