"""The controller's numba kernels, as plain Python kernel sources (`rtsim.world.jit`): the
command-aware rollout (`rtsim.control.rollout.Rollout`), its bounds and the ``plan``
policy's decision or the ``commands`` speed search (`rtsim.control.policy.PlanPolicy`).
They call the world's kernel sources (the motion model's parts: `rtsim.world.motion`; the
follow-the-leader law: `rtsim.world.ftl`; CPython's hypot and remainder:
`rtsim.world.exactmath`); the cache keyed on source hashes sees an edit there.
`rtsim.control.compiled_rollout.CompiledRollout` packs a state and calls them.

`rollout_kernels` compiles `ENTRIES` (or loads them from the cache) once per process and
motion model, when a run first rolls out.
"""

from __future__ import annotations

import functools
import math
import types
from typing import Any, NamedTuple

import numpy as np

from rtsim.world import scanstep
from rtsim.world.contact import closest_over, closest_to, lowest_contact
from rtsim.world.exactmath import cpython_hypot, cpython_remainder
from rtsim.world.ftl import ftl_command_frame, path_frame
from rtsim.world.jit import Subs, build, kernel
from rtsim.world.kernels import announce, follow_with, kernels
from rtsim.world.motion import clip, follower_advance, leader_travel

__all__ = [
    "ENTRIES",
    "FollowerColumns",
    "RolloutScalars",
    "columns",
    "rollout_kernels",
    "scalars",
    "warm_all",
    "warm_rollout",
]


@kernel(inline=True)
def _rollout(
    G: Any,
    grp: Any,
    max_accel: float,
    max_speed: float,
    max_turn: float,
    speed_noise: float,
    turn_noise: float,
    step_ms: float,
    s_ref: Any,
    s_f: Any,
    gain: float,
    lookahead: float,
    ev_t: Any,
    ev_kind: Any,
    ev_k: Any,
    trace: Any,
    e0: int,
    e_end: int,
    scan: int,
    stop: int,
    out: Any,
) -> int:
    """Rollout._run's event loop: the followers' held commands, the follow-the-leader
    commands at the sends (no noise), and at each scan every follower's position in the
    leader frame and odometer (``out[scan, follower]``), the leader at each event where
    `_lead` put it (``trace``); the group ``grp`` (its rows x, y, θ, v, ω, held v, held ω,
    odometer, time: `_work`; indexed, not viewed: a view of a row is a reference count at
    each entry) and the law's arrays are updated in place.

    From event ``e0``, ``scan`` scans written, until the sample of scan ``stop`` is written
    (then the next event's index is returned: a later call resumes there with the same
    numbers) or event ``e_end`` is reached (returned)."""
    n = grp.shape[1]
    for e in range(e0, e_end):
        t = ev_t[e]
        lo_k = ev_k[e] if ev_kind[e] == 0 else 0
        hi_k = ev_k[e] + 1 if ev_kind[e] == 0 else n
        for k in range(lo_k, hi_k):
            if t > grp[8, k]:
                (
                    grp[0, k], grp[1, k], grp[2, k], grp[3, k], grp[4, k], grp[7, k]
                ) = follower_advance(
                    grp[0, k], grp[1, k], grp[2, k], grp[3, k], grp[4, k], grp[5, k], grp[6, k],
                    max_accel, grp[7, k], grp[8, k], t, step_ms,
                )  # fmt: skip
                grp[8, k] = t
        s_l, v0 = trace[e, 0], trace[e, 1]
        # (the leader's frame: its heading's cosine and sine are math.cos/math.sin of it)
        xl, yl, _, c, s = path_frame(G, s_l)
        if ev_kind[e] == 0:
            k = ev_k[e]
            vc, wc = ftl_command_frame(
                G, s_ref, s_f, gain, lookahead, k, s_l, xl, yl, c, s, v0,
                grp[0, k], grp[1, k], grp[2, k],
            )  # fmt: skip
            vc, wc = clip(vc, max_speed), clip(wc, max_turn)
            grp[5, k] = clip(vc + speed_noise * 0.0, max_speed)
            grp[6, k] = clip(wc + turn_noise * 0.0, max_turn)
            continue
        for i in range(n):
            dx, dy = grp[0, i] - xl, grp[1, i] - yl
            out[scan, i, 0] = c * dx + s * dy
            out[scan, i, 1] = -s * dx + c * dy
            out[scan, i, 2] = grp[7, i]
        scan += 1
        if scan > stop:
            return e + 1
    return e_end


