"""Figures of one scenario run, drawn from its ``windows.csv`` table (schema: docs/outputs.md).

The paper's Figures 8-15 (paths, processing window and slack, effective bounds, leader speed),
the operating space of its Figure 2 (w_sch ≤ w ≤ min MSB, critical region where min MSB < w_sch)
and side-by-side comparisons of the three modes. Every function takes the windows DataFrame
and returns a `matplotlib.figure.Figure` built without pyplot;
[`figure_data`][rtsim.plots.scenario.figure_data]
returns the exact columns each figure plots, so a figure can be redrawn from CSV.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib import patches as mpatches
from matplotlib.axes import Axes
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.path import Path as MplPath
from matplotlib.patheffects import AbstractPathEffect

from rtsim.errors import InputError
from rtsim.io.atomic import atomic_path, write_table
from rtsim.plots.figure import new_figure
from rtsim.plots.scenario_data import (
    BOUND_KINDS,
    BOUNDS_CLIP,
    WINDOW_CLIP,
    as_bool,
    as_floats,
    binding_xy,
    critical_spans,
    dot_points,
    ends_s,
    figure_data,
    followers,
    headline_counts,
    line_points,
    need_columns,
    spans_of,
    text_field,
    times_s,
    violation_ratios,
)
from rtsim.plots.sketch import FigureSketch
from rtsim.plots.style import COLUMN_IN, PAGE_IN, few, paper
from rtsim.plots.style import DPI as _PRINT_DPI

__all__ = [
    "BOUND_KINDS",
    "COLORS",
    "SCENARIO_FIGURES",
    "critical_spans",
    "figure_data",
    "binding_xy",
    "followers",
    "plot_bounds",
    "plot_modes",
    "plot_msb",
    "plot_operating_space",
    "plot_paths",
    "plot_speed",
    "plot_window_slack",
    "save_figure",
    "violation_ratios",
    "write_scenario_figures",
]

COLORS: dict[str, str] = {
    "w_sch": "#000000",
    "w": "#0072B2",
    "slack": "#8C8C8C",
    "msb_min": "#D55E00",
    "localization": "#56B4E9",
    "separation": "#E69F00",
    "path_diversion": "#009E73",
    "bearing": "#CC79A7",
    "leader": "#000000",
    "v_desired": "#000000",
    "v_actual": "#0072B2",
    "critical": "#D55E00",
    "safe": "#009E73",
    "turn": "#7F7F7F",
    "miss": "#D55E00",
}
FOLLOWER_COLORS: tuple[str, ...] = (
    "#0072B2",
    "#E69F00",
    "#009E73",
    "#CC79A7",
    "#56B4E9",
    "#D55E00",
    "#F0E442",
)
#: Resolution of PNG figures: print (`rtsim.plots.style.DPI`); SVG and PDF are vector.
DPI = _PRINT_DPI
#: What the lines and dots of the bounds figures are (their legend's title).
BOUNDS_NOTE = (
    "lines: predicted at the leader's highest speed in the window; dots: threshold·w / true change"
)


def _new_figure(ax: Axes | None, size: tuple[float, float]) -> tuple[Figure, Axes, bool]:
    if ax is not None:
        return ax.figure, ax, False  # type: ignore[return-value]
    fig = new_figure(figsize=size, layout="constrained")
    return fig, fig.add_subplot(), True


def _finish(
    fig: Figure,
    ax: Axes,
    own: bool,
    title: str | None,
    legend: bool = True,
    note: str | None = None,
) -> Figure:
    """Title the figure; its legend below the axes, off the data (``note``: the legend's
    title, what its entries mean). In an axes given by the caller the legend goes where
    matplotlib finds room."""
    if title and own:
        fig.suptitle(title)
    elif title:
        ax.set_title(title, loc="left")
    if legend:
        handles, labels = few(*ax.get_legend_handles_labels())
        if handles and own:
            fig.legend(
                handles,
                labels,
                loc="outside lower center",
                ncols=min(len(handles), 3 if fig.get_figwidth() > COLUMN_IN + 0.5 else 1),
                fontsize="small",
                frameon=False,
                title=note,
                title_fontsize="small",
            )
        elif handles:
            ax.legend(handles, labels, fontsize="small")
    return fig


def _held(df: pd.DataFrame, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Window starts plus the last window's end, and ``y`` with its last value repeated.

    A per-window value holds from the window's start to its end; drawn as steps-post over
    these points, the last window gets its full width too (and a one-row table a segment).
    """
    t = times_s(df)
    if len(t) == 0:
        return t, y
    return np.append(t, ends_s(df)[-1]), np.append(y, y[-1])


#: Vertical travel, in pixels within the axes, of the longest piece a step line is
#: rasterized in as a PNG (`_Pieces`). Agg holds a cell per pixel a line's outline crosses
#: until the whole line is drawn, about 45 bytes per pixel of travel: a line drawn through
#: every bin's extremes (`line_points`) travels up and down each pixel column, 150,000 px
#: for 1 h of Test 2, 660,000 px (≈ 30 MB of cells) for 6 h.
AGG_LINE_TRAVEL = 200_000
#: The same for a sketched (long) run's figures, translucent lines too (`_line_pieces`):
#: its lines travel further (each pixel column's range of more windows), and Agg's cells
#: for one 200,000 px line were most of what its figures took beyond an hour's.
SKETCH_LINE_TRAVEL = 50_000
_TRAVEL: ContextVar[tuple[int | None, bool]] = ContextVar("_TRAVEL", default=(None, False))


