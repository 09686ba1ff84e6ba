"""The Hough transform in a follower's window: accumulator, votes, peak (docs/localization.md).

A follower is a disc of radius r_F; the scan points it returns lie on its near side, at r_F
from its centre. The leader seeks each centre in a **window**, the disc of radius r_H around
the window centre c. The window's **accumulator** has one cell per candidate centre: the
square cells of side ``cell`` (`CELL_CM` = 1 cm, so that a window covers π·r_H² cells,
Eq 1's first term taken literally) whose centres lie within r_H of c.

A scan point p **can belong** to a disc centred in the window when

    r_F − r_H ≤ |p − c| ≤ r_F + r_H;

those are the points that vote (Eq 1's second term, counted). Each votes once for every
cell of the window at distance r_F from it: the ring of radius r_F around p is walked at
half-cell steps (`ring`), and each cell it enters gets one vote from that point. The
**peak** is the cell with the most votes (ties: the mean of the tied cells within two cells
of the first in row-major order); it is the fix when it has at least ``min_points`` votes,
otherwise the window has no fix. The cells are anchored at the window centre, so a fix is a
multiple of ``cell`` away from it (up to the mean of tied cells). The window does no data
association: points of a neighbour that fall in the window vote as well and can take the
peak. Whose points made the peak is read from the
truth (each beam's owner), only to count it: the owner with the most points within one cell
of the ring through the peak.

`hough_window` and `locate_all` are plain functions that numba compiles
(`compiled`); the Python path runs the same functions and is the reference in the
tests.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rtsim.world.jit import build, kernel
from rtsim.world.kernels import built_entry

__all__ = [
    "CELL_CM",
    "EPOCHS",
    "VOTE_BITS",
    "WINDOW_ROW",
    "Accumulator",
    "compiled",
    "TURNS",
    "hough_window",
    "locate_all",
    "peak_fix",
    "ring",
    "ring_arc",
    "ring_cells",
    "ring_steps",
    "window_cells",
    "window_votes",
]

#: The accumulator's cell side (cm): 1 cm² cells make a window of radius r_H cover π·r_H²
#: cells, Eq 1's first term.
CELL_CM = 1.0

#: One window's outcome, a record of `hough_window`'s output: the fix (cm; NaN, NaN when no
#: point voted), the peak's votes, the points that voted, the follower whose points made the
#: peak (−1: none) and the window's cells.
WINDOW_ROW = np.dtype(
    [
        ("fix_x", np.float64),
        ("fix_y", np.float64),
        ("votes", np.int64),
        ("voters", np.int64),
        ("owner", np.int64),
        ("cells", np.int64),
    ]
)

_COMPILED: Any = None

#: A window's working arrays: the ring's steps (`ring_steps`: x, y) and the scratch (cell
#: words, tally, state, cells) of `hough_window`.
Work = tuple[
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.int64],
    NDArray[np.int64],
    NDArray[np.int64],
    NDArray[np.int64],
]

#: A cell's word in `hough_window`'s scratch: the stamp of the last point that voted for it
#: in the bits above `VOTE_BITS`, its votes below (one load and one store a vote, half the
#: footprint of two arrays); stamps stay below 2**(63 − VOTE_BITS) (`EPOCHS`).
VOTE_BITS = 32
#: The epoch past which `hough_window` clears the words and starts again from 0.
EPOCHS = 2 ** (63 - VOTE_BITS) - 1

#: `ring_steps` repeats the ring this many turns: an arc's direction indices a0 … a1 lie in
#: [−2·na, 3·na) (θ ± γ within ±2π, a step of margin each side), read at a + 2·na
TURNS = 5


def ring(r_F: float, cell: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The unit directions a point's ring of radius ``r_F`` is walked along: half-cell
    steps, so that no cell the ring crosses is skipped."""
    m = max(8, math.ceil(2.0 * math.pi * r_F / (0.5 * cell)))
    a = 2.0 * math.pi * np.arange(m) / m
    return np.cos(a), np.sin(a)