@kernel
def _lead(v: float, P: Any, ev_t: Any, trace: Any) -> None:
    """The leader of a rollout with target ``v`` (Leader.set_speed, then its ramp between
    events, Rollout._run's order): ``trace[e]`` ← its (arc length, speed) at event e. The
    followers see the leader only through these: two targets whose traces are equal bit
    for bit give the same rollout."""
    S = scalars(P[0])
    v_ld = S.v_ld
    speed = S.leader_speed
    a = 0.0 if 0.0 > v else v  # min(max(v, 0.0), v_ld), then Leader.set_speed
    if v_ld < a:
        a = v_ld
    target = v_ld if v_ld < a else a
    acc = S.accel if target > speed else S.decel
    if acc == math.inf:
        speed = target
    t_leader, s_l, v0 = S.t_now, S.leader_s, speed
    for e in range(ev_t.shape[0]):
        t = ev_t[e]
        if t > t_leader:
            v0, ds = leader_travel(v0, target, S.accel, S.decel, (t - t_leader) / 1000.0)
            s_l += ds
            t_leader = t
        trace[e, 0], trace[e, 1] = s_l, v0


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
        fs[11], fs[12], fs[13], fs[14], fs[15], fs[16], fs[17], fs[18], fs[19], fs[20],
    )  # fmt: skip


class FollowerColumns(NamedTuple):
    """A rollout's follower pack (one row per follower) by column, in the order of its
    columns (`CompiledRollout` builds the rows, `columns` reads them inside the kernels): the
    estimate (cm, cm, rad), its speed (cm/s) and turn rate (rad/s), the held command (cm/s,
    rad/s), the send offset after a window's scan (ms), ρ_d (cm)."""

    x: Any
    y: Any
    th: Any
    v: Any
    w: Any
    cmd_v: Any
    cmd_w: Any
    send: Any
    rho_d: Any


@kernel
def columns(fol: Any) -> FollowerColumns:
    """The follower pack ``fol`` as its named columns (views; the field order of
    FollowerColumns)."""
    return FollowerColumns(
        fol[:, 0], fol[:, 1], fol[:, 2], fol[:, 3], fol[:, 4], fol[:, 5], fol[:, 6], fol[:, 7],
        fol[:, 8],
    )  # fmt: skip


#: the follower pack's send-offset and ρ_d columns (the kernels index them: no view per call)
_SEND = FollowerColumns._fields.index("send")
_RHO_D = FollowerColumns._fields.index("rho_d")


@kernel
def _before(t1: float, k1: int, j1: int, t2: float, k2: int, j2: int) -> bool:
    """(t1, k1, j1) < (t2, k2, j2) as Python compares tuples."""
    if t1 != t2:
        return t1 < t2
    if k1 != k2:
        return k1 < k2
    return j1 < j2


@kernel
def _events(lengths: Any, P: Any) -> tuple[Any, Any, Any]:
    """The scans and sends of windows ``lengths`` from the state's next scan, in Python's
    order of the (time, kind, follower or scan) tuples (Rollout._run's): (times, kinds — 0 a
    send, 1 a scan —, follower or scan index). The same for every target."""
    fs, fol, pend = P[0], P[1], P[2]
    S = scalars(fs)
    n = fol.shape[0]
    nw = lengths.shape[0]
    t_now = S.t_now
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
            t = scans[j] + fol[k, _SEND]
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
    return ev_t[:m], ev_kind[:m], ev_k[:m]


@kernel
def _rollout_changes(
    v: float,
    lengths: Any,
    P: Any,
    out: Any,
    keep: float,
    need: float,
    contact: float,
) -> int:
    """Rollout._run whole: the leader set to target ``v`` (`_lead`), the scans and sends of
    windows ``lengths`` (`_events`), and the changes per window and follower (`_roll`).
    ``P``: the state's pack (`rtsim.control.compiled_rollout.CompiledRollout.pack`);
    ``keep``, ``need``, ``contact`` and the return value: `_roll`'s."""
    ev_t, ev_kind, ev_k = _events(lengths, P)
    trace = np.empty((ev_t.shape[0], 2))
    _lead(v, P, ev_t, trace)
    W = _work(P, lengths.shape[0], 0)
    return _roll(lengths, P, ev_t, ev_kind, ev_k, trace, out, keep, need, contact, W)


@kernel
def _work(P: Any, nw: int, n_ev: int) -> tuple[Any, Any, Any, Any, Any]:
    """`_roll`'s scratch for rollouts of up to ``nw`` windows on pack ``P``, made once per
    call from Python and reused by each rollout of it (fresh arrays per rollout cost more than
    the rollout's own arithmetic at two followers): the group's nine columns (x, y, θ, v, ω,
    held v, held ω, odometer, time), the samples at the scans (leader-frame x, y, odometer,
    range, bearing), the closest approaches at the scans, the law's search starts (two
    rows), and the first window's prefix (`_keep_prefix`) of a rollout over up to ``n_ev``
    events (0: none kept; its first element, the mode, 0)."""
    n = P[1].shape[0]
    ns = P[4].shape[0]
    pre = np.empty(_PREFIX + 12 * n + 2 * ns + 5 * n_ev)
    pre[0], pre[1] = 0.0, 0.0
    return (
        np.empty((9, n)),
        np.empty((nw + 1, n, 5)),
        np.empty((nw + 1, n)),
        np.empty((2, ns)),
        pre,
    )


@kernel
def _scans_before(ev_kind: Any, e: int) -> int:
    """How many of the first ``e`` events are scans."""
    m = 0
    for i in range(e):
        m += ev_kind[i]
    return m  # type: ignore[no-any-return]


#: the prefix scratch's header: (mode — 0 none, 1 keep it, 2 start from it —, its events)
_PREFIX = 2


