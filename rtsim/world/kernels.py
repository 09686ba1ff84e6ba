"""The world's and the controller's numba kernels, as plain Python kernel sources
(`rtsim.world.jit`): the follow-the-leader law's search and projection, CPython's
hypot and remainder, the command-aware rollout and the plan policy's decision
(`rtsim.world.compiled` for the classes that call them and why the results are bit for
bit the Python ones). The motion and the EKF are the world's own functions
(`rtsim.world.motion`, `rtsim.world.ekf`), compiled with the kernels that call
them.

`kernels` compiles `ENTRIES` (or loads them from the cache) once per process;
numba is imported only then.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Iterable
from typing import Any, NamedTuple

import numpy as np

from rtsim.world.contact import closest_over, closest_to, lowest_contact
from rtsim.world.ekf import ekf_command, ekf_predict, ekf_update
from rtsim.world.ftl import _BISECT, _NEWTON, _NEWTON_REACH, _SCALE_MIN, FTL_STEP
from rtsim.world.jit import Subs, build, cached, kernel
from rtsim.world.motion import clip, follower_advance, leader_travel
from rtsim.world.path import along

__all__ = ["announce", "available", "kernels", "warm_all", "warm_rollout"]

_KERNELS: Any = None
_AVAILABLE: bool | None = None


def available() -> bool:
    """Whether numba can be imported (the compiled backend can run)."""
    global _AVAILABLE
    if _AVAILABLE is None:
        try:
            import numba  # noqa: F401
        except Exception:  # ImportError, or a numba that does not fit this numpy
            _AVAILABLE = False
        else:
            _AVAILABLE = True
    return _AVAILABLE


# -- the kernels, as plain Python (numba compiles them; the names are what they call) ---------


@kernel
def _index(s0: Any, lap: float, s: float) -> tuple[int, float]:
    """LeaderPath's segment index at arc length s (bisect_right − 1) and u = s mod lap."""
    u = s % lap
    lo, hi = 0, s0.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if u < s0[mid]:
            hi = mid
        else:
            lo = mid + 1
    return lo - 1, u


@kernel
def _point(
    s0: Any, poses: Any, kappa: Any, lap: float, o: float, s: float
) -> tuple[float, float, float]:
    """TraceFollower.point: LeaderPath.pose(s) moved ``o`` to the left."""
    x, y, h = _pose(s0, poses, kappa, lap, s)
    return x - o * math.sin(h), y + o * math.cos(h), h


@kernel
def _scale(s0: Any, kappa: Any, lap: float, o: float, s: float) -> float:
    k, _ = _index(s0, lap, s)
    return max(_SCALE_MIN, 1.0 - kappa[k] * o)


@kernel
def _gap(
    s0: Any,
    poses: Any,
    kappa: Any,
    lap: float,
    o: float,
    s: float,
    xl: float,
    yl: float,
    rho2: float,
) -> float:
    x, y, _ = _point(s0, poses, kappa, lap, o, s)
    return (x - xl) ** 2 + (y - yl) ** 2 - rho2


@kernel
def _search(
    s0: Any,
    poses: Any,
    kappa: Any,
    lap: float,
    o: float,
    s: float,
    s_l: float,
    xl: float,
    yl: float,
    rho: float,
) -> float:
    """TraceFollower._search (``s`` the last reference, NaN for none); returns s_ref."""
    rho2 = rho * rho
    if not math.isnan(s) and s <= s_l:
        s_n = s
        for _ in range(_NEWTON):
            x, y, h = _point(s0, poses, kappa, lap, o, s_n)
            dx, dy = x - xl, y - yl
            dg = 2.0 * (dx * math.cos(h) + dy * math.sin(h)) * _scale(s0, kappa, lap, o, s_n)
            if dg > -1e-6 * rho:
                break
            step = (dx * dx + dy * dy - rho2) / dg
            s_n -= step
            if abs(s_n - s) > _NEWTON_REACH or s_n > s_l:
                break
            if abs(step) < 1e-9:
                return s_n
    limit = int(lap / FTL_STEP) + 2
    if math.isnan(s) or s > s_l:
        s = s_l
    lo = hi = s
    if _gap(s0, poses, kappa, lap, o, s, xl, yl, rho2) > 0.0:
        lo = s
        for _ in range(limit):
            hi = min(lo + FTL_STEP, s_l)
            if _gap(s0, poses, kappa, lap, o, hi, xl, yl, rho2) <= 0.0 or hi >= s_l:
                break
            lo = hi
    else:
        hi = s
        for _ in range(limit):
            lo = hi - FTL_STEP
            if _gap(s0, poses, kappa, lap, o, lo, xl, yl, rho2) > 0.0:
                break
            hi = lo
    for _ in range(_BISECT):
        mid = 0.5 * (lo + hi)
        if _gap(s0, poses, kappa, lap, o, mid, xl, yl, rho2) > 0.0:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-7:
            break
    return 0.5 * (lo + hi)