@contextmanager
def _line_pieces(sketch: FigureSketch | None) -> Iterator[None]:
    """Within: the solid lines `_step` draws are rasterized in pieces of
    `SKETCH_LINE_TRAVEL`, translucent ones too, if ``sketch`` is given (a long run; where
    two pieces of a translucent line join, its colour is laid twice over a few pixels:
    under half the scale at alpha 0.3), else as `AGG_LINE_TRAVEL` says."""
    token = _TRAVEL.set((SKETCH_LINE_TRAVEL, True) if sketch is not None else _TRAVEL.get())
    try:
        yield
    finally:
        _TRAVEL.reset(token)


class _Pieces(AbstractPathEffect):
    """Rasterize an opaque line whose vertical travel within the axes exceeds
    `AGG_LINE_TRAVEL` as consecutive pieces of at most that travel, each ending at the next
    one's first vertex (Agg's cells stay bounded; the pixels where two pieces join may
    differ in their antialiasing, and a dash pattern starts again at each piece). A
    shorter line, a translucent one (its pieces would blend twice where they join) or a
    vector format is drawn as it is, in one call: its image is the one drawn without this
    effect. ``travel`` replaces `AGG_LINE_TRAVEL` for a solid line (a dashed one keeps it:
    each piece starts its pattern again); with ``translucent`` a translucent line is cut
    too (`_line_pieces`). With ``passes`` each piece is drawn that many times over itself:
    a path a long run retraced lap after lap, drawn once from its sketch
    (`rtsim.plots.sketch.LineSketch`), gets the edges its laps' opaque antialiased strokes
    piled up to (each pass composites the edge pixels' coverage again)."""

    def __init__(
        self, travel: int | None = None, translucent: bool = False, passes: int = 1
    ) -> None:
        super().__init__()
        self.travel = travel
        self.translucent = translucent
        self.passes = passes

    def _draw(self, renderer: Any, gc: Any, path: MplPath, affine: Any, face: Any) -> None:
        for _ in range(self.passes):
            renderer.draw_path(gc, path, affine, face)

    def draw_path(
        self,
        renderer: Any,
        gc: Any,
        tpath: MplPath,
        affine: Any,
        rgbFace: Any = None,  # noqa: N803 - matplotlib's name
    ) -> None:
        from matplotlib.backends.backend_agg import RendererAgg

        dashed = gc.get_dashes()[1] is not None  # each piece starts its pattern again
        limit = AGG_LINE_TRAVEL if self.travel is None or dashed else self.travel
        v = np.asarray(tpath.vertices)
        alpha = gc.get_alpha() if gc.get_forced_alpha() else gc.get_rgb()[3]
        if (
            not isinstance(renderer, RendererAgg)
            or tpath.codes is not None
            or len(v) < 3
            or (alpha < 1.0 and not self.translucent)  # its pieces blend twice where they join
        ):
            self._draw(renderer, gc, tpath, affine, rgbFace)
            return
        y = affine.transform(v)[:, 1]
        box = gc.get_clip_rectangle()
        if box is not None:
            y = np.clip(y, box.y0, box.y1)
        dy = np.abs(np.diff(y))
        travel = np.r_[0.0, np.cumsum(np.where(np.isfinite(dy), dy, 0.0))]
        if travel[-1] <= limit:
            self._draw(renderer, gc, tpath, affine, rgbFace)
            return
        piece = np.floor(travel / limit)
        starts = np.flatnonzero(np.r_[True, piece[1:] != piece[:-1]])
        for a, b in zip(starts, np.r_[starts[1:], len(v) - 1], strict=True):
            if b > a:
                p = MplPath(v[a : b + 1])
                p.should_simplify = tpath.should_simplify
                p.simplify_threshold = tpath.simplify_threshold
                self._draw(renderer, gc, p, affine, rgbFace)


#: Most times a sketched path is drawn over itself (`_sketched_line`).
RETRACE_PASSES = 16


def _sketched_line(ax: Axes, sketch: FigureSketch, name: str, **kw: Any) -> None:
    """A path of the ``sketch`` drawn as often over itself as it was traced (at most
    `RETRACE_PASSES`; `_Pieces`)."""
    (line,) = ax.plot(*sketch.lines[name], **kw)
    k = int(min(RETRACE_PASSES, max(1, round(sketch.passes.get(name, 1.0)))))
    if k > 1:
        line.set_path_effects([_Pieces(passes=k)])


def _step(ax: Axes, df: pd.DataFrame, y: np.ndarray, **kw: object) -> Line2D:
    """``y`` held over each window (`_held`), through the points `line_points` keeps;
    rasterized in pieces when long (`_Pieces`)."""
    x, yy = _held(df, y)
    keep = line_points(x, [yy])
    (line,) = ax.plot(x[keep], yy[keep], drawstyle="steps-post", **kw)  # type: ignore[arg-type]
    line.set_path_effects([_Pieces(*_TRAVEL.get())])
    return line


#: Points of a band a sketched run's figure fills at a time (`_fill`).
SKETCH_FILL_POINTS = 2048


