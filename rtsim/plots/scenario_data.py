"""What a scenario figure shows, selected from a run's ``windows.csv`` table (docs/outputs.md):
the followers present, the critical spans, the violation ratios, the columns each figure
plots ([`figure_data`][rtsim.plots.scenario_data.figure_data]), the table a run's figures are
drawn from, read back in chunks and thinned per pixel column (`read_figure_table`), with a
long run's sketch of its paths and dots (`read_figures`, `rtsim.plots.sketch`), and the
points of each line and dot series drawn (`line_points`, `dot_points`). No drawing here:
`rtsim.plots.scenario` draws what these return.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator

import numpy as np
import pandas as pd

from rtsim.coupling.recorder import window_columns
from rtsim.errors import InputError
from rtsim.io.columns import iter_columns
from rtsim.plots.sketch import DotSketch, FigureSketch, Grid, LineSketch, PointSketch

__all__ = [
    "BOUND_KINDS",
    "BOUNDS_CLIP",
    "DOT_BAND",
    "FIGURE_BINS",
    "FIGURE_DOT_CELL",
    "FIGURE_READ_ROWS",
    "FIGURE_ROWS",
    "WINDOW_CLIP",
    "binding_xy",
    "critical_spans",
    "dot_points",
    "dot_rows_of",
    "figure_columns",
    "figure_data",
    "followers",
    "keep_extremes",
    "line_points",
    "read_figure_table",
    "read_figures",
    "reduce_chunk",
    "text_field",
    "thin_rows",
    "violation_ratios",
]

BOUND_KINDS: tuple[str, ...] = ("localization", "separation", "path_diversion", "bearing")

# Okabe-Ito colour-blind-safe palette; one colour per quantity, the same in every figure.
VIOLATION_TOLERANCE = 0.05  # a broken bound counts beyond this relative overshoot

_FOLLOWER_RE = re.compile(r"^f(\d+)_x$")


# --- the table ---------------------------------------------------------------------------


def followers(df: pd.DataFrame) -> list[int]:
    """Follower numbers (1-based) found in the columns ``f{i}_x``, in numeric order."""
    found = (_FOLLOWER_RE.match(str(c)) for c in df.columns)
    return sorted(int(m.group(1)) for m in found if m)


def need_columns(df: pd.DataFrame, cols: list[str], what: str) -> None:
    missing = [c for c in cols if c not in df.columns]
    if missing:
        raise InputError(f"windows table: missing column {missing[0]!r} (needed for {what})")


def as_bool(s: pd.Series) -> np.ndarray:
    """A boolean column as read from CSV (bool dtype, or 'True'/'False' text)."""
    if s.dtype == bool:
        return s.to_numpy()
    text = s.astype(str).str.strip().str.lower()
    return text.isin(("true", "1", "1.0")).to_numpy()


def text_field(s: pd.Series, last: bool = False, sep: str = ":") -> np.ndarray:
    """Per row, a text column's field before its first ``sep`` (``last``: after its last),
    as ``s.astype(str).str.split(sep).str[0]`` (``.str.rsplit(sep, n=1).str[-1]``) gives
    it (NaN where the cell is NaN), worked out once per distinct value: a long run's
    ``binding`` column has a few dozen values but 65,000 rows, and splitting every row
    made a list and strings per row (≈ 20 MB at 6 h)."""
    codes, uniques = pd.factorize(s.astype(str))
    fields = [u.rsplit(sep, 1)[-1] if last else u.split(sep)[0] for u in uniques]
    return np.array([*fields, np.nan], dtype=object)[codes]


def as_floats(s: pd.Series) -> np.ndarray:
    """A column's values as floats (text that is not a number: NaN); a float column's own
    values without a copy (read-only: the figures draw a long run's table column by column,
    and a copy per use was most of a figure's peak)."""
    if s.dtype == np.float64:
        return s.to_numpy()
    return pd.to_numeric(s, errors="coerce").to_numpy(dtype=float)


def times_s(df: pd.DataFrame) -> np.ndarray:
    return as_floats(df["t"]) / 1000.0


def ends_s(df: pd.DataFrame) -> np.ndarray:
    """End of each window in s: the next window's start; the last one ends at t + w."""
    t = times_s(df)
    if len(t) == 0:
        return t
    last_w = as_floats(df["w"])[-1] / 1000.0 if "w" in df.columns else 0.0
    last = t[-1] + (last_w if np.isfinite(last_w) else 0.0)
    return np.append(t[1:], last)


def spans_of(df: pd.DataFrame, mask: np.ndarray) -> list[tuple[float, float]]:
    """Maximal runs of consecutive windows where ``mask`` holds, as (start, end) in s."""
    t, ends = times_s(df), ends_s(df)
    spans: list[tuple[float, float]] = []
    start = None
    for i, on in enumerate(mask):
        if on and start is None:
            start = i
        if start is not None and (not on or i == len(mask) - 1):
            stop = i if on else i - 1
            spans.append((float(t[start]), float(ends[stop])))
            start = None
    return spans


def critical_spans(df: pd.DataFrame) -> list[tuple[float, float]]:
    """Time spans (s) of the critical region, min MSB < w_sch (runs of ``critical`` windows)."""
    need_columns(df, ["t", "critical"], "the critical region")
    return spans_of(df, as_bool(df["critical"]))


def kind_min(df: pd.DataFrame, kind: str, which: str) -> np.ndarray:
    """Per window, the minimum over followers of one bound kind's ``which`` (``pred`` or
    ``true``) column (inf when none is finite)."""
    if f"bound_{kind}_{which}" in df.columns:  # reduced as it was read (`reduce_chunk`)
        return as_floats(df[f"bound_{kind}_{which}"])
    cols = [f"f{i}_msb_{kind}_{which}" for i in followers(df)]
    need_columns(df, cols, f"the {kind} bound")
    if not cols:
        return np.full(len(df), np.inf)
    return np.min(np.column_stack([as_floats(df[c]) for c in cols]), axis=1)


def violation_ratios(df: pd.DataFrame) -> np.ndarray:
    """Per (window, follower, bound) the observed change over its threshold, w / ``_true``
    (> 1: the window broke the bound), as an (m, n·4) array (empty without ``_true``)."""
    cols = [f"f{i}_msb_{k}_true" for i in followers(df) for k in BOUND_KINDS]
    cols = [c for c in cols if c in df.columns]
    if not cols or "w" not in df.columns:
        return np.zeros((len(df), 0))
    true = np.column_stack([as_floats(df[c]) for c in cols])
    return as_floats(df["w"])[:, None] / true


def headline_counts(df: pd.DataFrame) -> str:
    """Panel headline: violations beyond 5 % and the largest violation ratio first, then
    misses and lost tracks."""
    missed = int(as_bool(df["missed"]).sum()) if "missed" in df.columns else 0
    lost = int(as_floats(df["tracks_lost"]).sum()) if "tracks_lost" in df.columns else 0
    r = violation_ratios(df)
    beyond = int((r > 1.0 + VIOLATION_TOLERANCE).sum())
    worst = float(r.max()) if r.size else 0.0
    return (
        f"violations > 5 % {beyond} · max ratio {worst:.2f} · misses {missed}\nlost tracks {lost}"
    )


def figure_columns(n: int) -> list[str]:
    """The columns of windows.csv that
    [`write_scenario_figures`][rtsim.plots.write_scenario_figures] draws (``n`` followers),
    in table order — what a long run reads back instead of the whole table."""
    need = {
        "window",
        "t",
        "w",
        "slack",
        "w_sch",
        "missed",
        "critical",
        "msb_min",
        "binding",
        "v_leader_desired",
        "v_leader",
        "v_leader_target",
        "segment",
        "leader_x",
        "leader_y",
    }
    for i in range(1, n + 1):
        need |= {f"f{i}_x", f"f{i}_y", f"f{i}_x_est", f"f{i}_y_est"}
        need |= {f"f{i}_msb_{k}_{which}" for k in BOUND_KINDS for which in ("pred", "true")}
    return [c for c in window_columns(n) if c in need]


#: The scenario figures in the order they are written (``SCENARIO_FIGURES``).
FIGURE_NAMES: tuple[str, ...] = (
    "paths",
    "window_slack",
    "bounds",
    "msb",
    "speed",
    "operating_space",
)

#: Rows of windows.csv parsed at a time when the figures' table is read back
#: (`read_figure_table`): the parser's buffers and each chunk stay this small.
FIGURE_READ_ROWS = 2048
#: Bins of the time axis `read_figure_table` keeps each plotted value's extremes of: about
#: the pixel columns of a page-wide figure (`rtsim.plots.style.PAGE_IN` × 300 dpi = 2,148
#: px, the axes a little narrower), so a bin is at most one pixel column wide.
FIGURE_BINS = 2048
#: The time figures' y axes end at most at these multiples of the run's largest w_sch: the
#: bounds, msb and operating-space figures (`BOUNDS_CLIP`), the window figure
#: (`WINDOW_CLIP`: w is capped, but the cap may be large).
BOUNDS_CLIP = 4.0
WINDOW_CLIP = 6.0
#: The band of values, as a fraction of the run's largest w_sch, within which
#: `read_figure_table` keeps one dot per bin: the time figures' y axes reach at least 1.5 ×
#: w_sch over about 500 px, so this is under 4 px; a dot is about 10 px wide.
FIGURE_DOT_CELL = 0.01
#: Most rows the figures' table holds as it is (`read_figures`): a longer run's figures
#: draw its lines from fewer rows and its paths and dots from a `FigureSketch`. 1 hour of
#: Test 2 keeps 13,202 rows, 6 hours 65,310.
FIGURE_ROWS = 16_384
#: Cells across the larger side of the paths' extent of a sketched path (`LineSketch`):
#: the paths figure's axes are under 1,100 px wide at 300 dpi, so a cell is under half a
#: pixel.
FIGURE_PATH_CELLS = 2048
#: Cells across the same extent for the translucent scatters (`PointSketch`), about two
#: pixels, and the points each keeps at most: a marker is about 10 px wide, so a pixel in
#: a full cell's neighbourhood lies under dozens of kept markers (alpha 0.3 or 0.5: under
#: 1 % of the colour left to add).
FIGURE_POINT_CELLS = 512
FIGURE_POINTS_PER_CELL = 8
#: A sketched dot series' cells (`DotSketch`): this many time bins by this many
#: `FIGURE_DOT_CELL` bands, holding at most `FIGURE_DOTS_PER_CELL` dots each.
#: The changes of ``critical`` and the misses a sketched run's table keeps at each end of a
#: time bin (`keep_extremes`' ``events``).
FIGURE_EVENTS = 2
FIGURE_DOT_BINS = 1
FIGURE_DOT_BANDS = 1
FIGURE_DOTS_PER_CELL = 1

#: The plotted values whose extremes a thinned table keeps, by name (each follower's bound
#: columns too, and the minima over followers `reduce_chunk` adds).
_GUARDED = ("w", "slack", "w_sch", "msb_min", "v_leader", "v_leader_target", "v_leader_desired")


def _guarded(df: pd.DataFrame, dots: bool = False) -> list[np.ndarray]:
    """Every value a figure plots against time, per row: the named columns, each bound
    column, and the minima over bound kinds the msb and operating-space figures draw
    (the largest value of a minimum is not always a kept row of its parts). With ``dots``
    the true values, which are drawn as dots (`_dots`), are left to those."""
    ends = ("_pred",) if dots else ("_pred", "_true")

    def plotted(c: str) -> bool:
        bound = (c.startswith("f") and "_msb_" in c) or c.startswith("bound_")
        return c in _GUARDED or (bound and c.endswith(ends))

    out = [as_floats(df[c]) for c in df.columns if plotted(str(c))]
    for which in ("pred",) if dots else ("pred", "true"):
        if all(f"bound_{k}_{which}" in df.columns for k in BOUND_KINDS):
            out.append(np.min([as_floats(df[f"bound_{k}_{which}"]) for k in BOUND_KINDS], axis=0))
    return out


def _dots(df: pd.DataFrame) -> list[tuple[np.ndarray, np.ndarray]]:
    """The values the figures draw as a dot per window, each with a group per row (dots of
    one group look alike): each bound kind's true value and their minimum (bounds, msb,
    operating space), and ``msb_min`` in the critical windows by binding kind (msb)."""
    out: list[tuple[np.ndarray, np.ndarray]] = []
    every = np.zeros(len(df), dtype=np.int64)
    true = [f"bound_{k}_true" for k in BOUND_KINDS if f"bound_{k}_true" in df.columns]
    out += [(as_floats(df[c]), every) for c in true]
    if len(true) == len(BOUND_KINDS):
        out.append((np.min([as_floats(df[c]) for c in true], axis=0), every))
    if {"msb_min", "critical", "binding"} <= set(df.columns):
        kind = pd.factorize(text_field(df["binding"]))[0] + 1
        out.append((as_floats(df["msb_min"]), np.where(as_bool(df["critical"]), kind, -1)))
    return out


def keep_extremes(
    df: pd.DataFrame,
    bins: np.ndarray,
    dot_cell: float | None = None,
    dot_top: float = np.inf,
    *,
    dot_rows: bool = True,
    events: int | None = None,
) -> np.ndarray:
    """Which rows to draw (a boolean mask) when rows are grouped by ``bins`` (one
    non-decreasing bin number per row): per bin its first and last row and, for every
    plotted value (`_guarded`), the rows of its smallest and largest value; both rows of
    every change of ``critical`` (so the shaded regions are exact) and every missed window
    (each is marked and counted). Drawn through these rows, each line covers in each bin
    the same range as through every row, so a bin no wider than a pixel column draws the
    same picture. With ``dot_cell`` (ms), of the values drawn as dots (`_dots`) up to
    ``dot_top`` (ms; no dot is drawn above the y axis) one row per bin and
    ``dot_cell``-high band of values is kept too, so the dots cover what every row's dots
    cover to within that band (``dot_rows`` False: those rows are left to a `DotSketch`,
    and the true values still left out of the lines' extremes). With ``events``, of the
    changes of ``critical`` and the misses only the first and last ``events`` of each bin
    are kept (a bin is under a pixel column wide: the shading of the changes between
    differs in that column only, by at most its alpha)."""
    m = len(df)
    keep = np.zeros(m, dtype=bool)
    if m == 0:
        return keep
    starts = np.flatnonzero(np.r_[True, bins[1:] != bins[:-1]])
    keep[starts] = True
    keep[np.r_[starts[1:], m] - 1] = True
    if "critical" in df.columns:
        f = as_bool(df["critical"])
        ch = np.flatnonzero(f[1:] != f[:-1])
        if events is not None:
            ch = ch[_ends_of_bins(bins[ch + 1], events)]
        keep[ch] = True
        keep[ch + 1] = True
    if "missed" in df.columns:
        missed = np.flatnonzero(as_bool(df["missed"]))
        if events is not None:
            missed = missed[_ends_of_bins(bins[missed], events)]
        keep[missed] = True
    dots = dot_cell is not None and dot_cell > 0
    for v in _guarded(df, dots):
        _keep_extremes_of(v, starts, keep)
    if dots and dot_rows:
        assert dot_cell is not None
        keep |= dot_rows_of(df, bins, dot_cell, dot_top)
    return keep


def _ends_of_bins(b: np.ndarray, k: int) -> np.ndarray:
    """Of items with non-decreasing bins ``b``, which are among the first or last ``k`` of
    their bin (a boolean mask)."""
    if not len(b):
        return np.zeros(0, dtype=bool)
    starts = np.flatnonzero(np.r_[True, b[1:] != b[:-1]])
    size = np.diff(np.r_[starts, len(b)])
    pos = np.arange(len(b)) - np.repeat(starts, size)
    return (pos < k) | (pos >= np.repeat(size, size) - k)


def dot_rows_of(df: pd.DataFrame, bins: np.ndarray, dot_cell: float, dot_top: float) -> np.ndarray:
    """The rows `keep_extremes` keeps for the dots: of the values drawn as dots (`_dots`) up
    to ``dot_top``, the first row of each bin, group and ``dot_cell``-high band."""
    keep = np.zeros(len(df), dtype=bool)
    for v, group in _dots(df):
        drawn = np.flatnonzero((v <= dot_top) & (group >= 0))
        key = np.column_stack(
            [bins[drawn], group[drawn], np.floor(v[drawn] / dot_cell).astype(np.int64)]
        )
        first = np.unique(key, axis=0, return_index=True)[1]
        keep[drawn[first]] = True
    return keep


def _keep_extremes_of(v: np.ndarray, starts: np.ndarray, keep: np.ndarray) -> None:
    """Mark in ``keep`` the first row of each bin (starting at ``starts``) holding the bin's
    smallest and its largest value of ``v``."""
    m = len(v)
    nan = np.isnan(v)
    for pos in (
        np.minimum.reduceat(np.where(nan, np.inf, v), starts),
        np.maximum.reduceat(np.where(nan, -np.inf, v), starts),
    ):
        hit = v == np.repeat(pos, np.diff(np.r_[starts, m]))
        keep[np.flatnonzero(hit & ~_seen_in_bin(hit, starts, m))] = True


def line_points(x: np.ndarray, ys: list[np.ndarray], bins: int | None = None) -> np.ndarray:
    """Which points of lines drawn over ``x`` (non-decreasing) to draw (a boolean mask): all
    of them when there are no more than ``bins`` (default `FIGURE_BINS`); else per bin of
    ``bins`` equal parts of x's span its first and last point and the smallest and largest
    value of each of ``ys``, and every NaN (a line's break). Drawn steps-post through these
    points a line covers in each bin the range it covers through all of them."""
    bins = FIGURE_BINS if bins is None else bins
    m = len(x)
    keep = np.ones(m, dtype=bool)
    span = float(x[-1] - x[0]) if m else 0.0
    if m <= bins or not np.isfinite(span) or span <= 0:
        return keep
    b = np.clip(np.floor((x - x[0]) * (bins / span)), 0, bins - 1).astype(np.int64)
    starts = np.flatnonzero(np.r_[True, b[1:] != b[:-1]])
    keep[:] = False
    keep[starts] = True
    keep[np.r_[starts[1:], m] - 1] = True
    for y in ys:
        keep |= np.isnan(y)
        _keep_extremes_of(y, starts, keep)
    return keep


#: The dots a figure draws, one per this fraction of the y axis's height and time bin
#: (`dot_points`): under a pixel of an axes 300 px high or more.
DOT_BAND = 1 / 1000


def dot_points(x: np.ndarray, y: np.ndarray, top: float, bins: int | None = None) -> np.ndarray:
    """Which of the dots at (``x``, ``y``) to draw (a boolean mask) on a y axis from 0 to
    ``top``: all when there are no more than ``bins`` (default `FIGURE_BINS`); else the
    first dot of each time bin and `DOT_BAND` × ``top`` band of values (a dot is
    several pixels wide; the ones dropped lie within a pixel of one kept)."""
    bins = FIGURE_BINS if bins is None else bins
    m = len(x)
    span = float(x[-1] - x[0]) if m else 0.0
    if m <= bins or not np.isfinite(span) or span <= 0 or not top > 0:
        return np.ones(m, dtype=bool)
    b = np.clip(np.floor((x - x[0]) * (bins / span)), 0, bins - 1).astype(np.int64)
    band = np.floor(np.nan_to_num(y, posinf=-1.0, neginf=-1.0) / (DOT_BAND * top))
    first = np.unique(np.column_stack([b, band.astype(np.int64)]), axis=0, return_index=True)[1]
    keep = np.zeros(m, dtype=bool)
    keep[first] = True
    return keep


def _seen_in_bin(hit: np.ndarray, starts: np.ndarray, m: int) -> np.ndarray:
    """Per row, whether an earlier row of its bin already has ``hit``."""
    c = np.cumsum(hit)
    before = np.repeat(np.r_[0, c[starts[1:] - 1]], np.diff(np.r_[starts, m]))
    return (c - hit) > before


def thin_rows(df: pd.DataFrame, bucket: int) -> np.ndarray:
    """`keep_extremes` over buckets of ``bucket`` consecutive windows."""
    return keep_extremes(df, np.arange(len(df)) // max(1, int(bucket)))


def reduce_chunk(chunk: pd.DataFrame) -> pd.DataFrame:
    """The figures' columns of a chunk of windows.csv with each follower's bound columns
    replaced by their minimum over followers, ``bound_<kind>_pred`` and
    ``bound_<kind>_true`` (what `figure_data` derives; `kind_min` takes them as they are):
    the table a figure needs no longer grows with the follower count."""
    out = chunk.loc[:, [c for c in chunk.columns if "_msb_" not in str(c)]].copy()
    for kind in BOUND_KINDS:
        for which in ("pred", "true"):
            out[f"bound_{kind}_{which}"] = kind_min(chunk, kind, which)
    return out


def read_figure_table(path: str | os.PathLike[str], n: int) -> pd.DataFrame:
    """The rows and columns the scenario figures draw, read back from a run's windows.csv
    in chunks of `FIGURE_READ_ROWS` rows: each chunk reduced (`reduce_chunk`), its rows
    grouped by `FIGURE_BINS` equal bins of the run's time span and thinned
    (`keep_extremes`, dots kept per `FIGURE_DOT_CELL` × w_sch band). The table stays
    within ``FIGURE_BINS`` × (2 + 2 × plotted values + the dot bands a bin's values span)
    rows (plus the critical changes and misses, each kept); a run with fewer windows than
    bins keeps every row. `read_figures` bounds it by a constant.

    The file is read three times: the time span and w_sch, then which rows each chunk
    keeps, then the kept rows copied into columns allocated once at their final length
    (`_KeptColumns`), so nothing long-lived is allocated between the chunks' parses."""
    return read_figures(path, n, max_rows=np.inf)[0]


def _position_columns(n: int) -> list[str]:
    cols = ["leader_x", "leader_y"]
    for i in range(1, n + 1):
        cols += [f"f{i}_x", f"f{i}_y", f"f{i}_x_est", f"f{i}_y_est"]
    return cols


def _dot_series(df: pd.DataFrame, top: float) -> Iterator[tuple[str, np.ndarray]]:
    """The dot series the figures draw, by name (`FigureSketch`), each as the rows drawing
    a dot (value ≤ ``top``): each bound kind's true value and their minimum, and
    ``msb_min`` in the critical windows binding by each kind."""
    true = {k: as_floats(df[f"bound_{k}_true"]) for k in BOUND_KINDS}
    for k, v in true.items():
        yield f"bound_{k}_true", v <= top
    yield "msb_min_true", np.min(list(true.values()), axis=0) <= top
    kinds = text_field(df["binding"])
    crit = as_bool(df["critical"]) & (as_floats(df["msb_min"]) <= top)
    for k in BOUND_KINDS:
        yield f"binding_{k}", crit & (kinds == k)


def _dot_values(df: pd.DataFrame, name: str) -> np.ndarray:
    if name == "msb_min_true":
        return np.min([as_floats(df[f"bound_{k}_true"]) for k in BOUND_KINDS], axis=0)
    return as_floats(df["msb_min" if name.startswith("binding_") else name])


class _Sketcher:
    """A `FigureSketch` built chunk by chunk (`read_figures`' third pass)."""

    def __init__(
        self, n: int, lo: tuple[float, float], hi: tuple[float, float], cell: float, top: float
    ) -> None:
        lines = Grid.over(lo, hi, FIGURE_PATH_CELLS)
        points = Grid.over(lo, hi, FIGURE_POINT_CELLS)
        self.n, self.top = n, top
        self.lines = {r: LineSketch(lines) for r in ["leader", *(f"f{i}" for i in range(1, n + 1))]}
        self.points = {
            r: PointSketch(points, FIGURE_POINTS_PER_CELL)
            for r in ["critical", *(f"f{i}_est" for i in range(1, n + 1))]
        }
        self.dots: dict[str, DotSketch] = {}
        self.cell = cell
        self.missed = 0

    def add(self, df: pd.DataFrame, bins: np.ndarray) -> None:
        for r, line in self.lines.items():
            x, y = ("leader_x", "leader_y") if r == "leader" else (f"{r}_x", f"{r}_y")
            line.add(as_floats(df[x]), as_floats(df[y]))
        for i in range(1, self.n + 1):
            self.points[f"f{i}_est"].add(as_floats(df[f"f{i}_x_est"]), as_floats(df[f"f{i}_y_est"]))
        crit = as_bool(df["critical"])
        bx, by = binding_xy(df)
        self.points["critical"].add(bx[crit], by[crit])
        self.missed += int(np.count_nonzero(as_bool(df["missed"])))
        if not self.cell:
            return
        t = as_floats(df["t"])
        for name, drawn in _dot_series(df, self.top):
            sk = self.dots.setdefault(
                name, DotSketch(self.cell * FIGURE_DOT_BANDS, FIGURE_DOT_BINS, FIGURE_DOTS_PER_CELL)
            )
            sk.add(bins[drawn], t[drawn], _dot_values(df, name)[drawn])

    def sketch(self) -> FigureSketch:
        return FigureSketch(
            lines={r: s.xy() for r, s in self.lines.items()},
            passes={r: s.passes() for r, s in self.lines.items()},
            points={r: s.xy() for r, s in self.points.items()},
            dots={r: s.tv() for r, s in self.dots.items()},
            counts={"missed": self.missed, **{r: s.count for r, s in self.dots.items()}},
        )


def read_figures(
    path: str | os.PathLike[str], n: int, max_rows: float | None = None
) -> tuple[pd.DataFrame, FigureSketch | None]:
    """The figures' table (`read_figure_table`) and None while it holds at most
    ``max_rows`` rows (default `FIGURE_ROWS`); above, the table of the rows the lines need
    (`keep_extremes` without the dots' rows: within ``FIGURE_BINS`` × (2 + 2 × plotted
    values) rows plus the critical changes and misses) and a `FigureSketch` of the paths
    and dots, built from every window (each of its parts bounded by its grid)."""
    t0 = end = None
    w_sch = 0.0
    lo, hi = np.full(2, np.inf), np.full(2, -np.inf)
    for chunk in iter_columns(
        path, ["t", "w", "w_sch", *_position_columns(n)], chunk_rows=FIGURE_READ_ROWS
    ):
        if len(chunk):
            t = as_floats(chunk["t"])
            w = as_floats(chunk["w"])[-1]
            t0 = t[0] if t0 is None else t0
            end = t[-1] + (w if np.isfinite(w) else 0.0)
            r = as_floats(chunk["w_sch"])
            r = r[np.isfinite(r)]
            w_sch = max(w_sch, float(r.max())) if r.size else w_sch
            for k, axis in enumerate("xy"):
                v = np.concatenate(
                    [
                        as_floats(chunk[c])
                        for c in chunk.columns
                        if c.endswith(f"_{axis}") or c.endswith(f"_{axis}_est")
                    ]
                )
                v = v[np.isfinite(v)]
                if v.size:
                    lo[k], hi[k] = min(lo[k], v.min()), max(hi[k], v.max())
    if t0 is None or end is None:
        return reduce_chunk(pd.DataFrame(columns=figure_columns(n))), None
    span = end - t0
    cell = FIGURE_DOT_CELL * w_sch if w_sch > 0 else None
    top = BOUNDS_CLIP * w_sch

    def chunks() -> Iterator[tuple[pd.DataFrame, np.ndarray, np.ndarray, np.ndarray]]:
        for chunk in iter_columns(path, figure_columns(n), chunk_rows=FIGURE_READ_ROWS):
            small = reduce_chunk(chunk)
            del chunk
            if span > 0:
                t = as_floats(small["t"])
                bins = np.clip((t - t0) * (FIGURE_BINS / span), 0, FIGURE_BINS)
                bins = np.floor(np.nan_to_num(bins)).astype(np.int64)
            else:
                bins = np.zeros(len(small), dtype=np.int64)
            lines = keep_extremes(small, bins, cell, top, dot_rows=False)
            dots = dot_rows_of(small, bins, cell, top) if cell else np.zeros_like(lines)
            few = keep_extremes(small, bins, cell, top, dot_rows=False, events=FIGURE_EVENTS)
            yield small, bins, few, lines | dots

    every, few = _KeptColumns(), _KeptColumns()
    for small, _, lines, keep in chunks():
        every.plan(small, keep)
        few.plan(small, lines)
    if every.rows <= (FIGURE_ROWS if max_rows is None else max_rows):
        for small, _, _, keep in chunks():
            every.fill(small, keep)
        return every.frame(), None
    del every
    sketcher = _Sketcher(n, (lo[0], lo[1]), (hi[0], hi[1]), cell or 0.0, top)
    for small, bins, lines, _ in chunks():
        few.fill(small, lines)
        sketcher.add(small, bins)
    return few.frame(), sketcher.sketch()


class _KeptColumns:
    """The kept rows of a table read in chunks, assembled column by column.

    `plan` (first pass) counts the kept rows and notes each column's dtype; `fill`
    (second pass, the same chunks again) copies each chunk's kept rows into numeric
    columns allocated once at their final length. Text columns (a few bytes a row in
    pandas' Arrow strings), and a numeric column parsed as different dtypes in different
    chunks, are kept as per-chunk parts and joined as `pandas.concat` joins a DataFrame's
    column. The result equals ``pd.concat([chunk[keep] for ...], ignore_index=True)``
    (tests/plots/test_figure_table.py) without holding the parts and their concatenation
    at once, or leaving kept parts between the chunks' freed parses (the allocator could
    not give those back: 6 h of Test 2 held ≈ 13 MB more)."""

    def __init__(self) -> None:
        self.rows = 0
        self.dtypes: dict[str, set[object]] = {}
        self.arrays: dict[str, np.ndarray] = {}
        self.parts: dict[str, list[pd.Series]] = {}
        self.at = 0

    def plan(self, chunk: pd.DataFrame, keep: np.ndarray) -> None:
        self.rows += int(np.count_nonzero(keep))
        for c in chunk.columns:
            self.dtypes.setdefault(str(c), set()).add(chunk[c].dtype)

    def _numeric(self, c: str) -> np.dtype | None:
        (dtype,) = self.dtypes[c] if len(self.dtypes[c]) == 1 else (None,)
        return dtype if isinstance(dtype, np.dtype) and dtype.kind in "fiub" else None

    def fill(self, chunk: pd.DataFrame, keep: np.ndarray) -> None:
        k = int(np.count_nonzero(keep))
        for c in chunk.columns:
            name = str(c)
            dtype = self._numeric(name)
            if dtype is None:
                self.parts.setdefault(name, []).append(chunk[c][keep])
                continue
            if name not in self.arrays:
                self.arrays[name] = np.empty(self.rows, dtype=dtype)
            self.arrays[name][self.at : self.at + k] = chunk[c].to_numpy()[keep]
        self.at += k

    def frame(self) -> pd.DataFrame:
        data: dict[str, np.ndarray | pd.Series] = {}
        for c in self.dtypes:
            if c in self.arrays:
                data[c] = self.arrays.pop(c)
            else:
                parts = [p.to_frame(c) for p in self.parts.pop(c, [])]
                data[c] = pd.concat(parts, ignore_index=True)[c]
        return pd.DataFrame(data, copy=False)


def figure_data(df: pd.DataFrame, name: str) -> pd.DataFrame:
    """The exact columns figure ``name`` plots, taken or derived from the windows table.

    Columns named as in ``windows.csv`` carry its values unchanged (times stay in ms; the
    figures divide by 1000). ``bound_<kind>_pred`` / ``bound_<kind>_true`` are the minimum
    over followers of ``f{i}_msb_<kind>_pred`` (the decision's prediction at the highest
    speed the leader had in the window) and ``f{i}_msb_<kind>_true`` (what the world showed);
    ``msb_min_pred`` / ``msb_min_true`` the minimum of those over the bound kinds (operating
    space). Infinite values stay ``inf``.
    """
    keys = ["window", "t"]
    if name == "paths":
        cols = keys + ["leader_x", "leader_y"]
        for i in followers(df):
            cols += [f"f{i}_x", f"f{i}_y", f"f{i}_x_est", f"f{i}_y_est"]
        cols.append("critical")
        if "binding" in df.columns:
            cols.append("binding")
    elif name == "window_slack":
        cols = keys + ["w", "slack", "w_sch", "missed", "critical"]
    elif name == "bounds":
        cols = keys + ["w", "w_sch", "critical"]
    elif name == "msb":
        cols = keys + ["w", "w_sch", "msb_min", "binding", "critical"]
    elif name == "speed":
        cols = keys + ["v_leader_desired", "v_leader", "v_leader_target", "segment"]
    elif name == "operating_space":
        cols = keys + ["w", "w_sch", "msb_min", "critical"]
    else:
        raise InputError(f"figure_data: unknown figure {name!r} (known: {', '.join(FIGURE_NAMES)})")
    need_columns(df, cols, f"the {name} figure")
    # the columns as they are (no copy: a long run's table is drawn six times over)
    out: dict[str, pd.Series | np.ndarray] = {c: df[c].reset_index(drop=True) for c in cols}
    if name == "msb":
        out["msb_min_true"] = np.min(
            np.column_stack([kind_min(df, kind, "true") for kind in BOUND_KINDS]), axis=1
        )
    if name in ("bounds", "operating_space"):
        for which in ("pred", "true"):
            mins = {kind: kind_min(df, kind, which) for kind in BOUND_KINDS}
            if name == "bounds":
                for kind in BOUND_KINDS:
                    out[f"bound_{kind}_{which}"] = mins[kind]
            else:
                out[f"msb_min_{which}"] = np.min(np.column_stack(list(mins.values())), axis=1)
    return pd.DataFrame(out, copy=False)


# --- drawing helpers ---------------------------------------------------------------------


def binding_xy(df: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """Per window, the true position of the follower whose bound binds (``binding`` =
    ``kind:i``); the leader's where no follower binds or the table has no ``binding``."""
    x, y = as_floats(df["leader_x"]).copy(), as_floats(df["leader_y"]).copy()
    if "binding" not in df.columns:
        return x, y
    who = text_field(df["binding"], last=True)
    num = np.asarray(pd.to_numeric(who, errors="coerce"), dtype=float)
    for i in followers(df):
        sel = num == i
        if sel.any():
            x[sel] = as_floats(df[f"f{i}_x"])[sel]
            y[sel] = as_floats(df[f"f{i}_y"])[sel]
    return x, y