@kernel
def _keep_prefix(pre: Any, grp: Any, srf: Any, samples: Any, ev: Any, trace: Any, p: int) -> None:
    """Keep in ``pre`` a rollout's state after its first ``p`` events (those before its
    second scan, ``ev`` = its events, ``trace`` its leader): the group, the law's search
    starts, the first scan's samples, and the events and leader they came from."""
    ev_t, ev_kind, ev_k = ev
    n, ns = grp.shape[1], srf.shape[1]
    pre[1] = p
    o = _PREFIX
    for c in range(9):
        for i in range(n):
            pre[o] = grp[c, i]
            o += 1
    for c in range(2):
        for i in range(ns):
            pre[o] = srf[c, i]
            o += 1
    for i in range(n):
        for c in range(3):
            pre[o] = samples[0, i, c]
            o += 1
    for e in range(p):
        pre[o], pre[o + 1], pre[o + 2] = ev_t[e], ev_kind[e], ev_k[e]
        pre[o + 3], pre[o + 4] = trace[e, 0], trace[e, 1]
        o += 5


@kernel
def _from_prefix(pre: Any, grp: Any, srf: Any, samples: Any, ev: Any, trace: Any) -> int:
    """The events kept in ``pre`` (`_keep_prefix`) when this rollout's first ones (events
    ``ev``, leader ``trace``) are the same bit for bit: its state restored from there (the
    group, the search starts, the first scan's samples) and their count returned, else 0
    (nothing restored). The rollout's numbers go on from there as they would have: the same
    events on the same state give the same floats."""
    ev_t, ev_kind, ev_k = ev
    n, ns = grp.shape[1], srf.shape[1]
    p = int(pre[1])
    if p > ev_t.shape[0]:
        return 0
    o = _PREFIX + 12 * n + 2 * ns
    for e in range(p):
        if not (
            pre[o] == ev_t[e]
            and pre[o + 1] == ev_kind[e]
            and pre[o + 2] == ev_k[e]
            and pre[o + 3] == trace[e, 0]
            and pre[o + 4] == trace[e, 1]
        ):
            return 0
        o += 5
    o = _PREFIX
    for c in range(9):
        for i in range(n):
            grp[c, i] = pre[o]
            o += 1
    for c in range(2):
        for i in range(ns):
            srf[c, i] = pre[o]
            o += 1
    for i in range(n):
        for c in range(3):
            samples[0, i, c] = pre[o]
            o += 1
    return p


@kernel
def _roll(
    lengths: Any,
    P: Any,
    ev_t: Any,
    ev_kind: Any,
    ev_k: Any,
    trace: Any,
    out: Any,
    keep: float,
    need: float,
    contact: float,
    W: Any,
) -> int:
    """`_rollout` over the events on copies of the group and the law's search starts (in the
    scratch ``W``, `_work`), the leader at ``trace``, and the changes per window and follower
    (``out[window, follower]``: displacement, |Δρ|, distance, |Δβ|, closest approach).

    Returns how many windows it filled: all of them, or, for a pass/fail question (``need``
    finite) whose first window alone fails (keep · its smallest bound, lowered by its contact
    bound at d_c = ``contact``, below ``need``: later windows can only lower it), 1 — the
    rollout stops at that window's closing scan, its first window the numbers it would have
    had (the events up to that scan are the whole rollout's, in the same order).

    The scratch's prefix mode (``W[4][0]``, `_plan_decide` sets it): 1 keeps the state after
    the events before the second scan (`_keep_prefix`), 2 starts from a kept one when its
    events and leader are this rollout's first ones (`_from_prefix`), 0 neither."""
    fs, fol, pend, G, sr0, sf0 = P
    S = scalars(fs)
    n = fol.shape[0]
    nw = lengths.shape[0]
    grp, samples, near, srf, pre = W  # (near: each follower's closest approach at each scan)
    for i in range(n):  # the pack's columns copied in, the odometers at 0, the time now
        for c in range(7):
            grp[c, i] = fol[i, c]
        grp[7, i] = 0.0
        grp[8, i] = S.t_now
        for j in range(nw + 1):
            for c in range(3):
                samples[j, i, c] = 0.0
    for i in range(sr0.shape[0]):
        srf[0, i] = sr0[i]
        srf[1, i] = sf0[i]
    sr, sf = srf[0], srf[1]
    # a pass/fail question stops after the first window if that one already fails
    first = 1 if nw > 1 and need > -math.inf else nw
    e = 0 * nw  # (an int64, not the literal 0)
    n_ev = ev_t.shape[0]
    e_end = n_ev
    scan = 0  # scans written
    mode = pre[0]
    if mode == 2.0:  # from a kept prefix when its events and leader are these
        e = _from_prefix(pre, grp, srf, samples, (ev_t, ev_kind, ev_k), trace)
        scan = _scans_before(ev_kind, e)
    elif mode == 1.0:  # keep the events before the second scan (`_keep_prefix`)
        t1 = S.next_scan + lengths[0]  # (the second scan's time as `_events` sums it)
        e_end = 0 * nw
        while e_end < n_ev and ev_t[e_end] < t1:
            e_end += 1
    done = 0  # windows whose changes are in ``out``
    s_from = 0  # the first scan whose closest approaches, range and bearing are to come
    while True:
        stop = first if done == 0 else nw
        e = _rollout(
            G, grp, S.max_accel, S.max_speed, S.max_turn, S.speed_noise, S.turn_noise, S.step,
            sr, sf, S.gain, S.lookahead, ev_t, ev_kind, ev_k, trace, e, e_end, scan, stop,
            samples,
        )  # fmt: skip
        if e_end < n_ev:  # the prefix ran (its one scan, the first, written): keep it
            _keep_prefix(pre, grp, srf, samples, (ev_t, ev_kind, ev_k), trace, e_end)
            scan = _scans_before(ev_kind, e_end)
            e_end = n_ev
            continue
        scan = stop + 1
        for j in range(s_from, stop + 1):
            for i in range(n):
                near[j, i] = closest_to(samples[j, :, 0], samples[j, :, 1], i, 0.0, 0.0)
                # (each sample's range and bearing once, as Rollout._run's row: a window
                # reads those of both its scans)
                px, py = samples[j, i, 0], samples[j, i, 1]
                samples[j, i, 3] = cpython_hypot(px, py)
                samples[j, i, 4] = _bearing(py, px)
        s_from = stop + 1
        for j in range(done, stop):
            _window_changes(samples, near, j, out)
        done = stop
        if done >= nw:
            return nw
        m0 = _min_bound(out[0], S, fol, lengths[0])
        if keep * lowest_contact(out[0:1], lengths[0], contact, m0) < need:
            return done