def _fill(ax: Axes, x: np.ndarray, lo: np.ndarray, hi: np.ndarray, **kw: Any) -> None:
    """A steps-post band from ``lo`` to ``hi`` through the points `line_points` keeps;
    within `_line_pieces` of a sketched run, in consecutive pieces of `SKETCH_FILL_POINTS`
    points (each ends where the next begins: Agg's cells for a long band's outline were
    4.4 MB of the operating-space figure at 6 hours; the pixel column of each joint is
    laid twice, by under half the scale at alpha 0.25)."""
    keep = line_points(x, [lo, hi])
    if not _TRAVEL.get()[1] or keep.sum() <= SKETCH_FILL_POINTS:
        ax.fill_between(x[keep], lo[keep], hi[keep], step="post", **kw)
        return
    x, lo, hi = x[keep], lo[keep], hi[keep]
    for a in range(0, len(x) - 1, SKETCH_FILL_POINTS):
        b = min(a + SKETCH_FILL_POINTS, len(x) - 1) + 1
        ax.fill_between(x[a:b], lo[a:b], hi[a:b], step="post", **kw)
        kw.pop("label", None)


def _dots(ax: Axes, t: np.ndarray, y: np.ndarray, top: float, fmt: str, **kw: Any) -> Line2D:
    """Dots at (``t``, ``y``) on a y axis up to ``top``, those `dot_points` keeps."""
    keep = dot_points(t, y, top)
    (line,) = ax.plot(t[keep], y[keep], fmt, **kw)
    return line