@kernel
def _dl_mul(x: float, y: float) -> tuple[float, float]:
    """x·y and its exact rounding error (Dekker's product with Veltkamp's split)."""
    z = x * y
    c = 134217729.0 * x  # 2^27 + 1
    xh = c - (c - x)
    xl = x - xh
    c = 134217729.0 * y
    yh = c - (c - y)
    yl = y - yh
    return z, ((xh * yh - z) + xh * yl + xl * yh) + xl * yl


@kernel
def _hypot_core(ax: float, ay: float, mx: float) -> float:
    _, e = math.frexp(mx)
    scale = math.ldexp(1.0, -e)
    csum, frac1, frac2 = 1.0, 0.0, 0.0
    for v in (ax, ay):
        v *= scale
        hi, lo = _dl_mul(v, v)
        t = csum + hi
        frac2 += (csum - t) + hi
        csum = t
        frac1 += lo
    h = math.sqrt(csum - 1.0 + (frac1 + frac2))
    hi, lo = _dl_mul(-h, h)
    t = csum + hi
    frac2 += (csum - t) + hi
    csum = t
    frac1 += lo
    v = csum - 1.0 + (frac1 + frac2)
    h += v / (2.0 * h)
    return h / scale


@kernel
def _hypot(x: float, y: float) -> float:
    """CPython's ``math.hypot`` of two coordinates (its vector_norm: scaled by a power of
    two, the squares summed with their exact errors, a square root and one differential
    correction); `kernels` checks it against ``math.hypot`` before a kernel uses it."""
    ax, ay = abs(x), abs(y)
    if math.isnan(ax) or math.isnan(ay):
        return math.nan
    mx = ax if ax > ay else ay
    if math.isinf(mx) or mx == 0.0:
        return mx
    _, e = math.frexp(mx)
    if e < -1021:  # subnormal: CPython divides by DBL_MIN first
        dmin = 2.2250738585072014e-308
        return dmin * _hypot_core(ax / dmin, ay / dmin, mx / dmin)
    return _hypot_core(ax, ay, mx)


@kernel
def _pose(s0: Any, poses: Any, kappa: Any, lap: float, s: float) -> tuple[float, float, float]:
    """LeaderPath.pose(s)."""
    k, u = _index(s0, lap, s)
    return along(poses[k, 0], poses[k, 1], poses[k, 2], kappa[k], u - s0[k])


@kernel
def _project(
    s0: Any, poses: Any, kappa: Any, lap: float, o: float, s: float, x: float, y: float
) -> float:
    """TraceFollower.project's Newton steps from ``s`` on the offset-``o`` trace."""
    for _ in range(6):
        px, py, h = _point(s0, poses, kappa, lap, o, s)
        ds = ((x - px) * math.cos(h) + (y - py) * math.sin(h)) / _scale(s0, kappa, lap, o, s)
        s += ds
        if abs(ds) < 1e-3:
            break
    return s


@kernel
def _ftl_exact(
    s0: Any,
    poses: Any,
    kappa: Any,
    lap: float,
    lateral: Any,
    ahead: Any,
    spacing: Any,
    s_ref: Any,
    s_f: Any,
    gain: float,
    lookahead: float,
    k: int,
    s_l: float,
    xl: float,
    yl: float,
    hl: float,
    v_l: float,
    x: float,
    y: float,
    th: float,
) -> tuple[float, float]:
    """TraceFollower.command whole (with `_hypot`): (v, ω); updates s_ref, s_f."""
    chain = np.empty(ahead.shape[0] + 1, dtype=np.int64)
    m = 0
    j = k
    while j >= 0:
        chain[m] = j
        m += 1
        j = ahead[j]
    s_t, tx, ty, th_t, v_t = s_l, xl, yl, hl, v_l
    v_ref = v_l
    for c in range(m - 1, -1, -1):
        q = chain[c]
        o = lateral[q]
        sr = _search(s0, poses, kappa, lap, o, s_ref[q], s_t, tx, ty, spacing[q])
        s_ref[q] = sr
        px, py, hp = _point(s0, poses, kappa, lap, o, sr)
        dx, dy = tx - px, ty - py
        den = dx * math.cos(hp) + dy * math.sin(hp)
        if den <= 0.1 * _hypot(dx, dy):
            v_ref = v_t
        else:
            v_ref = v_t * (dx * math.cos(th_t) + dy * math.sin(th_t)) / den
        if c > 0:
            tx, ty, th_t = _point(s0, poses, kappa, lap, o, sr)
            s_t, v_t = sr, v_ref
    o = lateral[k]
    sf = s_f[k]
    if math.isnan(sf):
        sf = s_ref[k]
    sf = _project(s0, poses, kappa, lap, o, sf, x, y)
    s_f[k] = sf
    v = v_ref + gain * (s_ref[k] - sf) * _scale(s0, kappa, lap, o, sf)
    if not v > 0.0:
        v = 0.0
    ahead_s = sf + lookahead
    if s_l < ahead_s:
        ahead_s = s_l
    gx, gy, _ = _point(s0, poses, kappa, lap, o, ahead_s)
    dx, dy = gx - x, gy - y
    dist = _hypot(dx, dy)
    if dist < 1e-9:
        return v, 0.0
    alpha = math.atan2(dy, dx) - th
    return v, v * 2.0 * math.sin(alpha) / dist


