"""Bounded sketches of what a long run's figures draw, built chunk by chunk: a path's
polyline without its retraced segments (`LineSketch`), a translucent scatter with at most
a few points per grid cell (`PointSketch`) and a dot series with one dot per time bin and
value band (`DotSketch`). Each holds at most a fixed number of items per cell of a grid
fixed before the first chunk, so its size is bounded by the grid, not by the run's length
(docs/reliability.md, "Figures of any length"). Pure numpy: `rtsim.plots.scenario_data`
feeds them, `rtsim.plots.scenario` draws them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["DotSketch", "FigureSketch", "Grid", "LineSketch", "PointSketch"]


@dataclass(frozen=True)
class Grid:
    """Square cells of side ``cell`` (data units) from ``(x0, y0)``, ``size`` per row."""

    x0: float
    y0: float
    cell: float
    size: int

    @classmethod
    def over(cls, lo: tuple[float, float], hi: tuple[float, float], cells: int) -> Grid:
        """``cells`` cells across the larger side of the box ``lo``..``hi``."""
        side = max(hi[0] - lo[0], hi[1] - lo[1], 1e-9)
        return cls(lo[0], lo[1], side / cells, cells + 2)

    def ids(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Each (finite) point's cell number."""
        cx = np.clip(np.floor((x - self.x0) / self.cell), -1, self.size - 2).astype(np.int64)
        cy = np.clip(np.floor((y - self.y0) / self.cell), -1, self.size - 2).astype(np.int64)
        return (cx + 1) * self.size + (cy + 1)