def _dot_data(
    df: pd.DataFrame, sketch: FigureSketch | None, name: str, values: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """A dot series' times (s) and ``values``: the table's rows, or the ``sketch``'s dots
    of series ``name`` (`FigureSketch`)."""
    if sketch is None:
        return times_s(df), values
    t, v = sketch.dots.get(name, (np.zeros(0), np.zeros(0)))
    return t / 1000.0, v


def _ylimit(values: list[np.ndarray], w_sch: np.ndarray, factor: float) -> float:
    """Top of the y-axis (ms): a little above the finite data, at most ``factor`` × w_sch."""
    finite = np.concatenate([v[np.isfinite(v)] for v in values] + [np.zeros(1)])
    top = float(finite.max()) * 1.08
    ref = w_sch[np.isfinite(w_sch) & (w_sch > 0)]
    if ref.size:
        r = float(ref.max())
        top = min(max(top, 1.5 * r), factor * r)
    return top if top > 0 else 1.0


def _offscale(y: np.ndarray, top: float) -> np.ndarray:
    """Values to draw: +inf becomes a point above the axes, so the line leaves at the top."""
    return np.where(np.isposinf(y), 2.0 * top, y)


def _note_clip(ax: Axes, values: list[np.ndarray], top: float) -> None:
    if any(np.any(v > top) for v in values):
        ax.set_title(
            f"off-scale above {top:.0f} ms (∞ = unbounded)",
            loc="right",
            fontsize="small",
            color="#555555",
        )


def _shade(ax: Axes, spans: list[tuple[float, float]], kind: str, label: str) -> None:
    """Shade each (start, end) span over the axes' height: the first as an ``axvspan``
    (it carries the legend entry), the others as one `PolyCollection` of the same
    rectangles, drawn right after it with the same colour, alpha, edge and snapping, so
    the image is the one a patch per span drew (pixel-identical, tests/plots/
    test_figure_table.py) while a 6 h run's 700–1,400 spans per figure are one artist, not
    one patch (≈ 5 KB of transforms each) per span."""
    if not spans:
        return
    (a, b), rest = spans[0], spans[1:]
    ax.axvspan(a, b, color=COLORS[kind], alpha=0.15, lw=0, gid=kind, label=label)
    if rest:
        # the path axvspan's Rectangle draws: the unit square scaled by the span's width
        verts = [
            [(x0, 0.0), (x0 + (x1 - x0), 0.0), (x0 + (x1 - x0), 1.0), (x0, 1.0)] for x0, x1 in rest
        ]
        ax.add_collection(
            PolyCollection(
                verts,
                closed=True,
                color=COLORS[kind],
                alpha=0.15,
                lw=0,
                gid=kind,
                transform=ax.get_xaxis_transform(),
                zorder=mpatches.Patch.zorder,
            ),
            autolim=False,
        )


def _time_axes(ax: Axes, df: pd.DataFrame, ylabel: str) -> None:
    ax.set_xlabel("time t (s)")
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    if len(df):
        t, ends = times_s(df), ends_s(df)
        if ends[-1] > t[0]:
            ax.set_xlim(t[0], ends[-1])
    else:
        ax.text(0.5, 0.5, "no windows", transform=ax.transAxes, ha="center", va="center")


def _wsch_line(ax: Axes, df: pd.DataFrame) -> None:
    _step(ax, df, as_floats(df["w_sch"]), color=COLORS["w_sch"], ls="--", lw=1.2, label="$w_{sch}$")


# --- drawers (one axes each; shared by the single figures and plot_modes) ---------------


def _draw_paths(
    ax: Axes, df: pd.DataFrame, top: float | None = None, sketch: FigureSketch | None = None
) -> None:
    """The paths; with a ``sketch`` (a long run) its lines and scatters instead of every
    row's positions."""
    figure_data(df, "paths")  # validates the columns
    lx, ly = as_floats(df["leader_x"]), as_floats(df["leader_y"])
    if sketch is None:
        crit = as_bool(df["critical"])
        bx, by = binding_xy(df)
        cx, cy = bx[crit], by[crit]
    else:
        cx, cy = sketch.points["critical"]
    where = "at the binding follower" if "binding" in df.columns else "on leader path"
    ax.scatter(
        cx,
        cy,
        s=30,
        color=COLORS["critical"],
        alpha=0.5,
        lw=0,
        gid="critical",
        label=f"critical windows ({where})",
        zorder=1,
    )
    leader: dict[str, Any] = {"color": COLORS["leader"], "lw": 1.4, "label": "leader", "zorder": 3}
    if sketch is None:
        ax.plot(lx, ly, **leader)
    else:
        _sketched_line(ax, sketch, "leader", **leader)
    for k, i in enumerate(followers(df)):
        c = FOLLOWER_COLORS[k % len(FOLLOWER_COLORS)]
        line: dict[str, Any] = {"color": c, "lw": 1.2, "label": f"follower {i}", "zorder": 3}
        if sketch is None:
            ax.plot(as_floats(df[f"f{i}_x"]), as_floats(df[f"f{i}_y"]), **line)
        else:
            _sketched_line(ax, sketch, f"f{i}", **line)
        ax.scatter(
            *(
                (as_floats(df[f"f{i}_x_est"]), as_floats(df[f"f{i}_y_est"]))
                if sketch is None
                else sketch.points[f"f{i}_est"]
            ),
            s=6,
            color=c,
            alpha=0.3,
            lw=0,
            gid="estimate",
            zorder=2,
            label="estimated follower positions" if k == 0 else None,
        )
        if len(df):
            ax.plot(
                as_floats(df[f"f{i}_x"])[0],
                as_floats(df[f"f{i}_y"])[0],
                "o",
                color=c,
                mec="white",
                ms=7,
                zorder=4,
                gid="start",
            )
    if len(df):
        ax.plot(
            lx[0],
            ly[0],
            "o",
            color=COLORS["leader"],
            mec="white",
            ms=7,
            zorder=4,
            gid="start",
            label="start",
        )
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (cm)")
    ax.set_ylabel("y (cm)")
    ax.grid(True, alpha=0.3)


def _draw_window(
    ax: Axes, df: pd.DataFrame, top: float | None = None, sketch: FigureSketch | None = None
) -> None:
    figure_data(df, "window_slack")
    t, w, slack = times_s(df), as_floats(df["w"]), as_floats(df["slack"])
    top = top if top is not None else _ylimit([w, slack], as_floats(df["w_sch"]), WINDOW_CLIP)
    _shade(ax, critical_spans(df), "critical", "critical (min MSB < $w_{sch}$)")
    x, hi = _held(df, _offscale(slack, top))
    _fill(ax, x, np.zeros_like(hi), hi, color=COLORS["slack"], alpha=0.25, lw=0)
    _step(
        ax,
        df,
        _offscale(slack, top),
        color=COLORS["slack"],
        lw=1.0,
        label="slack $t_{slack}$ = max(0, w − $w_{sch}$)",
    )
    _step(ax, df, _offscale(w, top), color=COLORS["w"], lw=1.5, label="processing window w")
    _wsch_line(ax, df)
    missed = as_bool(df["missed"])
    count = int(missed.sum()) if sketch is None else sketch.counts.get("missed", 0)
    if missed.any():
        ax.plot(
            t[missed],
            np.minimum(w[missed], top),
            "x",
            color=COLORS["miss"],
            ms=7,
            mew=1.8,
            gid="miss",
            label=f"deadline miss ({count})",
        )
    ax.set_ylim(0, top)
    _note_clip(ax, [w, slack], top)
    _time_axes(ax, df, "time (ms)")


def _bounds_top(df: pd.DataFrame) -> float:
    data = figure_data(df, "bounds")
    values = [as_floats(data[f"bound_{k}_pred"]) for k in BOUND_KINDS] + [as_floats(data["w"])]
    return _ylimit(values, as_floats(data["w_sch"]), BOUNDS_CLIP)


def _draw_bounds(
    ax: Axes, df: pd.DataFrame, top: float | None = None, sketch: FigureSketch | None = None
) -> None:
    data = figure_data(df, "bounds")
    top = top if top is not None else _bounds_top(df)
    _shade(ax, critical_spans(df), "critical", "critical (min MSB < $w_{sch}$)")
    values = []
    for kind in BOUND_KINDS:
        y = as_floats(data[f"bound_{kind}_pred"])
        values.append(y)
        _step(
            ax,
            df,
            _offscale(y, top),
            color=COLORS[kind],
            lw=1.3,
            gid=f"pred_{kind}",
            label=f"{kind.replace('_', ' ')} MSB predicted",
        )
        yt = as_floats(data[f"bound_{kind}_true"])
        values.append(yt)
        dt, dv = _dot_data(df, sketch, f"bound_{kind}_true", yt)
        shown = dv <= top
        _dots(
            ax,
            dt[shown],
            dv[shown],
            top,
            ".",
            color=COLORS[kind],
            ms=2.5,
            alpha=0.6,
            gid=f"true_{kind}",
            label=f"{kind.replace('_', ' ')} MSB true",
        )
    w = as_floats(data["w"])
    _step(
        ax,
        df,
        _offscale(w, top),
        color=COLORS["w"],
        lw=4.0,
        alpha=0.3,
        zorder=1.8,
        label="processing window w",
    )
    _wsch_line(ax, df)
    ax.set_ylim(0, top)
    _note_clip(ax, values + [w], top)
    _time_axes(ax, df, "bound on w (ms), min over followers")


def _draw_msb(
    ax: Axes, df: pd.DataFrame, top: float | None = None, sketch: FigureSketch | None = None
) -> None:
    data = figure_data(df, "msb")
    w_sch = as_floats(data["w_sch"])
    pred, true = as_floats(data["msb_min"]), as_floats(data["msb_min_true"])
    w = as_floats(data["w"])
    top = top if top is not None else _ylimit([pred, w], w_sch, BOUNDS_CLIP)
    _shade(ax, critical_spans(df), "critical", "critical (min MSB < $w_{sch}$)")
    _step(
        ax,
        df,
        _offscale(pred, top),
        color=COLORS["msb_min"],
        lw=1.5,
        gid="msb_pred",
        label="min MSB at $V_{Ld}$, predicted",
    )
    dt, dv = _dot_data(df, sketch, "msb_min_true", true)
    shown = dv <= top
    _dots(
        ax,
        dt[shown],
        dv[shown],
        top,
        ".",
        color=COLORS["msb_min"],
        ms=2.5,
        alpha=0.5,
        gid="msb_true",
        label="min MSB, true (threshold·w / change, at the speed driven)",
    )
    _step(
        ax,
        df,
        _offscale(w, top),
        color=COLORS["w"],
        lw=4.0,
        alpha=0.3,
        zorder=1.8,
        label="processing window w",
    )
    _wsch_line(ax, df)
    crit = as_bool(df["critical"])
    kinds = text_field(data["binding"])
    for kind in BOUND_KINDS:
        sel = crit & (kinds == kind) & (pred <= top)
        dt, dv = _dot_data(df, sketch, f"binding_{kind}", pred)
        if sketch is None:
            dt, dv, count = dt[sel], dv[sel], int(sel.sum())
        else:
            sel = dv <= top
            dt, dv, count = dt[sel], dv[sel], sketch.counts.get(f"binding_{kind}", 0)
        if count:
            _dots(
                ax,
                dt,
                dv,
                top,
                "o",
                ms=3.5,
                color=COLORS[kind],
                mec="none",
                gid=f"binding_{kind}",
                label=f"binding: {kind.replace('_', ' ')} ({count})",
            )
    ax.set_ylim(0, top)
    _note_clip(ax, [pred, w], top)
    _time_axes(ax, df, "min MSB (ms)")


def _draw_speed(ax: Axes, df: pd.DataFrame, top: float | None = None) -> None:
    figure_data(df, "speed")
    turn = (df["segment"].astype(str).str.strip() == "turn").to_numpy()
    _shade(ax, spans_of(df, turn), "turn", "turn")
    v_d, v = as_floats(df["v_leader_desired"]), as_floats(df["v_leader"])
    _step(ax, df, v, color=COLORS["v_actual"], lw=1.5, label="actual $V_L$ (at t)")
    _step(
        ax,
        df,
        as_floats(df["v_leader_target"]),
        color=COLORS["v_actual"],
        ls=":",
        lw=1.0,
        gid="target",
        label="target (the decision's)",
    )
    _step(
        ax, df, v_d, color=COLORS["v_desired"], ls="--", lw=1.2, zorder=3, label="desired $V_{Ld}$"
    )
    ax.set_ylim(0, top if top is not None else _ylimit([v_d, v], np.zeros(0), 1.0))
    _time_axes(ax, df, "leader speed (cm/s)")


def _draw_operating(
    ax: Axes, df: pd.DataFrame, top: float | None = None, sketch: FigureSketch | None = None
) -> None:
    data = figure_data(df, "operating_space")
    w_sch = as_floats(data["w_sch"])
    msb, w = as_floats(data["msb_min"]), as_floats(data["w"])
    top = top if top is not None else _ylimit([msb, w], w_sch, BOUNDS_CLIP)
    spans = critical_spans(df)
    _shade(ax, spans, "critical", "critical (min MSB < $w_{sch}$)")
    safe = msb >= w_sch
    x, lo = _held(df, w_sch)  # zero height where critical, so runs keep their full width
    _fill(
        ax,
        x,
        lo,
        _held(df, np.where(safe, np.minimum(msb, top), w_sch))[1],
        color=COLORS["safe"],
        alpha=0.18,
        lw=0,
        gid="safe",
        label="safe operating area ($w_{sch}$ ≤ w ≤ min MSB)",
    )
    _step(
        ax,
        df,
        _offscale(w, top),
        color=COLORS["w"],
        lw=4.0,
        alpha=0.3,
        zorder=1.8,
        label="processing window w",
    )
    _step(
        ax,
        df,
        _offscale(msb, top),
        color=COLORS["msb_min"],
        lw=1.5,
        label="min MSB at $V_{Ld}$ (the decision's)",
    )
    pred, true = as_floats(data["msb_min_pred"]), as_floats(data["msb_min_true"])
    _step(
        ax,
        df,
        _offscale(pred, top),
        color=COLORS["msb_min"],
        lw=1.0,
        ls=":",
        gid="pred_min",
        label="min MSB predicted at the leader's speed",
    )
    dt, dv = _dot_data(df, sketch, "msb_min_true", true)
    shown = dv <= top
    _dots(
        ax,
        dt[shown],
        dv[shown],
        top,
        ".",
        color="#333333",
        ms=2.5,
        alpha=0.6,
        gid="true_min",
        label="min MSB true (threshold·w / change)",
    )
    _wsch_line(ax, df)
    _label_runs(ax, df, safe, w_sch, np.minimum(msb, top), "safe operating area", top)
    _label_runs(ax, df, ~safe, np.zeros_like(w_sch), w_sch, "critical", top)
    ax.set_ylim(0, top)
    _note_clip(ax, [msb, w, pred, true], top)
    _time_axes(ax, df, "processing window (ms)")


def _label_runs(
    ax: Axes,
    df: pd.DataFrame,
    mask: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    text: str,
    top: float,
) -> None:
    """Write ``text`` in the middle of the longest run of ``mask`` (if wide enough); above
    the band instead when it is thinner than 10% of the axis height ``top``."""
    spans = spans_of(df, mask)
    if not spans or len(df) < 2:
        return
    a, b = max(spans, key=lambda s: s[1] - s[0])
    total = ends_s(df)[-1] - times_s(df)[0]
    if total <= 0 or (b - a) < 0.12 * total:
        return
    inside = (times_s(df) >= a) & (times_s(df) < b)
    y, va = float(np.nanmedian((lo[inside] + hi[inside]) / 2)), "center"
    if float(np.nanmedian(hi[inside] - lo[inside])) < 0.1 * top:
        y, va = float(np.nanmax(hi[inside])) + 0.02 * top, "bottom"
    ax.text(
        (a + b) / 2, y, text, ha="center", va=va, fontsize="small", style="italic", color="#333333"
    )


def _draw_plane(ax: Axes, df: pd.DataFrame, top: float) -> None:
    """The (w_sch, min MSB) plane: points below the diagonal are critical."""
    w_sch, msb = as_floats(df["w_sch"]), as_floats(df["msb_min"])
    ax.fill_between([0, top], [0, top], 0, color=COLORS["critical"], alpha=0.15, lw=0)
    ax.fill_between([0, top], [0, top], top, color=COLORS["safe"], alpha=0.12, lw=0)
    ax.plot([0, top], [0, top], color="#333333", lw=1.0, label="min MSB = $w_{sch}$")
    crit = msb < w_sch
    y = np.minimum(msb, top * 0.98)
    ax.scatter(w_sch[~crit], y[~crit], s=8, color=COLORS["w"], alpha=0.5, lw=0)
    ax.scatter(w_sch[crit], y[crit], s=8, color=COLORS["critical"], alpha=0.7, lw=0, gid="critical")
    ax.text(0.95 * top, 0.08 * top, "critical", ha="right", fontsize="small", style="italic")
    ax.text(0.05 * top, 0.92 * top, "safe", ha="left", va="top", fontsize="small", style="italic")
    ax.set_xlim(0, top)
    ax.set_ylim(0, top)
    ax.set_aspect("equal")
    ax.set_xlabel("$w_{sch}$ (ms)")
    ax.set_ylabel("min MSB (ms)")
    ax.grid(True, alpha=0.3)


# --- public figures ----------------------------------------------------------------------


@paper
def plot_paths(
    df: pd.DataFrame,
    *,
    title: str | None = None,
    ax: Axes | None = None,
    sketch: FigureSketch | None = None,
) -> Figure:
    """Figs 8/12: the leader's and followers' true paths, estimates faint, critical windows
    drawn where the binding follower was (`binding_xy`); from a long run's ``sketch``
    (`rtsim.plots.scenario_data.read_figures`) if given."""
    fig, ax, own = _new_figure(ax, (COLUMN_IN, COLUMN_IN + 1.6))
    _draw_paths(ax, df, sketch=sketch)
    return _finish(fig, ax, own, title)


@paper
def plot_window_slack(
    df: pd.DataFrame,
    *,
    title: str | None = None,
    ax: Axes | None = None,
    sketch: FigureSketch | None = None,
) -> Figure:
    """Figs 9/13: the processing window w and the slack (Eq 22) over time, w_sch for reference
    (``sketch``: a long run's, for its count of misses)."""
    fig, ax, own = _new_figure(ax, (PAGE_IN, 2.8))
    with _line_pieces(sketch):
        _draw_window(ax, df, sketch=sketch)
    return _finish(fig, ax, own, title)


@paper
def plot_bounds(
    df: pd.DataFrame,
    *,
    title: str | None = None,
    ax: Axes | None = None,
    sketch: FigureSketch | None = None,
) -> Figure:
    """The per-kind detail of Figs 10/14 (`plot_msb` is the paper's picture): w_sch,
    each MSB kind (min over followers, estimates) and w over time; the dots from a long
    run's ``sketch`` if given."""
    fig, ax, own = _new_figure(ax, (PAGE_IN, 3.2))
    with _line_pieces(sketch):
        _draw_bounds(ax, df, sketch=sketch)
    return _finish(fig, ax, own, title, note=BOUNDS_NOTE)


@paper
def plot_msb(
    df: pd.DataFrame,
    *,
    title: str | None = None,
    ax: Axes | None = None,
    sketch: FigureSketch | None = None,
) -> Figure:
    """Figs 10/14 as the paper draws them: the minimum MSB over every follower and bound,
    predicted at the desired speed V_Ld (the decision's ``msb_min``) and as the truth showed
    it, against w_sch and w; in the critical windows a marker coloured by the binding bound.
    The per-kind detail is [`plot_bounds`][rtsim.plots.scenario.plot_bounds]. The dots from
    a long run's ``sketch`` if given."""
    fig, ax, own = _new_figure(ax, (PAGE_IN, 2.8))
    with _line_pieces(sketch):
        _draw_msb(ax, df, sketch=sketch)
    return _finish(fig, ax, own, title)


@paper
def plot_speed(
    df: pd.DataFrame,
    *,
    title: str | None = None,
    ax: Axes | None = None,
    sketch: FigureSketch | None = None,
) -> Figure:
    """Figs 11/15: the desired and actual leader speed over time, turns shaded (``sketch``:
    not needed, taken for a uniform call)."""
    fig, ax, own = _new_figure(ax, (PAGE_IN, 2.5))
    with _line_pieces(sketch):
        _draw_speed(ax, df)
    return _finish(fig, ax, own, title)


@paper
def plot_operating_space(
    df: pd.DataFrame,
    *,
    title: str | None = None,
    ax: Axes | None = None,
    plane: bool = True,
    sketch: FigureSketch | None = None,
) -> Figure:
    """Fig 2's operating space over time: w_sch ≤ w ≤ min MSB, the critical region shaded.

    With ``plane`` (and no ``ax`` given) a second panel shows the (w_sch, min MSB) plane with
    the diagonal min MSB = w_sch that separates the safe area from the critical region.
    The dots from a long run's ``sketch`` if given.
    """
    if ax is not None or not plane:
        fig, ax, own = _new_figure(ax, (PAGE_IN, 2.8))
        with _line_pieces(sketch):
            _draw_operating(ax, df, sketch=sketch)
        return _finish(fig, ax, own, title)
    fig = new_figure(figsize=(PAGE_IN, 2.8), layout="constrained")
    ax_t, ax_p = fig.subplots(1, 2, width_ratios=[3, 1.1])
    data = figure_data(df, "operating_space")
    top = _ylimit(
        [as_floats(data["msb_min"]), as_floats(data["w"])], as_floats(data["w_sch"]), BOUNDS_CLIP
    )
    with _line_pieces(sketch):
        _draw_operating(ax_t, df, top, sketch)
    _draw_plane(ax_p, df, top)
    return _finish(fig, ax_t, True, title)


_DRAWERS: dict[str, Callable[[Axes, pd.DataFrame, float | None], None]] = {
    "paths": _draw_paths,
    "window": _draw_window,
    "window_slack": _draw_window,
    "bounds": _draw_bounds,
    "msb": _draw_msb,
    "speed": _draw_speed,
    "operating_space": _draw_operating,
}


@paper
def plot_modes(
    dfs: Mapping[str, pd.DataFrame], kind: str = "window", *, title: str | None = None
) -> Figure:
    """Side-by-side panels, one per mode (e.g. adjust, fixed-wsch, min-msb), shared axes.

    ``kind`` is ``window``, ``bounds``, ``speed``, ``paths`` or ``operating_space``. Each
    panel's title counts its window deadline misses, bound violations (window, follower pairs)
    and lost tracks, from the table's columns.
    """
    if kind not in _DRAWERS:
        raise InputError(f"plot_modes: unknown kind {kind!r} (known: {', '.join(_DRAWERS)})")
    if not dfs:
        raise InputError("plot_modes: no runs given")
    top: float | None = None
    if kind in ("window", "window_slack", "bounds", "operating_space"):
        tops = []
        for df in dfs.values():
            if kind == "bounds":
                tops.append(_bounds_top(df))
            else:
                cols = ["w", "slack"] if kind.startswith("window") else ["w", "msb_min"]
                need_columns(df, cols + ["w_sch"], f"the {kind} figure")
                clip = WINDOW_CLIP if kind.startswith("window") else BOUNDS_CLIP
                tops.append(_ylimit([as_floats(df[c]) for c in cols], as_floats(df["w_sch"]), clip))
        top = max(tops)
    elif kind == "speed":
        speeds = [
            as_floats(df[c])
            for df in dfs.values()
            for c in ("v_leader_desired", "v_leader")
            if c in df.columns
        ]
        top = _ylimit(speeds, np.zeros(0), 1.0)
    n = len(dfs)
    size = (PAGE_IN, PAGE_IN / n + 1.2) if kind == "paths" else (PAGE_IN, 2.8)
    fig = new_figure(figsize=size, layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, n, sharex=True, sharey=True, squeeze=False)[0])
    for ax, (mode, df) in zip(axes, dfs.items(), strict=True):
        _DRAWERS[kind](ax, df, top)
        if kind == "paths":
            ax.set_aspect("equal", adjustable="box")  # shared axes cannot adjust data limits
        note = ax.get_title(loc="right")  # the off-scale note would overlap the counts
        ax.set_title("", loc="right")
        ax.set_title(
            f"{mode}\n{headline_counts(df)}" + (f"\n{note}" if note else ""),
            fontsize="small",
            loc="left",
        )
        if ax is not axes[0]:
            ax.set_ylabel("")
    if kind != "paths":  # shared time axis: the union of the runs (each panel set its own)
        spans = [(times_s(df)[0], ends_s(df)[-1]) for df in dfs.values() if len(df)]
        if spans and max(b for _, b in spans) > min(a for a, _ in spans):
            axes[0].set_xlim(min(a for a, _ in spans), max(b for _, b in spans))
    handles: dict[str, Any] = {}
    for ax in axes:  # union of legend entries (a panel may lack misses or critical spans)
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(lab.split(" (")[0] if lab.startswith("deadline") else lab, h)
    if handles:
        shown = few(list(handles.values()), list(handles))
        fig.legend(
            *shown,
            loc="outside lower center",
            ncols=min(len(shown[0]), 3),
            fontsize="small",
            frameon=False,
            title=BOUNDS_NOTE if kind == "bounds" else None,
            title_fontsize="small",
        )
    if title:
        fig.suptitle(title)
    return fig