@kernel
def _rollout(
    s0: Any,
    poses: Any,
    kappa: Any,
    lap: float,
    leader_s: float,
    v0: float,
    vt: float,
    accel_max: float,
    decel_max: float,
    x: Any,
    y: Any,
    th: Any,
    v: Any,
    w: Any,
    cmd_v: Any,
    cmd_w: Any,
    odo: Any,
    t_f: Any,
    max_accel: float,
    max_speed: float,
    max_turn: float,
    speed_noise: float,
    turn_noise: float,
    step_ms: float,
    lateral: Any,
    ahead: Any,
    spacing: Any,
    s_ref: Any,
    s_f: Any,
    gain: float,
    lookahead: float,
    ev_t: Any,
    ev_kind: Any,
    ev_k: Any,
    t_now: float,
    out: Any,
) -> None:
    """Rollout._run's event loop: the leader's ramp, the followers' held commands, the
    follow-the-leader commands at the sends (no noise), and at each scan every follower's
    position in the leader frame and odometer (``out[scan, follower]``); the arrays of the
    group and the law are updated in place."""
    n = x.shape[0]
    t_leader = t_now
    s_l = leader_s
    scan = 0
    for e in range(ev_t.shape[0]):
        t = ev_t[e]
        if t > t_leader:
            v0, ds = leader_travel(v0, vt, accel_max, decel_max, (t - t_leader) / 1000.0)
            s_l += ds
            t_leader = t
        lo_k = ev_k[e] if ev_kind[e] == 0 else 0
        hi_k = ev_k[e] + 1 if ev_kind[e] == 0 else n
        for k in range(lo_k, hi_k):
            if t > t_f[k]:
                x[k], y[k], th[k], v[k], w[k], odo[k] = follower_advance(
                    x[k],
                    y[k],
                    th[k],
                    v[k],
                    w[k],
                    cmd_v[k],
                    cmd_w[k],
                    max_accel,
                    odo[k],
                    t_f[k],
                    t,
                    step_ms,
                )
                t_f[k] = t
        xl, yl, hl = _pose(s0, poses, kappa, lap, s_l)
        if ev_kind[e] == 0:
            k = ev_k[e]
            vc, wc = _ftl_exact(
                s0,
                poses,
                kappa,
                lap,
                lateral,
                ahead,
                spacing,
                s_ref,
                s_f,
                gain,
                lookahead,
                k,
                s_l,
                xl,
                yl,
                hl,
                v0,
                x[k],
                y[k],
                th[k],
            )
            vc, wc = clip(vc, max_speed), clip(wc, max_turn)
            cmd_v[k] = clip(vc + speed_noise * 0.0, max_speed)
            cmd_w[k] = clip(wc + turn_noise * 0.0, max_turn)
            continue
        c, s = math.cos(hl), math.sin(hl)
        for i in range(n):
            dx, dy = x[i] - xl, y[i] - yl
            out[scan, i, 0] = c * dx + s * dy
            out[scan, i, 1] = -s * dx + c * dy
            out[scan, i, 2] = odo[i]
        scan += 1


# -- the command-aware rollout's changes, bounds and the plan policy's speed search ---------
# (rtsim.control.rollout.Rollout and rtsim.control.policy.PlanPolicy)


class RolloutScalars(NamedTuple):
    """A rollout's scalars (ms, cm, cm/s, rad), in the order of its float pack (the pack's
    first element; `CompiledRollout` builds it, `scalars`
    reads it back inside the kernels): the five that change from one decision to the next
    come first."""

    leader_s: float
    leader_speed: float
    v_ld: float
    t_now: float
    next_scan: float
    lap: float
    accel: float
    decel: float
    max_accel: float
    max_speed: float
    max_turn: float
    speed_noise: float
    turn_noise: float
    step: float
    gain: float
    lookahead: float
    r_H: float
    T_rho: float
    T_eps: float
    T_beta: float
    predicted: float  # 1.0 when the window follows the predicted motion, else 0.0
    predicted_ms: float


@kernel
def scalars(fs: Any) -> RolloutScalars:
    """The float pack ``fs`` as its named scalars (the field order of RolloutScalars)."""
    return RolloutScalars(
        fs[0], fs[1], fs[2], fs[3], fs[4], fs[5], fs[6], fs[7], fs[8], fs[9], fs[10],
        fs[11], fs[12], fs[13], fs[14], fs[15], fs[16], fs[17], fs[18], fs[19], fs[20], fs[21],
    )  # fmt: skip


