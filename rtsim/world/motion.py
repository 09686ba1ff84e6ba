"""The unicycle's motion, written once: the exact arc, the followers' speed ramp and the
leader's (docs/model/world.md).

Each function is plain Python on floats and a kernel source (`rtsim.world.jit.kernel`):
the ``python`` backend calls it as it is, the ``compiled`` backend's kernels call the same
function compiled by numba, so both backends run these expressions in this order.

**Exact arc.** Holding speed v and turn rate ω for dt seconds moves the unicycle
(ẋ = v cos θ, ẏ = v sin θ, θ̇ = ω) along a circular arc whose chord has length
c = v·dt·sin(Δθ/2)/(Δθ/2) (1 when Δθ = 0) and direction m = θ + Δθ/2, Δθ = ω·dt:

    x' = x + c cos m,   y' = y + c sin m,   θ' = θ + Δθ.

**Followers' ramp.** The wheel speed moves from v₀ toward the held command v_c at most a
cm/s² (a = inf: at once); with τ = |v_c − v₀|/a the mean speed over dt is
((v₀ + v_c)/2·τ + v_c·(dt − τ))/dt when τ ≤ dt (the speed reaches v_c), else (v₀ + v₁)/2
with v₁ = v₀ ± a·dt.

**Leader's ramp.** The leader's speed moves toward its target at ``accel`` cm/s² when
speeding up and ``decel`` when slowing down; the arc length it drives over dt is the exact
integral of that ramp-then-hold profile, (v₀ + v_t)/2·τ + v_t·(dt − τ) (τ ≤ dt) or
(v₀ + v₁)/2·dt. (It is kept apart from the followers' ramp: the leader's arc length is
summed directly, not as a mean speed times dt, and ties τ = dt round differently.)
"""

from __future__ import annotations

import math

from rtsim.world.jit import kernel

__all__ = ["arc", "chord", "clip", "follower_advance", "leader_travel", "ramp", "ramp_arc"]


@kernel(inline=True)
def chord(th: float, v: float, w: float, dt: float) -> tuple[float, float, float, float]:
    """The exact arc's (Δθ, chord c, mid-heading m, sinc term s = sin(Δθ/2)/(Δθ/2))."""
    dth = w * dt
    s = math.sin(0.5 * dth) / (0.5 * dth) if dth != 0.0 else 1.0
    return dth, v * dt * s, th + 0.5 * dth, s


@kernel(inline=True)
def arc(x: float, y: float, th: float, v: float, w: float, dt: float) -> tuple[float, float, float]:
    """The pose after holding (v, ω) for ``dt`` s: the exact arc (module docstring)."""
    dth, c, m, _ = chord(th, v, w, dt)
    return x + c * math.cos(m), y + c * math.sin(m), th + dth


@kernel(inline=True)
def ramp(v0: float, vc: float, a: float, dt: float) -> tuple[float, float]:
    """A follower's speed ramp toward ``vc`` at most ``a`` cm/s² over ``dt`` s: (speed after
    dt, mean speed over dt) (module docstring)."""
    if dt <= 0.0:
        return v0, v0
    dv = vc - v0
    if a == math.inf or abs(dv) <= a * dt:
        tau = 0.0 if a == math.inf else abs(dv) / a
        return vc, ((v0 + vc) * 0.5 * tau + vc * (dt - tau)) / dt
    v1 = v0 + math.copysign(a * dt, dv)
    return v1, 0.5 * (v0 + v1)


@kernel(inline=True)
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
def follower_advance(
    x: float, y: float, th: float, v: float, w: float, vc: float, wc: float, a: float, odo: float,
    t0: float, t_ms: float, step_ms: float,
) -> tuple[float, float, float, float, float, float]:  # fmt: skip
    """A follower holding (v_c, ω_c) integrated from ``t0`` to ``t_ms`` (ms): the exact arc at
    the ramp's mean speed, in steps of at most ``step_ms`` while the ramp lasts longer than
    one step (a shorter ramp is folded into one arc; the heading–speed coupling it ignores is
    below 1e-3 cm for a command's speed change): (x, y, θ, speed, turn rate, odometer)."""
    while t_ms - t0 > 1e-12:
        short = v == vc or abs(vc - v) <= a * step_ms / 1000.0
        h = t_ms - t0 if short else min(step_ms, t_ms - t0)
        dt = h / 1000.0
        x, y, th, v, w, vm = ramp_arc(x, y, th, v, w, vc, wc, a, dt)
        odo += abs(vm) * dt
        t0 += h
    return x, y, th, v, w, odo


@kernel
def leader_travel(
    v0: float, vt: float, accel: float, decel: float, dt: float
) -> tuple[float, float]:
    """The leader's speed ramp toward its target ``vt`` over ``dt`` s: (speed after dt, arc
    length driven) (module docstring)."""
    if v0 == vt or dt <= 0.0:
        return v0, v0 * dt
    a = accel if vt > v0 else decel
    tau = abs(vt - v0) / a
    if tau <= dt:
        return vt, 0.5 * (v0 + vt) * tau + vt * (dt - tau)
    v1 = v0 + math.copysign(a * dt, vt - v0)
    return v1, 0.5 * (v0 + v1) * dt


@kernel(inline=True)
def clip(v: float, lim: float) -> float:
    """``min(max(v, −lim), lim)``, a command's saturation, with Python's choice among equal
    values and its NaN rule (the value itself), written out so that numba compiles the same."""
    m = v
    if -lim > m:
        m = -lim
    if lim < m:
        m = lim
    return m
