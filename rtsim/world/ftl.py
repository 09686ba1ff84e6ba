"""Follow-the-leader control: each follower tracks the path the leader drove, offset
sideways, holding its place in line by a search on its offset trace, a speed law (FTL-1)
and pure pursuit (docs/model/world.md, "The follow-the-leader law").

The law's equations are written once, as kernel sources (`rtsim.world.jit`) on the law's
geometry ``G`` (`TraceFollower.geometry`): `TraceFollower` runs them as Python (with
``math.hypot``), the compiled backend's `rtsim.world.compiled.CompiledTraceFollower` and the
controller's rollout (`rtsim.control.kernels`) run them compiled.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from typing import Any

from rtsim.world.exactmath import HYPOT_SUBS, cpython_hypot
from rtsim.world.jit import kernel, specialise
from rtsim.world.path import Frame, LeaderPath, along

__all__ = [
    "TraceFollower",
    "FTL_STEP",
    "ftl_command",
    "ftl_command_frame",
    "ftl_project",
    "ftl_reference",
    "ftl_reference_frame",
    "path_frame",
]

#: Bracketing step (cm) of the search for the reference point along the trace.
FTL_STEP = 10.0
_BISECT = 40
_NEWTON = 8
_NEWTON_REACH = 50.0
_SCALE_MIN = 0.05

# -- the equations, on the geometry G = (s0, seg, lap, fol): the path's segment starts (cm);
# per segment its start frame (x, y, heading, the heading's cosine and sine:
# `rtsim.world.path.along`) and curvature (1/cm), six a segment, flat; its lap (cm); per
# follower its lateral offset (cm, left positive), whom it follows (-1: the leader; an index
# held as a float) and at what spacing (cm), three a follower, flat. Tuples in Python, arrays
# compiled (`rtsim.world.path.geometry_arrays`).


@kernel(inline=True)
def path_segment(G: Any, s: float) -> tuple[int, float]:
    """`LeaderPath.index` (s), the segment's index (bisect_right − 1 of the starts), and u = s
    mod lap (Python's ``%``; within one lap either side of 0 its result without the fmod:
    fmod(s, lap) is s exactly there, and ``%`` adds lap to a negative one)."""
    s0, lap = G[0], G[2]
    if 0.0 < s < lap:
        u = s
    elif -lap < s < 0.0:
        u = s + lap
    else:
        u = s % lap
    lo, hi = 0, len(s0)
    while lo < hi:
        mid = (lo + hi) // 2
        if u < s0[mid]:
            hi = mid
        else:
            lo = mid + 1
    return lo - 1, u


@kernel
def _pose_at(G: Any, k: int, u: float) -> Frame:
    """The frame (pose, cos and sin of its heading) `along` segment k at u − its start (u: s
    mod lap), from the segment's start frame."""
    p, j = G[1], 6 * k
    return along(p[j], p[j + 1], p[j + 2], p[j + 3], p[j + 4], p[j + 5], u - G[0][k])


@kernel
def path_pose(G: Any, s: float) -> tuple[float, float, float]:
    """`LeaderPath.pose` (s): `along` the segment at ``s`` from its start pose."""
    k, u = path_segment(G, s)
    x, y, h, _, _ = _pose_at(G, k, u)
    return x, y, h


@kernel
def path_frame(G: Any, s: float) -> Frame:
    """`path_pose` and the cosine and sine of its heading (``math.cos``/``math.sin`` of it:
    `along`), for the law's and a scan's reads of the leader (`ftl_command_frame`)."""
    k, u = path_segment(G, s)
    return _pose_at(G, k, u)


@kernel
def trace_point(G: Any, k: int, s: float) -> tuple[float, float, float]:
    """P_k(s) and the heading there: the path's pose at ``s`` moved follower k's offset to
    the left (`trace_frame`'s first three)."""
    x, y, h, _, _, _ = trace_frame(G, k, s)
    return x, y, h


@kernel
def trace_scale(G: Any, k: int, s: float) -> float:
    """1 − κ(s)·o_k: follower k's offset curve's length per unit of trace (floored at 0.05;
    `trace_frame`'s last)."""
    return trace_frame(G, k, s)[3]  # type: ignore[no-any-return]


@kernel(inline=True)
def trace_frame(G: Any, k: int, s: float) -> tuple[float, float, float, float, float, float]:
    """P_k(s), the heading there, `trace_scale`, the heading's cosine and sine (one segment
    lookup): the path's pose at ``s`` moved follower k's offset to the left."""
    i, u = path_segment(G, s)
    x, y, h, c, sn = _pose_at(G, i, u)
    o = G[3][3 * k]
    return x - o * sn, y + o * c, h, max(_SCALE_MIN, 1.0 - G[1][6 * i + 5] * o), c, sn