#: columns of a rollout's follower pack: the estimate, its speed and turn rate, the held
#: command, the send offset after a window's scan, ρ_d (CompiledRollout builds the rows in
#: this order)
F_X, F_Y, F_TH, F_V, F_W, F_CMD_V, F_CMD_W, F_SEND, F_RHO_D, F_SIZE = range(10)


@kernel
def _remainder(x: float, y: float) -> float:
    """CPython's ``math.remainder`` (its m_remainder) for finite ``y`` ≠ 0: x − n·y with n the
    integer nearest x / y, ties to even, computed exactly with fmod (``%`` of non-negative
    operands, which is fmod)."""
    if math.isnan(x):
        return x
    absx, absy = abs(x), abs(y)
    m = absx % absy
    c = absy - m
    if m < c:
        r = m
    elif m > c:
        r = -c
    else:
        r = m - 2.0 * ((0.5 * (absx - m)) % absy)
    return math.copysign(1.0, x) * r


@kernel
def _before(t1: float, k1: int, j1: int, t2: float, k2: int, j2: int) -> bool:
    """(t1, k1, j1) < (t2, k2, j2) as Python compares tuples."""
    if t1 != t2:
        return t1 < t2
    if k1 != k2:
        return k1 < k2
    return j1 < j2


@kernel
def _rollout_changes(
    v: float,
    lengths: Any,
    P: Any,
    out: Any,
) -> None:
    """Rollout._run whole: the leader set to target ``v`` (Leader.set_speed), the scans and
    sends of windows ``lengths`` in Python's tuple order, `_rollout` on copies of the
    group and the law's search starts, and the changes per window and follower
    (``out[window, follower]``: displacement, |Δρ|, distance, |Δβ|, closest approach).
    ``P``: the state's pack (`rtsim.world.compiled.CompiledRollout.pack`)."""
    fs, fol, pend, s0, poses, kappa, lateral, ahead, spacing, sr0, sf0 = P
    S = scalars(fs)
    n = fol.shape[0]
    nw = lengths.shape[0]
    v_ld = S.v_ld
    speed = S.leader_speed
    t_now = S.t_now
    a = 0.0 if 0.0 > v else v  # min(max(v, 0.0), v_ld), then Leader.set_speed
    if v_ld < a:
        a = v_ld
    target = v_ld if v_ld < a else a
    acc = S.accel if target > speed else S.decel
    if acc == math.inf:
        speed = target
    scans = np.empty(nw + 1)
    scans[0] = S.next_scan
    for j in range(nw):
        scans[j + 1] = scans[j] + lengths[j]
    last = scans[nw]
    cap = n * (pend.shape[1] + nw) + nw + 1
    ev_t = np.empty(cap)
    ev_kind = np.empty(cap, dtype=np.int64)
    ev_k = np.empty(cap, dtype=np.int64)
    m = 0
    for k in range(n):
        for p in range(pend.shape[1]):
            t = pend[k, p]
            if t_now <= t < last:  # NaN pads fail both
                ev_t[m], ev_kind[m], ev_k[m] = t, 0, k
                m += 1
        for j in range(nw):
            t = scans[j] + fol[k, F_SEND]
            if t < last:
                ev_t[m], ev_kind[m], ev_k[m] = t, 0, k
                m += 1
    for j in range(nw + 1):
        ev_t[m], ev_kind[m], ev_k[m] = scans[j], 1, j
        m += 1
    for i in range(1, m):  # insertion sort: Python's sort of the (t, kind, k) tuples
        t, kd, kk = ev_t[i], ev_kind[i], ev_k[i]
        j = i - 1
        while j >= 0 and _before(t, kd, kk, ev_t[j], ev_kind[j], ev_k[j]):
            ev_t[j + 1], ev_kind[j + 1], ev_k[j + 1] = ev_t[j], ev_kind[j], ev_k[j]
            j -= 1
        ev_t[j + 1], ev_kind[j + 1], ev_k[j + 1] = t, kd, kk
    x = fol[:, F_X].copy()
    y = fol[:, F_Y].copy()
    th = fol[:, F_TH].copy()
    vf = fol[:, F_V].copy()
    wf = fol[:, F_W].copy()
    cmd_v = fol[:, F_CMD_V].copy()
    cmd_w = fol[:, F_CMD_W].copy()
    odo = np.zeros(n)
    t_f = np.full(n, t_now)
    samples = np.zeros((nw + 1, n, 3))
    _rollout(
        s0,
        poses,
        kappa,
        S.lap,
        S.leader_s,
        speed,
        target,
        S.accel,
        S.decel,
        x,
        y,
        th,
        vf,
        wf,
        cmd_v,
        cmd_w,
        odo,
        t_f,
        S.max_accel,
        S.max_speed,
        S.max_turn,
        S.speed_noise,
        S.turn_noise,
        S.step,
        lateral,
        ahead,
        spacing,
        sr0.copy(),
        sf0.copy(),
        S.gain,
        S.lookahead,
        ev_t[:m],
        ev_kind[:m],
        ev_k[:m],
        t_now,
        samples,
    )
    two_pi = 2.0 * math.pi
    near = np.empty((nw + 1, n))  # (contact: each follower's closest approach at each scan)
    for j in range(nw + 1):
        for i in range(n):
            near[j, i] = closest_to(samples[j, :, 0], samples[j, :, 1], i, 0.0, 0.0)
    for j in range(nw):
        for i in range(n):
            px, py, po = samples[j, i, 0], samples[j, i, 1], samples[j, i, 2]
            qx, qy, qo = samples[j + 1, i, 0], samples[j + 1, i, 1], samples[j + 1, i, 2]
            out[j, i, 0] = _hypot(qx - px, qy - py)
            out[j, i, 1] = abs(_hypot(qx, qy) - _hypot(px, py))
            out[j, i, 2] = qo - po
            b_q = math.atan2(qy, qx) % two_pi
            b_p = math.atan2(py, px) % two_pi
            out[j, i, 3] = abs(_remainder(b_q - b_p, two_pi))
            out[j, i, 4] = closest_over(near[j, i], near[j + 1, i])