# --- files -------------------------------------------------------------------------------


#: The file formats every command that draws offers (``--format``): raster PNG, or vector
#: SVG and PDF for papers (fonts kept as text in SVG, embedded as Type 42 in PDF).
FIGURE_FORMATS: tuple[str, ...] = ("png", "svg", "pdf")


#: Vertices Agg rasterizes a line in at a time when a figure is saved as PNG (matplotlib's
#: ``agg.path.chunksize``; 0, its default, draws a line at once): Agg's scanline cells
#: otherwise grow with the longest line's drawn length, so a 6 h run's figures peaked about
#: 7.5 MB higher (docs/reliability.md); at this size the six figures of that run are drawn
#: pixel for pixel as without chunks (checked at 300 dpi).
AGG_PATH_CHUNK = 20_000


def save_figure(
    fig: Figure, path: str | os.PathLike[str], *, dpi: int = DPI, fmt: str | None = None
) -> Path:
    """Write ``fig`` atomically (temp file beside ``path``, then rename) in format ``fmt``
    (`FIGURE_FORMATS`; default: the one ``path``'s suffix names; ``dpi`` for PNG);
    close it."""
    path = Path(path)
    fmt = (fmt or path.suffix.lstrip(".") or "png").lower()
    if fmt not in FIGURE_FORMATS:
        raise ValueError(f"figure format must be one of {', '.join(FIGURE_FORMATS)}, got {fmt!r}")
    import matplotlib

    with (
        atomic_path(path) as tmp,
        matplotlib.rc_context(
            {"svg.fonttype": "none", "pdf.fonttype": 42, "agg.path.chunksize": AGG_PATH_CHUNK}
        ),
    ):
        fig.savefig(
            tmp, format=fmt, dpi=dpi, metadata={"Date": None} if fmt in ("svg", "pdf") else None
        )
    if getattr(fig.canvas, "manager", None) is not None:  # made by pyplot: release it
        import matplotlib.pyplot as plt

        plt.close(fig)
    return path