@kernel
def _gap(G: Any, k: int, s: float, xl: float, yl: float, rho2: float) -> float:
    """|P_k(s) − (xl, yl)|² − ρ²."""
    x, y, _ = trace_point(G, k, s)
    return (x - xl) ** 2 + (y - yl) ** 2 - rho2


@kernel
def ftl_search(G: Any, k: int, s: float, s_l: float, xl: float, yl: float, rho: float) -> float:
    """The first s ≤ ``s_l`` behind (xl, yl) on follower k's trace with |P_k(s) − (xl, yl)|
    = ``rho``: Newton steps from the last reference ``s`` (NaN: none; it moves a few cm per
    command), else a bracketing walk by `FTL_STEP` and a bisection."""
    rho2 = rho * rho
    if not math.isnan(s) and s <= s_l:
        s_n = s
        for _ in range(_NEWTON):
            x, y, _, scale, c, sn = trace_frame(G, k, s_n)
            dx, dy = x - xl, y - yl
            dg = 2.0 * (dx * c + dy * sn) * scale
            if dg > -1e-6 * rho:
                break
            step = (dx * dx + dy * dy - rho2) / dg
            s_n -= step
            if abs(s_n - s) > _NEWTON_REACH or s_n > s_l:
                break
            if abs(step) < 1e-9:
                return s_n
    limit = int(G[2] / FTL_STEP) + 2
    if math.isnan(s) or s > s_l:
        s = s_l
    lo = hi = s
    if _gap(G, k, s, xl, yl, rho2) > 0.0:  # too far behind: walk forward to the crossing
        for _ in range(limit):
            hi = min(lo + FTL_STEP, s_l)
            if _gap(G, k, hi, xl, yl, rho2) <= 0.0 or hi >= s_l:
                break
            lo = hi
    else:  # too close: walk back
        for _ in range(limit):
            lo = hi - FTL_STEP
            if _gap(G, k, lo, xl, yl, rho2) > 0.0:
                break
            hi = lo
    for _ in range(_BISECT):
        mid = 0.5 * (lo + hi)
        if _gap(G, k, mid, xl, yl, rho2) > 0.0:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-7:
            break
    return 0.5 * (lo + hi)


@kernel
def ftl_project(G: Any, k: int, s: float, x: float, y: float) -> float:
    """Arc length of the trace whose follower-k offset point is nearest (x, y): Newton steps
    on (p − P)·t / (1 − κo) from ``s``."""
    for _ in range(6):
        px, py, _, scale, c, sn = trace_frame(G, k, s)
        ds = ((x - px) * c + (y - py) * sn) / scale
        s += ds
        if abs(ds) < 1e-3:
            return s  # (not ``break``: after a break numba keeps G's increfs and decrefs)
    return s


@kernel
def ftl_reference(
    G: Any, s_ref: Any, k: int, s_l: float, xl: float, yl: float, hl: float, v_l: float
) -> tuple[float, float]:
    """(s_ref, V_ref) of follower k for the leader at arc length ``s_l``, pose (xl, yl, hl),
    speed ``v_l``: `ftl_reference_frame` with the heading's cosine and sine."""
    return ftl_reference_frame(G, s_ref, k, s_l, xl, yl, math.cos(hl), math.sin(hl), v_l)