@kernel
def _bound(S: RolloutScalars, rho_d: float, j: int, ci: float, w: float) -> float:
    """Rollout.bounds of one change: L·w / c (∞ when c ≤ 0), L by kind j in BOUND_KINDS
    order; the predicted localization bound in place of kind 0 when the window follows the
    predicted motion."""
    if j == 0 and S.predicted != 0.0:
        return S.predicted_ms
    if j == 0:
        lim = S.r_H
    elif j == 1:
        lim = S.T_rho * rho_d
    elif j == 2:
        lim = S.T_eps * rho_d
    else:
        lim = S.T_beta
    return math.inf if ci <= 0.0 else lim * w / ci


@kernel
def _rows(changes: Any, S: RolloutScalars, fol: Any, w: float, rows: Any) -> float:
    """Rollout.bounds(changes, w) into ``rows`` [follower, kind]; returns min_bound_rows's
    bound (the first smallest)."""
    best = math.inf
    for i in range(changes.shape[0]):
        for j in range(4):
            b = _bound(S, fol[i, F_RHO_D], j, changes[i, j], w)
            rows[i, j] = b
            if b < best:
                best = b
    return best


@kernel
def _min_bound(changes: Any, S: RolloutScalars, fol: Any, w: float) -> float:
    """min_bound_rows(Rollout.bounds(changes, w))[0]: the smallest L·w / c of one window."""
    best = math.inf
    for i in range(changes.shape[0]):
        for j in range(4):
            b = _bound(S, fol[i, F_RHO_D], j, changes[i, j], w)
            if b < best:
                best = b
    return best


@kernel(inline=True)
def _rollout_worst(
    v: float,
    w: float,
    P: Any,
    ch: Any,
    contact: float,
) -> float:
    """PlanPolicy's m(V): the smallest bound of every follower in ``ch.shape[0]`` windows of
    ``w`` ms (Python's ``min`` over the windows: the first, then any smaller), then the
    contact bound at d_c = ``contact`` (0: off); the changes are left in ``ch``."""
    S, fol = scalars(P[0]), P[1]
    _rollout_changes(v, np.full(ch.shape[0], w), P, ch)
    m = _worst_after(ch, S, fol, w, _min_bound(ch[0], S, fol, w))
    return lowest_contact(ch, w, contact, m)  # type: ignore[no-any-return]


@kernel
def _worst_after(ch: Any, S: RolloutScalars, fol: Any, w: float, first: float) -> float:
    """Python's ``min`` over windows: ``first`` (window 0's smallest bound), then any window
    of ``ch`` after it with a smaller one."""
    worst = first
    for j in range(1, ch.shape[0]):
        mj = _min_bound(ch[j], S, fol, w)
        if mj < worst:
            worst = mj
    return worst