def _joined(a: list[np.ndarray], b: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Two lists of per-chunk arrays, each concatenated."""
    if not a:
        return np.zeros(0), np.zeros(0)
    return np.concatenate(a), np.concatenate(b)


def _merge_counts(
    ids: np.ndarray, counts: np.ndarray, new: np.ndarray, cap: int
) -> tuple[np.ndarray, np.ndarray]:
    """Sorted ``ids`` with ``counts`` plus the cells of ``new`` (each occurrence counted),
    capped at ``cap``."""
    u, c = np.unique(new, return_counts=True)
    merged = np.union1d(ids, u)
    out = np.zeros(len(merged), dtype=np.int64)
    out[np.searchsorted(merged, ids)] += counts
    out[np.searchsorted(merged, u)] += c
    return merged, np.minimum(out, cap)


class LineSketch:
    """An opaque polyline fed in order, keeping a segment between consecutive points unless
    every point sampled along it (at most ``grid.cell`` apart) falls in a cell first
    crossed more than ``lag`` segments before: a lap retracing the path within a cell
    adds nothing, while the path's own consecutive segments (which share cells) are all
    kept. Kept segments form runs separated by NaN (a break in a matplotlib line). Each
    kept segment crosses a cell first crossed at most ``lag`` segments before, so at most
    ``lag`` + 1 segments are kept per cell of the grid, whatever the run's length."""

    def __init__(self, grid: Grid, lag: int = 64) -> None:
        self.grid = grid
        self.lag = lag
        self.seen = np.zeros(0, dtype=np.int64)  # cells crossed, sorted
        self.first = np.zeros(0, dtype=np.int64)  # the segment that first crossed each
        self.base = 0  # segments fed before this chunk
        self.kept = 0  # segments kept
        self.last: tuple[float, float] | None = None
        self.open = False  # the last point is the end of a kept segment
        self.xs: list[np.ndarray] = []
        self.ys: list[np.ndarray] = []

    #: Points handled at a time (the samples along their segments are the transient arrays).
    SLICE = 256

    def add(self, x: np.ndarray, y: np.ndarray) -> None:
        for a in range(0, len(x), self.SLICE):
            self._add(x[a : a + self.SLICE], y[a : a + self.SLICE])

    def _add(self, x: np.ndarray, y: np.ndarray) -> None:
        carried = self.last is not None
        if self.last is not None:
            x, y = np.r_[self.last[0], x], np.r_[self.last[1], y]
        m = len(x)
        if m == 0:
            return
        self.last = (float(x[-1]), float(y[-1]))
        if m < 2:
            return
        ok = np.isfinite(x) & np.isfinite(y)
        seg = np.flatnonzero(ok[:-1] & ok[1:])
        dx, dy = np.diff(x)[seg], np.diff(y)[seg]
        n = np.ceil(np.hypot(dx, dy) / self.grid.cell).astype(np.int64) + 1
        owner = np.repeat(np.arange(len(seg)), n)
        start = np.repeat(np.cumsum(n) - n, n)
        frac = (np.arange(len(owner)) - start) / np.maximum(np.repeat(n, n) - 1, 1)
        ids = self.grid.ids(x[seg][owner] + frac * dx[owner], y[seg][owner] + frac * dy[owner])
        g = self.base + seg[owner]  # each sample's segment, counted over the whole line
        uniq, inv = np.unique(ids, return_inverse=True)
        first = np.full(len(uniq), np.iinfo(np.int64).max)
        np.minimum.at(first, inv, g)
        known = np.zeros(len(uniq), dtype=bool)
        if len(self.seen):
            at = np.minimum(np.searchsorted(self.seen, uniq), len(self.seen) - 1)
            known = self.seen[at] == uniq
            first[known] = self.first[at[known]]
        young = first[inv] >= g - self.lag
        kept = np.zeros(m - 1, dtype=bool)
        kept[seg[np.unique(owner[young])]] = True
        cells = np.r_[self.seen, uniq[~known]]
        order = np.argsort(cells, kind="stable")
        self.seen, self.first = cells[order], np.r_[self.first, first[~known]][order]
        self.base += m - 1
        self.kept += int(np.count_nonzero(kept))
        prev = np.r_[False, kept]  # vertex j ends kept segment j - 1
        nxt = np.r_[kept, False]  # vertex j starts kept segment j
        drawn = prev | nxt
        breaks = nxt & ~prev
        if carried and self.open:  # the carried vertex was drawn; its run goes on
            drawn[0] = breaks[0] = False
        idx = np.flatnonzero(drawn)
        xo = np.insert(x[idx], np.flatnonzero(breaks[idx]), np.nan)
        yo = np.insert(y[idx], np.flatnonzero(breaks[idx]), np.nan)
        if len(xo):
            self.xs.append(xo)
            self.ys.append(yo)
        self.open = bool(kept[-1])

    def xy(self) -> tuple[np.ndarray, np.ndarray]:
        return _joined(self.xs, self.ys)

    def passes(self) -> float:
        """Segments fed per segment kept: about how often the path was traced."""
        return self.base / self.kept if self.kept else 1.0


class _Cells:
    """Kept items per cell (sorted cell numbers and counts): `take` keeps, in order, the
    items whose cell holds fewer than ``cap`` kept ones."""

    def __init__(self, cap: int) -> None:
        self.cap = cap
        self.ids = np.zeros(0, dtype=np.int64)
        self.counts = np.zeros(0, dtype=np.int64)

    def take(self, ids: np.ndarray) -> np.ndarray:
        order = np.argsort(ids, kind="stable")
        s = ids[order]
        starts = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
        rank = np.empty(len(s), dtype=np.int64)
        rank[order] = np.arange(len(s)) - np.repeat(starts, np.diff(np.r_[starts, len(s)]))
        prior = np.zeros(len(ids), dtype=np.int64)  # items kept in each one's cell before
        if len(self.ids):
            at = np.minimum(np.searchsorted(self.ids, ids), len(self.ids) - 1)
            hit = self.ids[at] == ids
            prior[hit] = self.counts[at[hit]]
        keep = prior + rank < self.cap
        self.ids, self.counts = _merge_counts(self.ids, self.counts, ids[keep], self.cap)
        return keep

    def __len__(self) -> int:
        return len(self.ids)

    def forget_below(self, cell: int) -> None:
        """Drop the counts of the cells numbered below ``cell`` (no item will fall there)."""
        at = int(np.searchsorted(self.ids, cell))
        self.ids, self.counts = self.ids[at:].copy(), self.counts[at:].copy()


class PointSketch:
    """A scatter fed in order, keeping a point (as float32) while its grid cell holds fewer
    than ``cap`` kept points: where a cell a few pixels wide is full, the markers (wider
    than the cell) piled from it and its neighbours already cover each pixel many times
    over."""

    def __init__(self, grid: Grid, cap: int) -> None:
        self.grid = grid
        self.cells = _Cells(cap)
        self.xs: list[np.ndarray] = []
        self.ys: list[np.ndarray] = []

    def add(self, x: np.ndarray, y: np.ndarray) -> None:
        ok = np.isfinite(x) & np.isfinite(y)
        x, y = x[ok], y[ok]
        if not len(x):
            return
        keep = self.cells.take(self.grid.ids(x, y))
        self.xs.append(x[keep].astype(np.float32))
        self.ys.append(y[keep].astype(np.float32))

    def xy(self) -> tuple[np.ndarray, np.ndarray]:
        return _joined(self.xs, self.ys)


class DotSketch:
    """Dots (time, value) fed in time order with a non-decreasing, non-negative time bin
    each: a dot is kept while its cell, ``bins`` consecutive time bins by a ``band``-high
    value band, holds fewer than ``cap`` kept dots (across chunks too; only the cells of
    the current time cell are remembered). At most ``cap`` dots per cell, kept as float32
    (a pixel is thousands of ms wide and high multiples of their error); ``count`` is every
    dot fed (drawn or not)."""

    #: Value bands per time cell in a cell number (values beyond are clipped to the last).
    BANDS = 1 << 20

    def __init__(self, band: float, bins: int = 1, cap: int = 1) -> None:
        self.band = band
        self.bins = bins
        self.cells = _Cells(cap)
        self.ts: list[np.ndarray] = []
        self.vs: list[np.ndarray] = []
        self.count = 0

    def add(self, bins: np.ndarray, t: np.ndarray, v: np.ndarray) -> None:
        self.count += len(v)
        if not len(v):
            return
        band = np.clip(np.floor(v / self.band), -1, self.BANDS - 2).astype(np.int64) + 1
        group = bins // self.bins
        keep = self.cells.take(group * self.BANDS + band)
        self.cells.forget_below(int(group[-1]) * self.BANDS)
        self.ts.append(t[keep].astype(np.float32))
        self.vs.append(v[keep].astype(np.float32))

    def tv(self) -> tuple[np.ndarray, np.ndarray]:
        return _joined(self.ts, self.vs)


@dataclass
class FigureSketch:
    """What a long run's figures draw besides its table's rows (`rtsim.plots.scenario_data.
    read_figures`): the paths figure's lines (``leader``, ``f1``, …) and translucent
    scatters (``f1_est``, …, ``critical``) as (x, y) in cm, and the time figures' dots by
    series (``bound_<kind>_true``, ``msb_min_true``, ``binding_<kind>``) as (t in ms,
    value in ms) with ``counts`` (every window's dot, drawn or not, and ``missed``: the
    run's deadline misses)."""

    lines: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    passes: dict[str, float] = field(default_factory=dict)
    points: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    dots: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)

    def items(self) -> int:
        """Points held (each line vertex, scatter point and dot)."""
        return sum(len(a) for d in (self.lines, self.points, self.dots) for a, _ in d.values())

    def nbytes(self) -> int:
        return sum(
            a.nbytes + b.nbytes for d in (self.lines, self.points, self.dots) for a, b in d.values()
        )