@kernel
def ftl_reference_frame(
    G: Any, s_ref: Any, k: int, s_l: float, xl: float, yl: float, cl: float, sl: float, v_l: float
) -> tuple[float, float]:
    """(s_ref, V_ref) of follower k for the leader at arc length ``s_l``, position (xl, yl),
    heading hl given by its cosine ``cl`` and sine ``sl`` (``math.cos``/``math.sin`` of it),
    speed ``v_l``: down the chain of whom it follows, each one's reference behind the point it
    follows at its spacing (`ftl_search`) and that point's speed by (FTL-1) — V_T where the
    reference's tangent is nearly across the line. Updates ``s_ref`` (NaN: none yet) of each."""
    fol = G[3]  # (offset, whom it follows, spacing) per follower
    depth = 0  # how many followers k follows through
    j = int(fol[3 * k + 1])
    while j >= 0:
        depth += 1
        j = int(fol[3 * j + 1])
    # the point followed: arc length, position, its heading's cosine and sine, speed
    s_t, tx, ty, ct, st, v_t = s_l, xl, yl, cl, sl, v_l
    sr = v_ref = 0.0
    for c in range(depth, -1, -1):
        q = k
        for _ in range(c):
            q = int(fol[3 * q + 1])
        sr = ftl_search(G, q, s_ref[q], s_t, tx, ty, fol[3 * q + 2])
        s_ref[q] = sr
        # (the reference point and its heading's cosine and sine: `trace_frame`'s, the
        # doubles ``math.cos``/``math.sin`` give for its heading)
        px, py, _, _, cp, sp = trace_frame(G, q, sr)
        dx, dy = tx - px, ty - py
        den = dx * cp + dy * sp
        if den <= 0.1 * cpython_hypot(dx, dy):
            v_ref = v_t
        else:
            v_ref = v_t * (dx * ct + dy * st) / den
        s_t, tx, ty, ct, st, v_t = sr, px, py, cp, sp, v_ref  # the next one follows this one
    return sr, v_ref