@kernel
def _bearing(y: float, x: float) -> float:
    """``math.atan2(y, x) % 2π`` as Python computes it, without its fmod: atan2 is within
    [−π, π], where fmod(b, 2π) is b, so Python's ``%`` gives b when b > 0, b + 2π when b < 0
    and +0.0 for a zero of either sign (b − b: NaN stays NaN)."""
    b = math.atan2(y, x)
    if b > 0.0:
        return b
    if b < 0.0:
        return b + 2.0 * math.pi
    return b - b


@kernel
def _window_changes(samples: Any, near: Any, j: int, out: Any) -> None:
    """Window ``j``'s changes per follower into ``out[j]`` from the samples (leader-frame
    position, odometer, range, bearing: `_roll`) and closest approaches at its two scans
    (Rollout._run's last loop)."""
    two_pi = 2.0 * math.pi
    for i in range(samples.shape[1]):
        px, py, po = samples[j, i, 0], samples[j, i, 1], samples[j, i, 2]
        qx, qy, qo = samples[j + 1, i, 0], samples[j + 1, i, 1], samples[j + 1, i, 2]
        out[j, i, 0] = cpython_hypot(qx - px, qy - py)
        out[j, i, 1] = abs(samples[j + 1, i, 3] - samples[j, i, 3])
        out[j, i, 2] = qo - po
        out[j, i, 3] = abs(cpython_remainder(samples[j + 1, i, 4] - samples[j, i, 4], two_pi))
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
def _bounds_of(changes: Any, S: RolloutScalars, fol: Any, w: float, rows: Any, fill: bool) -> float:
    """Rollout.bounds(changes, w) — into ``rows`` [follower, kind] when ``fill`` — and
    min_bound_rows's bound of them (the first smallest)."""
    best = math.inf
    for i in range(changes.shape[0]):
        rho_d = fol[i, _RHO_D]
        for j in range(4):
            b = _bound(S, rho_d, j, changes[i, j], w)
            if fill:
                rows[i, j] = b
            if b < best:
                best = b
    return best


@kernel
def _rows(changes: Any, S: RolloutScalars, fol: Any, w: float, rows: Any) -> float:
    """`_bounds_of` into ``rows``: a window's bounds and the smallest."""
    return _bounds_of(changes, S, fol, w, rows, True)


@kernel
def _min_bound(changes: Any, S: RolloutScalars, fol: Any, w: float) -> float:
    """min_bound_rows(Rollout.bounds(changes, w))[0]: the smallest L·w / c of one window
    (`_bounds_of`, no rows kept)."""
    return _bounds_of(changes, S, fol, w, changes, False)


@kernel
def _same(a: Any, b: Any) -> bool:
    """Two leader traces (`_lead`) equal bit for bit (NaN never equal)."""
    for e in range(a.shape[0]):
        if not (a[e, 0] == b[e, 0] and a[e, 1] == b[e, 1]):
            return False
    return True