@kernel(inline=True)
def _search_into(
    keep: float,
    need: float,
    v_floor: float,
    grid: int,
    tol: float,
    w: float,
    P: Any,
    speeds: Any,
    changes: Any,
    first: int,
    found_out: Any,
    contact: float,
) -> int:
    """search_rollout(m, V_Ld, need, v_floor) with m(V) = keep · `_rollout_worst` over
    ``changes.shape[1]`` windows of ``w`` (contact bound at ``contact``); rollout r's speed
    and changes go to ``speeds[r]`` and ``changes[r]`` from r = ``first`` (as many as they
    hold). ``found_out`` ← (speed, 1 for ``numeric`` or 0 for ``best``, the found speed or
    NaN, the index of the speed's rollout or −1); returns the next free index (rollouts run:
    it − first)."""
    v_ld = scalars(P[0]).v_ld
    cap = speeds.shape[0]
    scratch = np.empty(changes.shape[1:])
    above = v_ld
    lo = hi = 0.0
    r_lo = -1
    # the scan's m and rollout index per j, replayed after the floor when none passes
    scan_m = np.empty(grid)
    scan_r = np.empty(grid, dtype=np.int64)
    m_floor, r_floor = -math.inf, -1
    r = first
    # one rollout per pass (one call site keeps the compiled code small): phase 1 the scan's
    # j-th speed, 2 the bisection, 0 the floor — last: its m matters only when no scanned
    # speed passes, so a search that brackets never rolls it out (search_rollout's order)
    phase = 1
    j = 1
    while True:
        if phase == 1 and j >= grid:
            if not v_floor > 0.0:
                break
            phase = 0
        if phase == 0:
            v = v_floor
        elif phase == 1:
            v = v_ld * (1.0 - j / grid)
        else:
            if not hi - lo > tol * v_ld:
                found_out[0], found_out[1], found_out[2], found_out[3] = lo, 1.0, lo, r_lo
                return r
            v = 0.5 * (lo + hi)
        ch = changes[r] if r < cap else scratch
        if r < cap:
            speeds[r] = v
        r_v = r if r < cap else -1
        r += 1
        m = keep * _rollout_worst(v, w, P, ch, contact)
        if phase == 0:
            m_floor, r_floor = m, r_v
            break
        if phase == 1:
            if m >= need:
                lo, hi, r_lo, phase = v, above, r_v, 2
            else:
                scan_m[j], scan_r[j] = m, r_v
                above = v
                j += 1
        elif m >= need:
            lo, r_lo = v, r_v
        else:
            hi = v
    # none passed: the least-bad speed, compared as if the floor came first
    best_v, best_m, best_r = v_floor, m_floor, r_floor
    for i in range(1, grid):
        if scan_m[i] > best_m:
            best_v, best_m, best_r = v_ld * (1.0 - i / grid), scan_m[i], scan_r[i]
    found_out[0], found_out[1], found_out[2], found_out[3] = best_v, 0.0, math.nan, best_r
    return r


@kernel
def _plan_decide(
    search_only: bool,
    keep: float,
    need: float,
    cap: float,
    v_floor: float,
    grid: int,
    tol: float,
    w: float,
    P: Any,
    speeds: Any,
    lens: Any,
    changes: Any,
    rows: Any,
    out: Any,
    contact: float,
) -> int:
    """PlanPolicy.decide's numbers over ``changes.shape[1]`` windows of ``w`` (the horizon H),
    with the contact bound at d_c = ``contact`` cm (0: off; `rtsim.world.contact`).

    Rows: ``rows[0]`` the bounds at V_Ld in the window the decision governs, ``rows[1]``
    those at the chosen speed; ``out`` ← (w, V_L, method: 0 none, 1 numeric, 2 best, the
    found speed or NaN, feasible 1/0 — NaN, with ``rows[1]`` not filled, when the chosen speed
    was not rolled out in the search (a zero floor) — the length of the longer first
    window checked).
    Every rollout goes to ``speeds[r]``, ``changes[r]`` with ``lens[r]``: 0 the horizon, 1
    the horizon and its first window as a one-window rollout of w (the sends after that
    window's closing scan cannot change it: they come after the sample), 2 one window of
    ``out[5]`` (in ``changes[r, 0]``); returns how many.

    ``search_only``: only the speed search (search_rollout with m(V) = keep · the smallest
    bound over H; ``adjust`` with the ``commands`` predictor, H one window): from rollout 0,
    ``out[1:4]`` its (speed, method, found), every rollout the search's own (``lens`` 0).
    """
    S, fol = scalars(P[0]), P[1]
    v_ld = S.v_ld
    res = np.empty(4)
    # (one call site of the inlined search: the search-only decision and the plan's search
    # share it, which halves the compiled code)
    first = 0 if search_only else 1
    feasible = False
    if not search_only:
        speeds[0], lens[0] = v_ld, 1
        m_ld = _rollout_worst(v_ld, w, P, changes[0], contact)
        m1 = _rows(changes[0, 0], S, fol, w, rows[0])
        feasible = keep * m_ld >= need
    if feasible:
        a = keep * m1
        mn = cap if cap < a else a  # max(w, min(keep·m1, cap)), as Python picks
        ww = mn if mn > w else w
        runs = 1
        if ww > w:  # the longer first window, checked by its own rollout
            speeds[1], lens[1] = v_ld, 2
            m_w = _rollout_worst(v_ld, ww, P, changes[1, 0:1], contact)
            runs = 2
            out[5] = ww
            if keep * m_w < ww:
                t = keep * m_w
                ww = t if t > w else w
        for i in range(rows.shape[1]):  # rows[1] = rows[0], without numba's shape-error
            for j in range(rows.shape[2]):  # message (its string formatting compiles ~3 s)
                rows[1, i, j] = rows[0, i, j]
        out[0], out[1], out[2], out[3], out[4] = ww, v_ld, 0.0, math.nan, 1.0
        return runs
    runs = _search_into(keep, need, v_floor, grid, tol, w, P, speeds, changes, first, res, contact)
    for r in range(first, min(runs, speeds.shape[0])):
        lens[r] = 0
    if search_only:
        out[0], out[1], out[2], out[3], out[4] = w, res[0], 2.0 - res[1], res[2], math.nan
        return runs
    v_l, r_l = res[0], int(res[3])
    out[0], out[1], out[2], out[3] = w, v_l, 2.0 - res[1], res[2]
    if r_l < 0:  # the speed was not rolled out (a zero floor): the caller rolls it out
        return runs
    lens[r_l] = 1
    m_l = _worst_after(changes[r_l], S, fol, w, _rows(changes[r_l, 0], S, fol, w, rows[1]))
    m_l = lowest_contact(changes[r_l], w, contact, m_l)
    out[4] = 1.0 if keep * m_l >= need else 0.0
    return runs