@kernel
def ftl_command(
    G: Any,
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
    """(v, ω) of follower k at (x, y, θ) (the leader's estimate), unsaturated:
    `ftl_command_frame` with the leader's heading ``hl`` as its cosine and sine."""
    return ftl_command_frame(
        G, s_ref, s_f, gain, lookahead, k, s_l, xl, yl, math.cos(hl), math.sin(hl), v_l, x, y, th
    )


@kernel
def ftl_command_frame(
    G: Any,
    s_ref: Any,
    s_f: Any,
    gain: float,
    lookahead: float,
    k: int,
    s_l: float,
    xl: float,
    yl: float,
    cl: float,
    sl: float,
    v_l: float,
    x: float,
    y: float,
    th: float,
) -> tuple[float, float]:
    """(v, ω) of follower k at (x, y, θ) (the leader's estimate), unsaturated, for the leader
    at (xl, yl) with the cosine and sine of its heading (``cl``, ``sl``: a kernel that has
    them from the leader's frame, `path_frame`, passes them rather than computing them
    again): its reference (`ftl_reference_frame`), its projection (`ftl_project`, from the
    last one, NaN: from the reference), the speed V_ref + k_ρ·(s_ref − s_f)·(1 − κo) (not
    below 0) and pure pursuit of the point ``lookahead`` ahead (not beyond the leader).
    Updates ``s_ref`` and ``s_f``."""
    sr, v_ref = ftl_reference_frame(G, s_ref, k, s_l, xl, yl, cl, sl, v_l)
    sf = s_f[k]
    if math.isnan(sf):
        sf = sr
    sf = ftl_project(G, k, sf, x, y)
    s_f[k] = sf
    v = v_ref + gain * (sr - sf) * trace_scale(G, k, sf)
    if not v > 0.0:
        v = 0.0
    ahead_s = sf + lookahead
    if s_l < ahead_s:
        ahead_s = s_l
    gx, gy, _ = trace_point(G, k, ahead_s)
    dx, dy = gx - x, gy - y
    dist = cpython_hypot(dx, dy)
    if dist < 1e-9:
        return v, 0.0
    alpha = math.atan2(dy, dx) - th
    return v, v * 2.0 * math.sin(alpha) / dist


@kernel
def _bisect_segment(G: Any, s: float) -> tuple[int, float]:
    """`path_segment` by the standard library's bisect_right (the Python twins')."""
    u = s % G[2]
    return bisect.bisect_right(G[0], u) - 1, u


#: the Python twins (`rtsim.world.jit.specialise`): ``math.hypot`` for `cpython_hypot`,
#: ``bisect`` for `path_segment`'s loop
_PY_SUBS = (*HYPOT_SUBS, (path_segment, _bisect_segment))
_PY_POINT = specialise(trace_point, _PY_SUBS)
_PY_REFERENCE = specialise(ftl_reference, _PY_SUBS)
_PY_COMMAND = specialise(ftl_command, _PY_SUBS)
_PY_PROJECT = specialise(ftl_project, _PY_SUBS)


class TraceFollower:
    """Follow-the-leader references and commands for n followers on ``path`` (the module's
    kernel sources, run as Python).

    ``rho_d``: each follower's separation (cm); ``lateral``: its offset from the trace (cm,
    left positive); ``gain`` k_ρ (1/s); ``lookahead`` ℓ (cm). Holds, per follower, the last
    reference and projection arc lengths (``_sr``, ``_sf``, NaN: none yet; searches start
    there).
    """

    def __init__(
        self,
        path: LeaderPath,
        rho_d: Sequence[float],
        lateral: Sequence[float],
        gain: float,
        lookahead: float,
    ) -> None:
        self.path = path
        self.rho_d = [float(r) for r in rho_d]
        self.lateral = [float(o) for o in lateral]
        # whom each follower follows (-1: the leader) and at what distance
        self.ahead: list[int] = []
        self.spacing: list[float] = []
        for k, (r, o) in enumerate(zip(self.rho_d, self.lateral, strict=True)):
            j = k - 2
            if j >= 0 and self.rho_d[j] < r:
                aj = math.sqrt(max(0.0, self.rho_d[j] ** 2 - self.lateral[j] ** 2))
                ak = math.sqrt(max(0.0, r * r - o * o))
                self.ahead.append(j)
                self.spacing.append(math.hypot(ak - aj, o - self.lateral[j]))
            else:
                self.ahead.append(-1)
                self.spacing.append(r)
        self.gain = float(gain)
        self.lookahead = float(lookahead)
        #: the geometry G the equations read, as Python tuples (module comment)
        fol = zip(self.lateral, self.ahead, self.spacing, strict=True)
        self.geometry: tuple[Any, ...] = (
            *path.geometry(),
            tuple(float(c) for row in fol for c in row),
        )
        n = len(self.rho_d)
        self._sr: Any = [math.nan] * n
        self._sf: Any = [math.nan] * n
        # what the equations run on: G and its functions (the compiled subclass swaps them)
        self._G: tuple[Any, ...] = self.geometry
        self._reference: Any = _PY_REFERENCE
        self._command: Any = _PY_COMMAND
        self._project: Any = _PY_PROJECT
        self._point: Any = _PY_POINT

    def clone(self) -> TraceFollower:
        """A copy with its own search starts (a rollout plays commands ahead on it without
        moving this law's)."""
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new._sr = self._sr.copy()
        new._sf = self._sf.copy()
        return new

    @property
    def _s_ref(self) -> list[float | None]:
        """The last references (None: none yet), as a list (for readers and tests)."""
        return [None if s != s else float(s) for s in self._sr]

    @property
    def _s_f(self) -> list[float | None]:
        """The last projections (None: none yet), as a list."""
        return [None if s != s else float(s) for s in self._sf]

    # -- geometry --------------------------------------------------------------------
    def point(self, k: int, s: float) -> tuple[float, float, float]:
        """P_k(s) and the heading there: (x, y, heading) of follower index k's offset curve."""
        return self._point(self._G, k, s)  # type: ignore[no-any-return]

    def reference(
        self, k: int, s_l: float, leader: tuple[float, float, float], v_l: float
    ) -> tuple[float, float]:
        """(s_ref, V_ref) of follower index k for the leader at arc length ``s_l``, pose
        ``leader``, speed ``v_l`` (`ftl_reference`)."""
        xl, yl, hl = leader
        return self._reference(self._G, self._sr, k, s_l, xl, yl, hl, v_l)  # type: ignore[no-any-return]

    def project(self, k: int, x: float, y: float, guess: float) -> float:
        """Arc length of the trace whose offset point is nearest (x, y) (`ftl_project`, from
        the last projection, or ``guess``)."""
        s = self._sf[k]
        if s != s:
            s = guess
        s = self._project(self._G, k, s, x, y)
        self._sf[k] = s
        return s  # type: ignore[no-any-return]

    # -- the controller --------------------------------------------------------------
    def initial(
        self, k: int, s_l: float, leader: tuple[float, float, float], v_l: float
    ) -> tuple[float, float, float, float]:
        """(x, y, heading, speed) of follower index k on its reference, moving with it."""
        s_ref, v_ref = self.reference(k, s_l, leader, v_l)
        x, y, h = self.point(k, s_ref)
        self._sf[k] = s_ref
        return x, y, h, v_ref

    def command(
        self,
        k: int,
        s_l: float,
        leader: tuple[float, float, float],
        v_l: float,
        x: float,
        y: float,
        th: float,
    ) -> tuple[float, float]:
        """(v, ω) for follower index k at (x, y, θ) (the leader's estimate), unsaturated
        (`ftl_command`)."""
        xl, yl, hl = leader
        return self._command(  # type: ignore[no-any-return]
            self._G,
            self._sr,
            self._sf,
            self.gain,
            self.lookahead,
            k,
            s_l,
            xl,
            yl,
            hl,
            v_l,
            x,
            y,
            th,
        )