def ring_steps(r_F: float, cell: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The ring's points relative to its centre, r_F·cos and r_F·sin of each direction of
    `ring` (the products the walk would form at each step, formed once), `TURNS` turns
    over: direction a (any a in [−2·na, 3·na)) at index a + 2·na, so an arc is one run of
    indices."""
    c, s = _ring_steps(r_F, cell)  # (made once per process for r_F and cell: copied)
    return c.copy(), s.copy()


@lru_cache(maxsize=16)
def _ring_steps(r_F: float, cell: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """`ring_steps`' arrays, kept per process by r_F and the cell (never written: a world
    copies them into its buffers)."""
    c, s = ring(r_F, cell)
    return np.tile(r_F * c, TURNS), np.tile(r_F * s, TURNS)


@lru_cache(maxsize=64)
def window_cells(r_H: float, cell: float = CELL_CM) -> int:
    """The cells of a window of radius ``r_H``: cell centres within r_H of the window centre
    (≈ π·r_H²/cell²; the Gauss circle count; kept per process: a world asks twice)."""
    h = int(math.floor(r_H / cell))
    lim = (r_H / cell) ** 2
    i = np.arange(-h, h + 1)
    return int(((i[:, None] ** 2 + i[None, :] ** 2) <= lim).sum())


@kernel
def ring_arc(
    x: float, y: float, d: float, cx: float, cy: float, r_F: float, reach: float, na: int
) -> tuple[int, int]:
    """The arc of the ring around (``x``, ``y``) (``na`` directions, ``d`` from the window
    centre (``cx``, ``cy``)) that can reach a cell of the window: the directions u with
    |p + r_F·u − c| ≤ ``reach``, within γ of the direction from p to c, a step of margin
    each side (the whole ring when that is all of it or d = 0). Returns its first direction
    index a0 (in [−2·na, 3·na)) and its length."""
    if d > 0.0:
        cg = (r_F * r_F + d * d - reach * reach) / (2.0 * r_F * d)
        if cg > -1.0:
            step = 2.0 * math.pi / na
            gamma = math.acos(min(cg, 1.0))
            theta = math.atan2(cy - y, cx - x)
            a0 = int(math.floor((theta - gamma) / step)) - 1
            a1 = int(math.ceil((theta + gamma) / step)) + 1
            if a1 - a0 + 1 < na:
                return a0, a1 - a0 + 1
    return 0, na


@kernel
def ring_cells(
    x: float,
    y: float,
    cx: float,
    cy: float,
    rx: NDArray[np.float64],
    ry: NDArray[np.float64],
    b: int,
    n: int,
    cell: float,
    r_H: float,
    into: NDArray[np.int64],
) -> None:
    """The cells that ``n`` steps of a point's ring enter, from index ``b`` of ``rx``, ``ry``
    (`ring_steps`), into ``into[:n]``: cell (i, j) of the window of radius ``r_H`` as
    i·(2h+1) + j (h = ⌊r_H/cell⌋), −1 where the step lands outside the
    window. No branch on the data, so that the compiler can run the steps side by side."""
    h = int(math.floor(r_H / cell))
    m = 2 * h + 1
    lim = (r_H / cell) * (r_H / cell)
    # a cell of a power of two (1 cm): times 1/cell is over cell, exactly, and cheaper
    inv = 1.0 / cell
    mul = math.frexp(cell)[0] == 0.5
    # the steps as views indexed from 0 (numba then knows the index is not negative and
    # loads the steps side by side, not one by one)
    sx = rx[b : b + n]
    sy = ry[b : b + n]
    for t in range(n):
        u = x + sx[t] - cx
        v = y + sy[t] - cy
        i = int(math.floor((u * inv if mul else u / cell) + 0.5)) + h
        j = int(math.floor((v * inv if mul else v / cell) + 0.5)) + h
        di = i - h
        dj = j - h
        inside = (i >= 0) & (j >= 0) & (i < m) & (j < m) & (di * di + dj * dj <= lim)
        into[t] = i * m + j if inside else -1


@kernel
def hough_window(
    px: NDArray[np.float64],
    py: NDArray[np.float64],
    owner: NDArray[np.int64],
    cx: float,
    cy: float,
    r_H: float,
    r_F: float,
    cell: float,
    cells: int,
    work: Work,
    out: NDArray[np.void],
    k: int,
) -> None:
    """One window's Hough transform (module docstring) on the scan points (``px``, ``py``;
    NaN: no return) whose beams hit ``owner`` (−1: none), window centre (``cx``, ``cy``),
    radius ``r_H`` (``cells`` of side ``cell``: `window_cells`), into record ``k`` of
    ``out`` (`WINDOW_ROW`): `locate_all` with this one window."""
    cxs, cys = np.empty(1), np.empty(1)  # (not np.full: `locate_all`'s note on np.empty)
    cxs[0], cys[0] = cx, cy
    locate_all(px, py, owner, cxs, cys, r_H, r_F, cell, cells, work, out[k : k + 1])


@kernel
def window_votes(
    px: NDArray[np.float64],
    py: NDArray[np.float64],
    owner: NDArray[np.int64],
    hits: NDArray[np.int64],
    nh: int,
    cx: float,
    cy: float,
    r_H: float,
    r_F: float,
    cell: float,
    cells: int,
    work: Work,
    out: NDArray[np.void],
    k: int,
) -> None:
    """`hough_window` on the scan points of the beams ``hits[:nh]`` (`locate_all`: the
    others returned nothing). ``work``: the ring's
    steps (`ring_steps`) and the scratch (`Accumulator`): ``word``, at least (2h+1)² cells,
    h = ⌊r_H/cell⌋, cell (i, j) at i·(2h+1) + j, cleared only when the epochs run out
    (`EPOCHS`) — each point p stamps the cells it votes for with ep + p + 1 (`VOTE_BITS`),
    ep this call's epoch (``state[0]``, advanced by each call past every stamp it gives), so
    a point votes for a cell once and a cell's votes count only if its stamp is above ep —,
    ``tally``, one entry per follower, and ``into``, one entry per direction. Writes record
    ``k`` of ``out`` (`WINDOW_ROW`)."""
    rx, ry, word, tally, state, into = work
    h = int(math.floor(r_H / cell))
    m = 2 * h + 1
    if state[0] + px.shape[0] + 2 > EPOCHS:
        word[:] = 0
        state[0] = 0
    ep = state[0] + 1
    state[0] = ep + px.shape[0] + 1
    low = (1 << VOTE_BITS) - 1
    lo = r_F - r_H
    hi = r_F + r_H
    voters = 0
    best = 0
    bf = -1
    na = rx.shape[0] // TURNS
    for e in range(nh):
        p = hits[e]
        x = px[p]
        y = py[p]
        d = math.sqrt((x - cx) * (x - cx) + (y - cy) * (y - cy))
        if d < lo or d > hi:
            continue
        voters += 1
        me = ep + p + 1
        # only the arc of the ring that can reach a cell of the window
        a0, n = ring_arc(x, y, d, cx, cy, r_F, r_H + cell, na)
        ring_cells(x, y, cx, cy, rx, ry, a0 + 2 * na, n, cell, r_H, into)
        # the cells in the window, less a step in the cell of the step before (the stamp
        # would refuse it), to the front of ``into``, without a branch on the data
        w = 0
        last = -2
        for t in range(n):
            f = into[t]
            into[w] = f
            w += (f != last) & (f >= 0)
            last = f
        for t in range(w):
            f = into[t]
            sw = word[f]
            s = sw >> VOTE_BITS
            if s == me:  # (an earlier step of this point's ring)
                continue
            v = ((sw & low) if s > ep else 0) + 1
            word[f] = (me << VOTE_BITS) | v
            # the peak: the most votes, the first in row-major order (the cells') among equals
            if v > best or (v == best and f < bf):
                best = v
                bf = f
    # the record: the fix, the mean of the tied cells within two cells of the peak, and the
    # owner, the follower with the most points within one cell of the ring through the fix
    rec = out[k]
    rec["voters"] = voters
    rec["cells"] = cells
    rec["votes"] = best
    if bf < 0:
        rec["fix_x"] = math.nan
        rec["fix_y"] = math.nan
        rec["owner"] = -1
        return
    bi = bf // m
    bj = bf - bi * m
    si = 0.0
    sj = 0.0
    cnt = 0
    for i in range(max(0, bi - 2), min(m, bi + 3)):
        for j in range(max(0, bj - 2), min(m, bj + 3)):
            sw = word[i * m + j]
            if (sw >> VOTE_BITS) > ep and (sw & low) == best:
                si += i
                sj += j
                cnt += 1
    fx = cx + (si / cnt - h) * cell
    fy = cy + (sj / cnt - h) * cell
    rec["fix_x"] = fx
    rec["fix_y"] = fy
    for q in range(tally.shape[0]):
        tally[q] = 0
    # (a point that counts lies within r_F + cell of the fix, the fix within r_H of the
    # centre: every such point is one of the scan's)
    for e in range(nh):
        p = hits[e]
        q = owner[p]
        if q < 0:
            continue
        d = math.sqrt((px[p] - fx) * (px[p] - fx) + (py[p] - fy) * (py[p] - fy))
        if abs(d - r_F) <= cell:
            tally[q] += 1
    who = -1
    most = 0
    for q in range(tally.shape[0]):
        if tally[q] > most:
            most = tally[q]
            who = q
    rec["owner"] = who


@kernel
def peak_fix(votes: int, who: int, k: int, min_pts: int) -> tuple[bool, bool]:
    """Window ``k``'s outcome from its peak's ``votes`` and the follower ``who`` made it
    (`WINDOW_ROW`): whether the peak is the fix (at least ``min_pts`` votes), and whether
    another follower's points made it (the track is lost to a neighbour)."""
    if votes >= min_pts:
        return True, who >= 0 and who != k
    return False, False