@kernel
def _rollout_worst(
    v: float,
    lengths: Any,
    P: Any,
    ch: Any,
    contact: float,
    keep: float,
    need: float,
    ev: Any,
    traces: Any,
    ms: Any,
    dones: Any,
    r: int,
    upto: int,
    W: Any,
) -> tuple[float, int, int]:
    """PlanPolicy's m(V): the smallest bound of every follower in ``ch.shape[0]`` windows of
    w = ``lengths[0]`` ms (``lengths``: as many, all w; Python's ``min`` over the windows:
    the first, then any smaller; scratch ``W``, `_work`), then the
    contact bound at d_c = ``contact`` (0: off); the changes are left in ``ch``. With ``need``
    finite, only whether keep · m(V) ≥ ``need`` is asked: a first window that already fails
    ends the rollout there (`_roll`) and m is that window's, still below.

    ``ev``: the windows' events (`_events`). With ``r`` ≥ 0 the rollout is the r-th of one
    search: its leader goes to ``traces[r]``, its m and windows rolled out to ``ms[r]``,
    ``dones[r]``. When its leader is that of a rollout q < ``upto`` (q ≠ r) bit for bit (a
    target the leader does not reach within the horizon, as another it does not reach on
    the same side), the rollout is q's: nothing is rolled out and q is returned (the caller
    copies its changes), unless q stopped early and this question needs every window.
    Returns (m, the windows rolled out, q or −1)."""
    S, fol = scalars(P[0]), P[1]
    ev_t, ev_kind, ev_k = ev
    nw = ch.shape[0]
    w = lengths[0]
    tr = traces[r] if r >= 0 else np.empty((ev_t.shape[0], 2))
    _lead(v, P, ev_t, tr)
    for q in range(upto):
        if q != r and (dones[q] == nw or need > -math.inf) and _same(traces[q], tr):
            if r >= 0:
                ms[r], dones[r] = ms[q], dones[q]
            return ms[q], dones[q], q
    done = _roll(lengths, P, ev_t, ev_kind, ev_k, tr, ch, keep, need, contact, W)
    part = ch[:done]
    m = _worst_after(part, S, fol, w, _min_bound(ch[0], S, fol, w))
    m = lowest_contact(part, w, contact, m)
    if r >= 0:
        ms[r], dones[r] = m, done
    return m, done, -1


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