#: the kernels the classes call, by the name they have in `kernels`'s namespace (each
#: compiled with the kernel sources it calls: `rtsim.world.jit.compile`)
ENTRIES: dict[str, Any] = {
    "advance_follower": follower_advance,
    "ekf_command": ekf_command,
    "ekf_predict": ekf_predict,
    "ekf_update": ekf_update,
    "ftl_exact": _ftl_exact,
    "project": _project,
    "hypot": _hypot,
    "remainder": _remainder,
    "rollout_changes": _rollout_changes,
    "plan_decide": _plan_decide,
}


#: the entries only a run that rolls out calls (compiled by `warm_rollout`)
ROLLOUT_ENTRIES = ("rollout_changes", "plan_decide")

#: the entries that run a motion model's parts (built again for a model other than the
#: unicycle: `kernels`)
MOTION_ENTRIES = ("advance_follower", "ekf_command", *ROLLOUT_ENTRIES)

#: about how long compiling takes, CPU s on a 2-core machine (numba 0.68; measured with a
#: fresh NUMBA_CACHE_DIR, docs/performance.md): the world's entries, the rollout's
COMPILE_S = {"world": 4.0, "rollout": 6.0}

_ANNOUNCED = False


def announce(sources: Iterable[Any], seconds: float, subs: Subs = ()) -> bool:
    """Say on stderr, in one line and once per process, that the kernels are being compiled
    (once per install, about ``seconds``), when any of the kernel ``sources`` (with
    ``subs``) has no build in the cache and progress is shown
    (`rtsim.sim.progress.progress_enabled`: a terminal, or ``RTSIM_PROGRESS=1``); nothing
    when they load from the cache. Returns whether it said so."""
    global _ANNOUNCED
    if _ANNOUNCED or all(cached(fn, subs) for fn in sources):
        return False
    _ANNOUNCED = True  # (asked once: a later group compiles under the same line)
    from rtsim.sim.progress import progress_enabled  # lazy: rtsim.sim loads simpy

    if not progress_enabled():
        return False
    from tqdm.auto import tqdm

    line = f"rtsim: compiling the world's kernels (once per install, about {seconds:.0f} s)..."
    tqdm.write(line, file=sys.stderr)  # (above a progress bar that is open, on a line of its own)
    sys.stderr.flush()
    return True


def _sources(names: Iterable[str], subs: Subs = ()) -> list[Any]:
    """The kernel sources of entries ``names`` for substitutions ``subs`` (an entry that is
    itself a substituted part is its replacement)."""
    swap = dict(subs)
    return [swap.get(ENTRIES[name], ENTRIES[name]) for name in names]


_BY_MODEL: dict[Subs, Any] = {}


def kernels(motion: Any = None) -> Any:
    """The compiled kernels (a namespace), compiled or loaded from the cache once per
    process (saying so when they compile: `announce`, with the rollout's time when
    those are not cached either, as most runs roll out next). ``motion``: a motion model
    (`rtsim.world.motionmodels.MotionModel`; None: the unicycle) whose parts the
    `MOTION_ENTRIES` run (the others are the unicycle's namespace's)."""
    global _KERNELS
    if _KERNELS is None:
        import types

        world = [fn for name, fn in ENTRIES.items() if name not in ROLLOUT_ENTRIES]
        if not all(cached(fn) for fn in world):
            rollout = [ENTRIES[name] for name in ROLLOUT_ENTRIES]
            later = 0.0 if all(cached(fn) for fn in rollout) else COMPILE_S["rollout"]
            announce(world, COMPILE_S["world"] + later)
        ns = types.SimpleNamespace(**{name: build(fn) for name, fn in ENTRIES.items()})
        _warm(ns)
        ns.exact_hypot = _hypot_matches(ns.hypot)
        _KERNELS = ns
    subs: Subs = () if motion is None else motion.subs
    if not subs:
        return _KERNELS
    model_ns = _BY_MODEL.get(subs)
    if model_ns is None:
        import types

        world = [n for n in MOTION_ENTRIES if n not in ROLLOUT_ENTRIES]
        announce(_sources(world, subs), COMPILE_S["world"], subs)
        model_ns = types.SimpleNamespace(**vars(_KERNELS))
        for name, fn in zip(MOTION_ENTRIES, _sources(MOTION_ENTRIES, subs), strict=True):
            setattr(model_ns, name, build(fn, subs))
        model_ns.rollout_warm = False
        model_ns.subs = subs
        _warm(model_ns)
        _BY_MODEL[subs] = model_ns
    return model_ns