@kernel
def locate_all(
    px: NDArray[np.float64],
    py: NDArray[np.float64],
    owner: NDArray[np.int64],
    cxs: NDArray[np.float64],
    cys: NDArray[np.float64],
    r_H: float,
    r_F: float,
    cell: float,
    cells: int,
    work: Work,
    out: NDArray[np.void],
) -> None:
    """`hough_window` for every follower's window (centres ``cxs``, ``cys``), one
    `WINDOW_ROW` of ``out`` each: `window_votes` on the beams that returned (``px`` not
    NaN), found once for every window."""
    # (np.empty's dtype by keyword, as every kernel writes it: numba compiles np.empty once
    # per calling style, not per signature; np.zeros and np.full each compile one more)
    hits = np.empty(px.shape[0], dtype=np.int64)
    nh = 0
    for p in range(px.shape[0]):
        if px[p] == px[p]:
            hits[nh] = p
            nh += 1
    for k in range(cxs.shape[0]):
        window_votes(px, py, owner, hits, nh, cxs[k], cys[k], r_H, r_F, cell, cells, work, out, k)


def compiled() -> Any:
    """(hough_window, locate_all) compiled with numba (`rtsim.world.jit.build`: once
    per process, cached on disk by their sources), loaded or compiled now — hough_window,
    which only a re-acquisition search runs, at its first call (`compiled_window`)."""
    global _COMPILED
    if _COMPILED is None:
        every = build(locate_all)
        every(*_dummy(every=True))
        _COMPILED = (compiled_window, every)
    return _COMPILED


