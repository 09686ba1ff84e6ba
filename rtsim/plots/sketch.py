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
    """An opaque polyline fed in order, keeping a segment between consecutive points only
    when a point sampled along it (at most ``grid.cell`` apart) falls in a cell no earlier
    kept segment's samples fell in: a lap retracing the path within a cell adds nothing.
    Kept segments form runs separated by NaN (a break in a matplotlib line). At most one
    kept segment per cell of the grid, whatever the run's length."""

    def __init__(self, grid: Grid) -> None:
        self.grid = grid
        self.seen = np.zeros(0, dtype=np.int64)
        self.last: tuple[float, float] | None = None
        self.open = False  # the last point is the end of a kept segment
        self.xs: list[np.ndarray] = []
        self.ys: list[np.ndarray] = []

    def add(self, x: np.ndarray, y: np.ndarray) -> None:
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
        valid = ok[:-1] & ok[1:]
        seg = np.flatnonzero(valid)
        dx, dy = np.diff(x)[seg], np.diff(y)[seg]
        n = np.ceil(np.hypot(dx, dy) / self.grid.cell).astype(np.int64) + 1
        owner = np.repeat(np.arange(len(seg)), n)
        start = np.repeat(np.cumsum(n) - n, n)
        frac = (np.arange(len(owner)) - start) / np.maximum(np.repeat(n, n) - 1, 1)
        sx = x[seg][owner] + frac * dx[owner]
        sy = y[seg][owner] + frac * dy[owner]
        ids = self.grid.ids(sx, sy)
        uniq, first = np.unique(ids, return_index=True)
        fresh = ~np.isin(uniq, self.seen, assume_unique=True)
        kept = np.zeros(m - 1, dtype=bool)
        kept[seg[np.unique(owner[first[fresh]])]] = True
        self.seen = np.union1d(self.seen, uniq[fresh])
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
        if not self.xs:
            return np.zeros(0), np.zeros(0)
        return np.concatenate(self.xs), np.concatenate(self.ys)


class PointSketch:
    """A scatter fed in order, keeping a point while its grid cell holds fewer than ``cap``
    kept points: translucent markers piled ``cap`` deep in a cell under a pixel wide look
    as more would (alpha 0.3: 0.7¹⁶ < 1/255 of the colour left to add)."""

    def __init__(self, grid: Grid, cap: int) -> None:
        self.grid = grid
        self.cap = cap
        self.ids = np.zeros(0, dtype=np.int64)
        self.counts = np.zeros(0, dtype=np.int64)
        self.xs: list[np.ndarray] = []
        self.ys: list[np.ndarray] = []

    def add(self, x: np.ndarray, y: np.ndarray) -> None:
        ok = np.isfinite(x) & np.isfinite(y)
        x, y = x[ok], y[ok]
        if not len(x):
            return
        ids = self.grid.ids(x, y)
        order = np.argsort(ids, kind="stable")
        s = ids[order]
        starts = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
        rank = np.empty(len(s), dtype=np.int64)
        rank[order] = np.arange(len(s)) - np.repeat(starts, np.diff(np.r_[starts, len(s)]))
        prior = np.zeros(len(ids), dtype=np.int64)  # points kept in each one's cell before
        if len(self.ids):
            at = np.minimum(np.searchsorted(self.ids, ids), len(self.ids) - 1)
            hit = self.ids[at] == ids
            prior[hit] = self.counts[at[hit]]
        keep = prior + rank < self.cap
        self.xs.append(x[keep])
        self.ys.append(y[keep])
        self.ids, self.counts = _merge_counts(self.ids, self.counts, ids[keep], self.cap)

    def xy(self) -> tuple[np.ndarray, np.ndarray]:
        if not self.xs:
            return np.zeros(0), np.zeros(0)
        return np.concatenate(self.xs), np.concatenate(self.ys)


class DotSketch:
    """Dots (time, value) fed in time order with a non-decreasing time bin per dot: the
    first dot of each (bin, ``band``-high value band) is kept, across chunks too. At most
    one dot per bin and band; ``count`` is every dot fed (drawn or not)."""

    def __init__(self, band: float) -> None:
        self.band = band
        self.bin = -1
        self.bands: set[int] = set()  # bands of ``bin`` already kept
        self.ts: list[np.ndarray] = []
        self.vs: list[np.ndarray] = []
        self.count = 0

    def add(self, bins: np.ndarray, t: np.ndarray, v: np.ndarray) -> None:
        self.count += len(v)
        if not len(v):
            return
        band = np.floor(v / self.band).astype(np.int64)
        first = np.unique(np.column_stack([bins, band]), axis=0, return_index=True)[1]
        first = np.sort(first)
        dup = np.array(
            [
                b == self.bin and k in self.bands
                for b, k in zip(bins[first], band[first], strict=True)
            ],
            dtype=bool,
        )
        first = first[~dup]
        last = int(bins[-1])
        if last != self.bin:
            self.bin, self.bands = last, set()
        self.bands.update(int(k) for k in band[first][bins[first] == last])
        self.ts.append(t[first])
        self.vs.append(v[first])

    def tv(self) -> tuple[np.ndarray, np.ndarray]:
        if not self.ts:
            return np.zeros(0), np.zeros(0)
        return np.concatenate(self.ts), np.concatenate(self.vs)


@dataclass
class FigureSketch:
    """What a long run's figures draw besides its table's rows (`rtsim.plots.scenario_data.
    read_figures`): the paths figure's lines (``leader``, ``f1``, …) and translucent
    scatters (``f1_est``, …, ``critical``) as (x, y) in cm, and the time figures' dots by
    series (``bound_<kind>_true``, ``msb_min_true``, ``binding_<kind>``) as (t in ms,
    value in ms) with ``counts`` (every window's dot, drawn or not)."""

    lines: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
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