def _hypot_matches(fn: Any, count: int = 20000) -> bool:
    """Whether the compiled hypot gives this interpreter's ``math.hypot`` bit for bit on
    ``count`` random pairs over the whole exponent range and the edge cases (a kernel that
    needs a hypot is only used when it does)."""
    rng = np.random.default_rng(20261124)
    a = rng.standard_normal((count, 2)) * 10.0 ** rng.integers(-30, 30, (count, 2))
    edge = [
        (0.0, 0.0),
        (0.0, -3.0),
        (3.0, 4.0),
        (1e-320, 3e-321),
        (1e308, 1e308),
        (5e-324, 0.0),
        (1.0, 1e-17),
        (-0.0, 2.5),
        (325.0, 325.0),
    ]
    pairs = [*edge, *map(tuple, a.tolist())]
    return all(fn(x, y) == math.hypot(x, y) for x, y in pairs)


def _warm(ns: Any) -> None:
    """Call every kernel once on dummy values, so that compiling it (the first time on a
    machine) or loading it from numba's cache happens when the world is built, not inside
    the first window."""
    ns.advance_follower(0.0, 0.0, 0.0, 1.0, 0.0, 2.0, 0.1, 10.0, 0.0, 0.0, 20.0, 10.0)
    ns.ekf_command(*([1.0] * 19))
    ns.ekf_predict(*([1.0] * 16))
    ns.ekf_update(*([1.0] * 15))
    one = np.zeros(1)
    ns.ftl_exact(
        np.zeros(1),
        np.zeros((1, 3)),
        np.zeros(1),
        100.0,
        one,
        np.full(1, -1),
        np.ones(1),
        np.full(1, math.nan),
        np.full(1, math.nan),
        0.5,
        10.0,
        0,
        50.0,
        50.0,
        0.0,
        0.0,
        1.0,
        0.0,
        0.0,
        0.0,
    )
    ns.project(np.zeros(1), np.zeros((1, 3)), np.zeros(1), 100.0, 0.0, 10.0, 20.0, 1.0)
    # (the rollout's kernels: warm_rollout, when a run first rolls out)


def warm_rollout(motion: Any = None) -> None:
    """Compile the rollout's kernels (or load them from numba's cache) once per process:
    called when the first compiled rollout is made (a coupled run makes it while it is set
    up, before the loop), so a run that never rolls out never compiles them. ``motion``: as
    `kernels`."""
    ns = kernels(motion)
    if getattr(ns, "rollout_warm", False):
        return
    subs = getattr(ns, "subs", ())
    announce(_sources(ROLLOUT_ENTRIES, subs), COMPILE_S["rollout"], subs)
    # one follower 100 cm behind a leader on a straight lap
    fs = np.array(
        RolloutScalars(
            *(0.0, 30.0, 30.0, 0.0, 0.0),  # leader_s, leader_speed, v_ld, t_now, next_scan
            lap=1e3,
            accel=20.0,
            decel=50.0,
            max_accel=100.0,
            max_speed=150.0,
            max_turn=3.0,
            speed_noise=0.0,
            turn_noise=0.0,
            step=10.0,
            gain=0.5,
            lookahead=40.0,
            r_H=25.0,
            T_rho=0.005,
            T_eps=0.025,
            T_beta=0.1,
            predicted=0.0,
            predicted_ms=0.0,
        )
    )
    fol = np.zeros((1, F_SIZE))
    fol[0, F_X], fol[0, F_V], fol[0, F_SEND], fol[0, F_RHO_D] = -100.0, 30.0, 100.0, 100.0
    nan1 = np.full(1, math.nan)
    path = (np.zeros(1), np.zeros((1, 3)), np.zeros(1), np.zeros(1), np.full(1, -1))
    P = (fs, fol, np.full((1, 1), math.nan), *path, np.full(1, 100.0), nan1, nan1)
    ch = np.empty((64, 2, 1, 5))
    ns.rollout_changes(20.0, np.full(2, 240.0), P, ch[0])
    bufs = (np.empty(64), np.zeros(64, dtype=np.int64), ch, np.empty((2, 1, 4)), np.empty(6))
    for search_only in (True, False):
        ns.plan_decide(search_only, 1.0, 240.0, 1e3, 3.0, 8, 0.005, 240.0, P, *bufs, 60.0)
    ns.rollout_warm = True


def warm_all() -> None:
    """Compile the kernels a coupled run of the compiled backend uses (the world's and the
    rollout's), or load them from the cache, in this process: called before a process pool
    starts (``rtsim reproduce``, the sweep engine), so that workers forked after it inherit
    them and spawned ones load what it cached: the first run pays the compile once, not once
    per worker."""
    warm_rollout()