def compiled_window(*args: Any) -> Any:
    """`hough_window` compiled (or loaded) at the first call, then called."""
    global _WINDOW
    if _WINDOW is None:
        _WINDOW = build(hough_window)
    return _WINDOW(*args)


_WINDOW: Any = None


def _dummy(every: bool) -> tuple[Any, ...]:
    """Arguments that compile the kernels once (an empty scan)."""
    px = np.full(3, np.nan)
    c, s = ring_steps(25.0, 1.0)
    word = np.zeros(121, dtype=np.int64)
    centre: Any = (np.zeros(1), np.zeros(1)) if every else (0.0, 0.0)
    one = np.zeros(1, dtype=np.int64)
    work = (c, s, word, one, one.copy(), np.zeros(c.size, np.int64))
    out = (np.zeros(1, WINDOW_ROW),) if every else (np.zeros(1, WINDOW_ROW), 0)
    return (px, px, np.full(3, -1, dtype=np.int64), *centre, 5.0, 25.0, 1.0, 81, work, *out)


class Accumulator:
    """The windows' accumulators for one world: scratch sized for the largest window
    (``r_max``), the ring for ``r_F``; ``fast`` runs the compiled kernels."""

    def __init__(self, n: int, r_F: float, r_max: float, fast: bool, cell: float = CELL_CM):
        self.r_F = float(r_F)
        self.cell = float(cell)
        self.ring_x, self.ring_y = ring_steps(self.r_F, self.cell)
        m = 2 * int(math.floor(r_max / cell)) + 1
        self.word = np.zeros(m * m, dtype=np.int64)
        self.tally = np.zeros(max(n, 1), dtype=np.int64)
        self.state = np.zeros(1, dtype=np.int64)
        self.into = np.zeros(self.ring_x.size // TURNS, dtype=np.int64)
        self.work: Work = (
            self.ring_x, self.ring_y, self.word, self.tally, self.state, self.into,
        )  # fmt: skip
        self._cells: dict[float, int] = {}
        self.out = np.zeros(n, WINDOW_ROW)
        self.one = np.zeros(1, WINDOW_ROW)
        # called directly (`rtsim.world.kernels.entry`: the work tuple is not typed again at
        # every call), with the types of `_dummy`'s arguments, which every call passes; in
        # ``fast``, each compiled at its first call (the compiled world runs the windows in
        # its scan's kernel, `rtsim.world.scanstep`, and searches rarely)
        self._one: Any = compiled_window if fast else hough_window
        self._every: Any = None if fast else locate_all

    def cells(self, r_H: float) -> int:
        """`window_cells` of a window of radius ``r_H`` (computed once per radius)."""
        c = self._cells.get(r_H)
        if c is None:
            c = self._cells[r_H] = window_cells(r_H, self.cell)
        return c

    def locate(
        self,
        px: NDArray[np.float64],
        py: NDArray[np.float64],
        owner: NDArray[np.int64],
        cxs: NDArray[np.float64],
        cys: NDArray[np.float64],
        r_H: float,
    ) -> NDArray[np.void]:
        """Every follower's window: its `WINDOW_ROW` records (valid until the next call)."""
        cells = self.cells(r_H)
        if self._every is None:
            self._every = built_entry(build(locate_all), _dummy(every=True))
        self._every(px, py, owner, cxs, cys, r_H, self.r_F, self.cell, cells, self.work, self.out)
        return self.out

    def search(
        self,
        px: NDArray[np.float64],
        py: NDArray[np.float64],
        owner: NDArray[np.int64],
        cx: float,
        cy: float,
        radius: float,
    ) -> np.void:
        """One window of ``radius`` around (``cx``, ``cy``) (a re-acquisition search): its
        `WINDOW_ROW` record (valid until the next call)."""
        cells = self.cells(radius)
        self._one(px, py, owner, cx, cy, radius, self.r_F, self.cell, cells, self.work, self.one, 0)
        return self.one[0]