SCENARIO_FIGURES: dict[str, Callable[..., Figure]] = {
    "paths": plot_paths,
    "window_slack": plot_window_slack,
    "bounds": plot_bounds,
    "msb": plot_msb,
    "speed": plot_speed,
    "operating_space": plot_operating_space,
}
_NAMES = tuple(SCENARIO_FIGURES)
_TITLES = {
    "paths": "Robots' paths",
    "window_slack": "Processing window and slack time",
    "bounds": "Effective processing-window bounds, per kind",
    "msb": "Minimum MSB against the schedulability bound",
    "speed": "Desired and actual leader speed",
    "operating_space": "Operating space",
}


def write_scenario_figures(
    df: pd.DataFrame,
    out_dir: str | os.PathLike[str],
    prefix: str = "",
    *,
    label: str | None = None,
    data: bool = False,
    dpi: int = DPI,
    fmt: str = "png",
    sketch: FigureSketch | None = None,
) -> list[Path]:
    """Write every figure of `SCENARIO_FIGURES` as ``<prefix><stem>.png`` in ``out_dir``.

    ``label`` (e.g. ``"Test 2, adjust"``) heads each title; with ``data`` each figure's
    [`figure_data`][rtsim.plots.scenario.figure_data] is also written as ``<prefix><stem>.csv``;
    ``sketch``: a long run's paths and dots (`rtsim.plots.scenario_data.read_figures`).
    Returns the paths written.
    """
    import gc

    out = Path(out_dir)
    written: list[Path] = []
    for stem, plot in SCENARIO_FIGURES.items():
        title = f"{label}: {_TITLES[stem]}" if label else _TITLES[stem]
        fig = plot(df, title=title, sketch=sketch)
        written.append(save_figure(fig, out / f"{prefix}{stem}.{fmt}", dpi=dpi))
        del fig
        # a figure is a web of reference cycles: freed here, before the next is drawn,
        # not when the collector next runs (six figures of a long run held at once)
        gc.collect()
        if data:
            csv = out / f"{prefix}{stem}.csv"
            write_table(csv, figure_data(df, stem))
            written.append(csv)
    return written
