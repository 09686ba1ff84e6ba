"""The leader's estimates of all followers as one array the compiled world owns, and the
kernels that read and write it, one call per reader (docs/performance.md).

Row k of the array (`new_estimates`) is follower index k: the filter's mean (`X`: x, y, θ),
its covariance (`Q`: the nine entries row by row, as `rtsim.world.ekf.FastFollowerEKF`
keeps them), the speed and turn rate the leader expects (`V`, `W`), the count of commands
held since the last scan (`M`), then from `BASE` each held command's start (ms), speed and
turn rate. The kernels are the rules of `rtsim.world.world.World`'s Python methods (the
reference, which the ``python`` backend runs and the backend tests compare with bit for
bit) on that row, composed of the same single-source kernels — the EKF's `ekf_command` and
`ekf_update`, the motion model's ``step`` (`rtsim.world.motion.ramp_arc`), the
follow-the-leader law's `ftl_command_frame`, a command's `clip` — so numba compiles the
expressions the Python runs:

- `est_scan`: `World.estimate` for every follower (carry, predict, update or reset, the
  heading variance's maximum);
- `est_carry`: `World._propagate` for one follower or all;
- `est_hold`: `World._hold`'s record of a command;
- `est_command_ftl`: `World.command` with the follow-the-leader law (the leader and the
  follower's truth advanced, the leader's pose, carry, law, clip, hold, the command realised
  with its actuation noise).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rtsim.world.ekf import ekf_command, ekf_update
from rtsim.world.ftl import ftl_command_frame, path_frame
from rtsim.world.jit import kernel
from rtsim.world.motion import GCV, GCW, actuated, clip, group_advance, leader_travel, ramp_arc

__all__ = [
    "BASE",
    "est_carry",
    "est_command_ftl",
    "est_hold",
    "est_scan",
    "new_estimates",
]

#: The row's columns: the mean, the covariance, v̂, ω̂, the held commands' count, the first
#: held command's start (each held command three columns: start, speed, turn rate).
X, Q, V, W, M, BASE = 0, 3, 12, 13, 14, 15
#: Held commands a row has room for at first (`World` grows the array when a run needs more).
HELD_ROOM = 8


def new_estimates(n: int, room: int = HELD_ROOM) -> NDArray[np.float64]:
    """A zeroed (n, `BASE` + 3·room) array of rows (module docstring)."""
    return np.zeros((n, BASE + 3 * room))


@kernel
def carry_row(E: Any, k: int, t: float, a: float) -> tuple[float, float, float, float, float]:
    """Row ``k``'s mean carried to ``t`` ms over its held commands (the motion model's
    ``step``, acceleration limit ``a``): (x, y, θ, v, ω) (`World._propagate`)."""
    x, y, th, v, w = E[k, X], E[k, X + 1], E[k, X + 2], E[k, V], E[k, W]
    last = int(E[k, M]) - 1
    for j in range(last + 1):
        o = BASE + 3 * j
        t0 = E[k, o]
        t1 = E[k, o + 3] if j < last else t
        if t1 > t:
            t1 = t
        if t1 > t0:
            x, y, th, v, w, _ = ramp_arc(
                x, y, th, v, w, E[k, o + 1], E[k, o + 2], a, (t1 - t0) / 1000.0
            )
    return x, y, th, v, w


@kernel
def est_carry(E: Any, k0: int, t: float, a: float, out: Any) -> None:
    """Rows ``k0`` … ``k0`` + len(``out``) − 1 carried to ``t`` ms (`carry_row`), with the
    command each holds last, into ``out``: one row of (x, y, θ, v, ω, v_c, ω_c) each."""
    for i in range(out.shape[0]):
        k = k0 + i
        x, y, th, v, w = carry_row(E, k, t, a)
        o = BASE + 3 * (int(E[k, M]) - 1)
        out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4] = x, y, th, v, w
        out[i, 5], out[i, 6] = E[k, o + 1], E[k, o + 2]


@kernel
def est_hold(E: Any, k: int, t: float, v: float, w: float) -> bool:
    """Hold command (``v``, ``w``) from ``t`` ms in row ``k``: it replaces the last held
    command when that starts at or after ``t`` (`World._hold`). False, nothing written, when
    the row is full (the caller grows the array and calls again)."""
    m = int(E[k, M])
    if m > 0 and E[k, BASE + 3 * (m - 1)] >= t:
        m -= 1
    o = BASE + 3 * m
    if o + 3 > E.shape[1]:
        return False
    E[k, o], E[k, o + 1], E[k, o + 2] = t, v, w
    E[k, M] = m + 1
    return True


@kernel
def predict_held(E: Any, k: int, t: float, a: float, noise: Any) -> None:
    """Row ``k``'s filter predicted over its held commands up to ``t`` ms (`ekf_command`,
    ``noise`` = σ_v², σ_ω², q_p², q_θ²), and the commands kept from ``t`` on: the one held
    at ``t`` restarted there, then those starting at or after ``t`` (`World.estimate`'s loop;
    the commands' starts rise, as `World` holds them: a command's time never precedes the
    world's, nor the start of any command it does not replace)."""
    sv2, sw2, qp2, qh2 = noise
    m = int(E[k, M])
    last = m - 1
    x0, x1, x2, v, w = E[k, X], E[k, X + 1], E[k, X + 2], E[k, V], E[k, W]
    q0, q1, q2, q4, q5, q8 = (
        E[k, Q],
        E[k, Q + 1],
        E[k, Q + 2],
        E[k, Q + 4],
        E[k, Q + 5],
        E[k, Q + 8],
    )
    q3, q6, q7 = E[k, Q + 3], E[k, Q + 6], E[k, Q + 7]
    out = 0  # the commands kept, written from the row's first
    for j in range(m):
        o = BASE + 3 * j
        t0, vc, wc = E[k, o], E[k, o + 1], E[k, o + 2]
        if t0 >= t:  # (behind the one restarted at t, if any: the kept ones move forward)
            p = BASE + 3 * out
            E[k, p], E[k, p + 1], E[k, p + 2] = t0, vc, wc
            out += 1
            continue
        nxt = E[k, o + 3] if j < last else math.inf
        t1 = nxt if nxt < t else t
        dt = (t1 - t0) / 1000.0
        if dt > 0.0:
            x0, x1, x2, q0, q1, q2, q4, q5, q8, v, w = ekf_command(
                x0, x1, x2, q0, q1, q2, q4, q5, q8, v, w, vc, wc, a, dt, sv2, sw2, qp2, qh2
            )
            q3, q6, q7 = q1, q2, q5
        if nxt > t:  # (held at t: the last before t, so the first kept)
            E[k, BASE], E[k, BASE + 1], E[k, BASE + 2] = t, vc, wc
            out = 1
    if out == 0:
        o = BASE + 3 * last
        E[k, BASE], E[k, BASE + 1], E[k, BASE + 2] = t, E[k, o + 1], E[k, o + 2]
        out = 1
    E[k, M] = out
    E[k, X], E[k, X + 1], E[k, X + 2], E[k, V], E[k, W] = x0, x1, x2, v, w
    E[k, Q], E[k, Q + 1], E[k, Q + 2], E[k, Q + 3], E[k, Q + 4] = q0, q1, q2, q3, q4
    E[k, Q + 5], E[k, Q + 6], E[k, Q + 7], E[k, Q + 8] = q5, q6, q7, q8


@kernel
def est_scan(
    E: Any, F: Any, t: float, a: float, sv2: float, sw2: float, qp2: float, qh2: float,
    r: float, xl: float, yl: float, hl: float, var: float, track: bool,
) -> float:  # fmt: skip
    """`World.estimate` at the scan at ``t`` ms for every row: `predict_held`, then the
    correction with row k of ``F`` (the fix mx, my in the frame of the leader's pose
    (``xl``, ``yl``, ``hl``), then 1: in its window, `ekf_update` with R = ``r`` I; 2:
    re-acquired, the position reset to it with covariance R, the heading kept; 0: none).
    Returns the largest heading variance P_θθ of ``var`` and, when ``track``, the rows'."""
    c, s = math.cos(hl), math.sin(hl)
    noise = (sv2, sw2, qp2, qh2)
    for k in range(E.shape[0]):
        predict_held(E, k, t, a, noise)
        how = F[k, 2]
        if how != 0.0:
            mx, my = F[k, 0], F[k, 1]
            z0, z1 = xl + c * mx - s * my, yl + s * mx + c * my
            if how == 1.0:
                u = ekf_update(
                    E[k, X], E[k, X + 1], E[k, X + 2], E[k, Q], E[k, Q + 1], E[k, Q + 2],
                    E[k, Q + 3], E[k, Q + 4], E[k, Q + 5], E[k, Q + 6], E[k, Q + 7],
                    E[k, Q + 8], r, z0, z1,
                )  # fmt: skip
                for i in range(12):
                    E[k, X + i] = u[i]
            else:
                E[k, X], E[k, X + 1] = z0, z1
                E[k, Q], E[k, Q + 1], E[k, Q + 2], E[k, Q + 3], E[k, Q + 4] = r, 0.0, 0.0, 0.0, r
                E[k, Q + 5], E[k, Q + 6], E[k, Q + 7] = 0.0, 0.0, 0.0
        if track and E[k, Q + 8] > var:
            var = E[k, Q + 8]
    return var


@kernel
def est_command_ftl(
    k: int, t: float, s: float, v0: float, vt: float, dt: float, nv: float, nw: float, E: Any,
    a: float, G: Any, s_ref: Any, s_f: Any, gain: float, lookahead: float, v_max: float,
    w_max: float, sv: float, sw: float, S: Any, step_ms: float, accel: float, decel: float,
) -> tuple[float, float, bool, float, float]:  # fmt: skip
    """`World.command` for row ``k`` at ``t`` ms with the follow-the-leader law: the leader
    at arc length ``s`` and speed ``v0`` driven ``dt`` s toward ``vt`` (`leader_travel`, at
    most ``accel`` / ``decel``; none when ``dt`` is 0), the follower's truth in the group
    state ``S`` advanced to ``t`` with the command it held (`group_advance`, sub-steps
    ``step_ms``), the leader's pose then (`path_frame`, `LeaderPath.pose`), the estimate
    carried there (`carry_row`), the law (`ftl_command_frame`, which updates ``s_ref`` and
    ``s_f``), the command clipped to ``v_max``, ``w_max`` (`clip`, the followers'
    saturation) and held (`est_hold`), and the command the follower realises with its
    actuation noise, standard normals ``nv``, ``nw`` times ``sv``, ``sw`` (`actuated`, as
    `FollowerGroup.apply_drawn`), written to ``S``: (v, ω, whether it was held — False: the
    row was full —, the leader's speed and arc length). (What changes per call first, the
    run's constants after: the caller passes those as one tuple.)"""
    v_l, s_l = v0, s
    if dt > 0.0:  # (`rtsim.world.leader.Leader.advance`)
        v_l, ds = leader_travel(v0, vt, accel, decel, dt)
        s_l = s + ds
    group_advance(S, k, k + 1, t, step_ms, a)
    xl, yl, _, cl, sl = path_frame(G, s_l)
    x, y, th, _, _ = carry_row(E, k, t, a)
    v, w = ftl_command_frame(G, s_ref, s_f, gain, lookahead, k, s_l, xl, yl, cl, sl, v_l, x, y, th)
    v, w = clip(v, v_max), clip(w, w_max)
    S[GCV, k], S[GCW, k] = actuated(v, w, nv, nw, sv, sw, v_max, w_max)
    return v, w, est_hold(E, k, t, v, w), v_l, s_l