@kernel
def _search_into(
    keep: float,
    need: float,
    v_floor: float,
    grid: int,
    tol: float,
    lengths: Any,
    P: Any,
    speeds: Any,
    changes: Any,
    cut: Any,
    first: int,
    found_out: Any,
    contact: float,
    ev: Any,
    traces: Any,
    ms: Any,
    dones: Any,
    W: Any,
) -> int:
    """search_rollout(m, V_Ld, need, v_floor) with m(V) = keep · `_rollout_worst` over
    ``changes.shape[1]`` windows ``lengths`` (contact bound at ``contact``); rollout r's speed
    and changes go to ``speeds[r]`` and ``changes[r]`` from r = ``first`` (as many as they
    hold), ``cut[r]`` ← 1 when it stopped after its first window. ``found_out`` ← (speed, 1
    for ``numeric`` or 0 for ``best``, the found speed or NaN, the index of the speed's
    rollout or −1, the rollouts run beyond the indices: the scanned speeds rolled out again
    less the speeds that were an earlier rollout's); returns the next free index (rollouts
    run: it − first, plus ``found_out[4]``). ``ev``, ``traces``, ``ms``, ``dones``: the
    horizon's events and the kept leaders of the decision's rollouts from index 0
    (`_rollout_worst`); ``W``: its scratch (`_work`).

    Only pass or fail matters for a speed of the bisection, and for a scanned speed unless
    none passes: those rollouts stop after a first window that fails (`_rollout_worst`).
    When none passes, the least-bad speed needs each scanned speed's m: the scanned rollouts
    that stopped are rolled out whole then (the same speed, the same numbers), after the
    floor's (rolled out whole). A speed whose leader is an earlier rollout's bit for bit is
    that rollout (its changes copied, not rolled out)."""
    v_ld = scalars(P[0]).v_ld
    cap = speeds.shape[0]
    nw = changes.shape[1]
    scratch = np.empty(changes.shape[1:])
    above = v_ld
    lo = hi = 0.0
    r_lo = -1
    # the scan's m, rollout index and whether it stopped early, per j, replayed after the
    # floor when none passes
    scan_m = np.empty(grid)
    scan_r = np.empty(grid, dtype=np.int64)
    scan_cut = np.empty(grid, dtype=np.int64)  # 0/1 (np.empty filled: `_plan_decide`'s note)
    for j in range(grid):
        scan_cut[j] = 0
    m_floor, r_floor = -math.inf, -1
    r = first
    r_v = -1
    again = 0
    # one rollout per pass (one call site keeps the compiled code small): phase 1 the scan's
    # j-th speed, 2 the bisection, 0 the floor — last: its m matters only when no scanned
    # speed passes, so a search that brackets never rolls it out (search_rollout's order) —
    # 3 a scanned speed that stopped early, whole
    phase = 1
    j = 1
    while True:
        if phase == 1 and j >= grid:
            phase, j = (0, j) if v_floor > 0.0 else (3, 1)
        if phase == 3:
            while j < grid and not scan_cut[j]:
                j += 1
            if j >= grid:
                break
        if phase == 0:
            v = v_floor
        elif phase == 2:
            if not hi - lo > tol * v_ld:
                found_out[0], found_out[1], found_out[2], found_out[3] = lo, 1.0, lo, r_lo
                found_out[4] = float(again)
                return r
            v = 0.5 * (lo + hi)
        else:
            v = v_ld * (1.0 - j / grid)
        if phase == 3:
            ch = changes[scan_r[j]] if scan_r[j] >= 0 else scratch
            ask = -math.inf
            slot = scan_r[j]
        else:
            ch = changes[r] if r < cap else scratch
            if r < cap:
                speeds[r] = v
            r_v = r if r < cap else -1
            slot = r_v
            r += 1
            ask = -math.inf if phase == 0 else need
        upto = r - 1 if r - 1 < cap else cap  # the rollouts before this one
        if phase == 3:
            upto = r if r < cap else cap  # every rollout so far
        mm, done, q = _rollout_worst(
            v, lengths, P, ch, contact, keep, ask, ev, traces, ms, dones, slot, upto, W
        )
        if q >= 0:  # an earlier rollout's leader: its changes
            src = changes[q]
            for a in range(ch.shape[0]):  # (loops: numba's slice assignment compiles slowly)
                for b in range(ch.shape[1]):
                    for c in range(ch.shape[2]):
                        ch[a, b, c] = src[a, b, c]
            again -= 1
        m = keep * mm
        if phase == 3:
            scan_m[j], scan_cut[j] = m, False
            if scan_r[j] >= 0:
                cut[scan_r[j]] = 0
            again += 1
            j += 1
            continue
        if done < nw and r_v >= 0:
            cut[r_v] = 1
        if phase == 0:
            m_floor, r_floor = m, r_v
            phase, j = 3, 1
            continue
        if phase == 1:
            if m >= need:
                lo, hi, r_lo, phase = v, above, r_v, 2
            else:
                scan_m[j], scan_r[j], scan_cut[j] = m, r_v, done < nw
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
    found_out[4] = float(again)
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
    cut: Any,
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
    ``out[5]`` (in ``changes[r, 0]``); returns how many. ``cut[r]`` ← 1 when rollout r
    stopped after its first window (a speed that fails there, whose m the decision does not
    need: `_search_into`; only ``changes[r, 0]`` is filled), and ``out[6]`` ← the rollouts
    run beyond the returned count (`_search_into`'s ``found_out[4]``: rolled out again
    whole, less those that were an earlier one's).

    ``search_only``: only the speed search (search_rollout with m(V) = keep · the smallest
    bound over H; ``adjust`` with the ``commands`` predictor, H one window): from rollout 0,
    ``out[1:4]`` its (speed, method, found), every rollout the search's own (``lens`` 0).
    """
    S, fol = scalars(P[0]), P[1]
    v_ld = S.v_ld
    res = np.empty(5)
    out[6] = 0.0
    nw = changes.shape[1]
    # the horizon's events, the same for every speed; the leaders of its rollouts; the
    # rollouts' scratch. (Arrays as np.empty filled by loops, its dtype by keyword, in every
    # kernel: numba compiles np.empty once per calling style, and np.zeros and np.full each
    # compile one more of their own.)
    hl = np.empty(nw)
    for j in range(nw):
        hl[j] = w
    ev = _events(hl, P)
    W = _work(P, nw, ev[0].shape[0])
    traces = np.empty((speeds.shape[0], ev[0].shape[0], 2))
    ms = np.empty(speeds.shape[0])
    dones = np.empty(speeds.shape[0], dtype=np.int64)
    for j in range(speeds.shape[0]):
        dones[j] = 0
    zero = 0 * nw  # (an int64, not the literal 0: one compiled _rollout_worst for every call)
    # (one call site of the search: the search-only decision and the plan's search share it)
    first = 0 if search_only else 1
    feasible = False
    if not search_only:
        speeds[0], lens[0] = v_ld, 1
        W[4][0] = 1.0  # (its events before the second scan kept: the longer window's start)
        m_ld, done, _ = _rollout_worst(
            v_ld, hl, P, changes[0], contact, keep, need, ev, traces, ms, dones, zero, zero, W
        )
        W[4][0] = 0.0
        if done < nw:
            cut[0] = 1
        m1 = _rows(changes[0, 0], S, fol, w, rows[0])
        feasible = keep * m_ld >= need
    if feasible:
        a = keep * m1
        mn = cap if cap < a else a  # max(w, min(keep·m1, cap)), as Python picks
        ww = mn if mn > w else w
        runs = 1
        if ww > w:  # the longer first window, checked by its own rollout
            speeds[1], lens[1] = v_ld, 2
            one = np.empty(1)
            one[0] = ww
            ev_w = _events(one, P)
            # its events before V_Ld's second scan are V_Ld's first ones (the same leader):
            # it goes on from V_Ld's state there (`_from_prefix` checks them bit for bit)
            W[4][0] = 2.0
            m_w = _rollout_worst(
                v_ld,
                one,
                P,
                changes[1, 0:1],
                contact,
                keep,
                -math.inf,
                ev_w,
                traces,
                ms,
                dones,
                zero - 1,
                zero,
                W,
            )[0]
            W[4][0] = 0.0
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
    runs = _search_into(
        keep, need, v_floor, grid, tol, hl, P, speeds, changes, cut, first, res, contact,
        ev, traces, ms, dones, W,
    )  # fmt: skip
    out[6] = res[4]
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


#: the decision's out values (`_plan_decide`'s ``out``), first in its float buffer
OUTS = 7


@kernel(unroll=False)  # (LLVM unrolling its loops: ≈ 0.3 s more compile, no faster)
def _roll_or_decide(
    whole: bool, v: float, search_only: bool, keep: float, need: float, cap: float,
    v_floor: float, grid: int, tol: float, w: float, contact: float, lengths: Any, P: Any,
    fb: Any, ib: Any,
) -> int:  # fmt: skip
    """The rollout's one entry from Python: with ``whole``, one rollout whole
    (`_rollout_changes` of target ``v`` over windows ``lengths`` into ``fb``, its changes
    [window, follower, change] flat, with ``keep``, ``need`` and ``contact``); else the
    decision (`_plan_decide` with the arguments after ``v`` but ``lengths``, its arrays
    views of two: ``fb`` = [out (`OUTS`), rows (2·n·4), speeds (R), changes (R·H·n·5)] with
    R = ``ib.shape[0] // 2`` and the horizon H what is left, ``ib`` = [lens (R), cut (R)]:
    out and rows start NaN, cut zero). One entry, not two: numba optimises and emits the code
    of every kernel an entry links once per entry, and both link the whole rollout. (Two
    buffers, not six arrays: numba unboxes every array argument at every call.)"""
    n = P[1].shape[0]
    if whole:
        return _rollout_changes(
            v, lengths, P, fb.reshape((lengths.shape[0], n, 5)), keep, need, contact
        )
    runs = ib.shape[0] // 2
    head = OUTS + 8 * n
    for i in range(head):
        fb[i] = math.nan
    for i in range(runs, 2 * runs):
        ib[i] = 0
    nw = (fb.shape[0] - head - runs) // (runs * n * 5)
    return _plan_decide(
        search_only, keep, need, cap, v_floor, grid, tol, w, P, fb[head : head + runs],
        ib[:runs], fb[head + runs :].reshape((runs, nw, n, 5)), ib[runs:],
        fb[OUTS:head].reshape((2, n, 4)), fb[:OUTS], contact,
    )  # fmt: skip


#: the kernels `CompiledRollout` calls, by the name they have in `rollout_kernels`'s
#: namespace (each compiled with the kernel sources it calls, the world's among them)
ENTRIES: dict[str, Any] = {"roll_or_decide": _roll_or_decide}

#: the unused lengths of a decision's call of `_roll_or_decide` (their type the whole
#: rollout's: one compiled specialisation)
NO_F1 = np.empty(0)


def decision_head(n: int) -> int:
    """Where the rollouts' speeds start in a decision's float buffer for ``n`` followers:
    after the out values (`OUTS`) and the rows (2·n·4), as `_roll_or_decide` lays it out."""
    return OUTS + 8 * n


def decision_at(head: int, n: int, runs: int, windows: int, r: int) -> int:
    """Where rollout ``r``'s changes start in a decision's float buffer (``n`` followers,
    its speeds at ``head``, `decision_head`'s; room for ``runs`` rollouts of ``windows``
    windows): after the speeds, as `_roll_or_decide` lays them out, [window, follower,
    change] flat."""
    return head + runs + r * windows * n * 5


def decision_buffers(n: int, windows: int, runs: int) -> tuple[Any, Any]:
    """Fresh float and integer buffers (``fb``, ``ib``) of `_roll_or_decide`'s decision for
    ``n`` followers, a horizon of ``windows`` windows and room for ``runs`` rollouts."""
    return np.empty(decision_head(n) + runs * (1 + windows * n * 5)), np.empty(2 * runs, np.int64)


def decision_views(fb: Any, ib: Any, n: int) -> tuple[Any, Any, Any, Any, Any, Any]:
    """The views of `_roll_or_decide`'s decision buffers ``fb`` and ``ib`` (``n``
    followers): (speeds, lens, changes [rollout, window, follower, change], cut, rows, out),
    as `_plan_decide` reads them."""
    runs = ib.shape[0] // 2
    head = decision_head(n)
    nw = (fb.shape[0] - head - runs) // (runs * n * 5)
    return (
        fb[head : head + runs],
        ib[:runs],
        fb[decision_at(head, n, runs, nw, 0) :].reshape(runs, nw, n, 5),
        ib[runs:],
        fb[OUTS:head].reshape(2, n, 4),
        fb[:OUTS],
    )


def _rollout_changes_via(
    ns: Any, v: float, lengths: Any, P: Any, out: Any, keep: float, need: float, contact: float
) -> int:
    """`_rollout_changes` (its arguments) through the entry of namespace ``ns`` (``out``: a
    C-contiguous [window, follower, change] array)."""
    if not out.flags.c_contiguous:
        raise ValueError("the changes' out array must be C-contiguous")
    return ns.roll_or_decide(  # type: ignore[no-any-return]
        True, v, False, keep, need, 0.0, 0.0, 0, 0.0, 0.0, contact, lengths, P,
        out.reshape(-1), NO_I1,
    )  # fmt: skip


def _plan_decide_via(
    ns: Any, search_only: bool, keep: float, need: float, cap: float, v_floor: float,
    grid: int, tol: float, w: float, P: Any, speeds: Any, lens: Any, changes: Any, cut: Any,
    rows: Any, out: Any, contact: float,
) -> int:  # fmt: skip
    """`_plan_decide` (its arguments) through the entry of namespace ``ns``: its arrays
    copied out of the entry's two buffers (``out`` and ``rows`` start NaN there, ``cut``
    zero)."""
    n, runs = P[1].shape[0], speeds.shape[0]
    fb, ib = decision_buffers(n, changes.shape[1], runs)
    got = ns.roll_or_decide(
        False, 0.0, search_only, keep, need, cap, v_floor, grid, tol, w, contact, NO_F1, P,
        fb, ib,
    )  # fmt: skip
    for dst, src in zip((speeds, lens, changes, cut, rows, out), decision_views(fb, ib, n)):  # noqa: B905
        dst[...] = src
    return got  # type: ignore[no-any-return]


#: an unused integer buffer (a whole rollout's call of `_roll_or_decide`)
NO_I1 = np.empty(0, dtype=np.int64)


#: about how long compiling `ENTRIES` takes, CPU s on a 2-core machine (numba 0.68; measured
#: with a fresh NUMBA_CACHE_DIR, docs/performance.md; 5.0-5.1 s at load 6 on 2026-11-29)
COMPILE_S = 5.0

# most runs roll out right after the world is built: the world's announcement counts these
follow_with(ENTRIES.values(), COMPILE_S)

_BY_MODEL: dict[Subs, Any] = {}


def rollout_kernels(motion: Any = None) -> Any:
    """The compiled rollout kernels (a namespace), compiled or loaded from the cache and
    called once on dummy values, once per process and motion model (the world's first:
    `rtsim.world.kernels.kernels`). ``motion``: a motion model
    (`rtsim.world.motionmodels.MotionModel`; None: the unicycle) whose parts they run."""
    subs: Subs = () if motion is None else motion.subs
    ns = _BY_MODEL.get(subs)
    if ns is None:
        kernels(motion)
        swap = dict(subs)
        announce([swap.get(fn, fn) for fn in ENTRIES.values()], COMPILE_S, subs)
        ns = types.SimpleNamespace(**{name: build(fn, subs) for name, fn in ENTRIES.items()})
        # (the two kernels by their own arguments: the whole rollout's and the tests' calls)
        ns.rollout_changes = functools.partial(_rollout_changes_via, ns)
        ns.plan_decide = functools.partial(_plan_decide_via, ns)
        _warm(ns)
        _BY_MODEL[subs] = ns
    return ns


def _warm(ns: Any) -> None:
    """Call the rollout kernels once on dummy values: one follower 100 cm behind a leader on
    a straight lap (compiling them, or loading them from the cache, before the first
    window)."""
    fs = np.array(
        RolloutScalars(
            *(0.0, 30.0, 30.0, 0.0, 0.0),  # leader_s, leader_speed, v_ld, t_now, next_scan
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
    fol = np.zeros((1, len(FollowerColumns._fields)))
    c = columns(fol)  # (views: the Python build of the kernel)
    c.x[0], c.v[0], c.send[0], c.rho_d[0] = -100.0, 30.0, 100.0, 100.0
    nan1 = np.full(1, math.nan)
    seg = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0])  # (x, y, heading, cos, sin, curvature)
    G = (np.zeros(1), seg, 1e3, np.array([0.0, -1.0, 100.0]))  # (path.geometry_arrays)
    P = (fs, fol, np.full((1, 1), math.nan), G, nan1, nan1)
    ch = np.empty((64, 2, 1, 5))
    ns.rollout_changes(20.0, np.full(2, 240.0), P, ch[0], 1.0, -math.inf, 0.0)
    cut = np.zeros(64, dtype=np.int64)
    bufs = (np.empty(64), np.zeros(64, dtype=np.int64), ch, cut, np.empty((2, 1, 4)), np.empty(7))
    for search_only in (True, False):
        ns.plan_decide(search_only, 1.0, 240.0, 1e3, 3.0, 8, 0.005, 240.0, P, *bufs, 60.0)


def warm_rollout(motion: Any = None) -> None:
    """Compile the rollout's kernels (or load them from the cache) once per process: called
    when the first compiled rollout is made (a coupled run makes it while it is set up,
    before the loop), so a run that never rolls out never compiles them. ``motion``: as
    `rollout_kernels`."""
    rollout_kernels(motion)


def warm_all() -> None:
    """Compile the kernels a coupled run of the compiled backend uses (the world's and the
    rollout's), or load them from the cache, in this process: called before a process pool
    starts (``rtsim reproduce``, the sweep engine), so that workers forked after it inherit
    them and spawned ones load what it cached: the first run pays the compile once, not once
    per worker. The scan's kernel too (`rtsim.world.scanstep`: the laser and the Hough
    windows; the re-acquisition search's `hough_window` stays lazy: most runs never search)."""
    warm_rollout()
    scanstep.warm()
