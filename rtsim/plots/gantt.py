"""Gantt chart of a simulated schedule: one row per task, CPU stretches as bars.

Input is the execution-interval trace of [`rtsim.sim.SimResult`][rtsim.sim.SimResult] (columns
`rtsim.sim.TRACE_COLUMNS`) and optionally the job table, whose releases (up arrows)
and absolute deadlines (down ticks; red when missed) are drawn too.

`GanttRows` keeps, during a run, only the records a chart of one time range draws (it
is a pair of record sinks, `rtsim.sim.records.RowBuffer`), so that ``rtsim simulate
--gantt`` does not hold the whole run; the command line cuts a range that would hold more
than `GANTT_MAX_JOBS` jobs and says so in the chart's title.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import matplotlib
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from rtsim.plots.figure import new_figure
from rtsim.sim.records import jobs_frame, trace_frame

__all__ = ["gantt", "GanttRows", "GANTT_MAX_JOBS"]

#: Jobs a ``rtsim simulate --gantt`` chart draws at most: a longer ``--gantt-range`` is cut
#: (estimated from the task set's periods before the run) and the title says where.
GANTT_MAX_JOBS = 2_000


def gantt(
    trace: pd.DataFrame,
    *,
    jobs: pd.DataFrame | None = None,
    start: float | None = None,
    end: float | None = None,
    tasks: Sequence[str] | None = None,
    ax: Axes | None = None,
    title: str | None = None,
) -> Figure:
    """Draw ``trace`` between ``start`` and ``end`` (ms); tasks top to bottom in ``tasks`` order.

    Compute stretches are solid, CPU-counted suspensions hatched, idle suspensions (CPU free)
    outlined only, context-switch overhead grey.
    """
    lo = float(trace["start"].min()) if start is None and len(trace) else (start or 0.0)
    hi = float(trace["end"].max()) if end is None and len(trace) else (end or lo + 1.0)
    if hi <= lo:
        raise ValueError(f"gantt: empty time range {lo:g}..{hi:g}")
    names = list(tasks) if tasks is not None else list(dict.fromkeys(trace["task"]))
    if jobs is not None and tasks is None:
        names += [n for n in dict.fromkeys(jobs["task"]) if n not in names]
    if ax is None:
        fig = new_figure(figsize=(10, 0.6 * max(len(names), 1) + 1.2))
        ax = fig.subplots()
    else:
        fig = ax.figure  # type: ignore[assignment]
    colors = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    rows = {n: i for i, n in enumerate(names)}
    view = trace[(trace["end"] > lo) & (trace["start"] < hi)]
    rec: Any  # a row (its fields typed by the columns, not by pandas)
    for rec in view.itertuples(index=False):
        if rec.task not in rows:
            continue
        y = rows[rec.task]
        s, e = max(rec.start, lo), min(rec.end, hi)
        color = colors[y % len(colors)]
        if rec.kind == "overhead":
            ax.broken_barh([(s, e - s)], (y - 0.35, 0.7), facecolors="0.6")
        elif not rec.on_cpu:
            ax.broken_barh([(s, e - s)], (y - 0.2, 0.4), facecolors="none", edgecolors=color)
        elif rec.kind == "suspend":
            ax.broken_barh(
                [(s, e - s)], (y - 0.35, 0.7), facecolors="white", edgecolors=color, hatch="//"
            )
        else:
            ax.broken_barh([(s, e - s)], (y - 0.35, 0.7), facecolors=color)
    if jobs is not None:
        jv = jobs[(jobs["release"] >= lo) & (jobs["release"] <= hi)]
        for rec in jv.itertuples(index=False):
            if rec.task in rows:
                y = rows[rec.task]
                ax.annotate(
                    "",
                    (rec.release, y + 0.1),
                    (rec.release, y + 0.5),
                    arrowprops={"arrowstyle": "->", "lw": 0.8},
                )
        dv = jobs[(jobs["deadline"] >= lo) & (jobs["deadline"] <= hi)]
        for rec in dv.itertuples(index=False):
            if rec.task in rows:
                y = rows[rec.task]
                ax.plot(
                    [rec.deadline] * 2,
                    [y - 0.5, y - 0.1],
                    color="red" if rec.missed else "0.3",
                    lw=1.0,
                )
    ax.set_xlim(lo, hi)
    ax.set_ylim(len(names) - 0.5, -0.6)
    ax.set_yticks(range(len(names)), names)
    ax.set_xlabel("time (ms)")
    ax.set_ylabel("task")
    ax.grid(axis="x", alpha=0.3)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    return fig


class _Rows:
    """A record sink (``write_rows``) keeping the rows ``keep(row)`` accepts."""

    def __init__(self, keep: Callable[[tuple[Any, ...]], bool]) -> None:
        self.keep = keep
        self.rows: list[tuple[Any, ...]] = []

    def write_rows(self, rows: Sequence[tuple[Any, ...]]) -> None:
        keep = self.keep
        self.rows.extend(r for r in rows if keep(r))


class GanttRows:
    """Sinks for a run's records that keep what `gantt` draws between ``start`` and
    ``end`` (ms): ``trace`` keeps the intervals that overlap the range, ``jobs`` the jobs
    released or due in it (so the chart is the one drawn from the whole tables). Memory
    grows with the jobs in the range, not with the run."""

    def __init__(self, start: float, end: float) -> None:
        lo, hi = float(start), float(end)
        self.start, self.end = lo, hi
        # TRACE_COLUMNS: start 5, end 6; JOB_COLUMNS: release 2, deadline 6
        self.trace = _Rows(lambda r: r[6] > lo and r[5] < hi)
        self.jobs = _Rows(lambda r: lo <= r[2] <= hi or lo <= r[6] <= hi)

    def frames(self) -> tuple[pd.DataFrame, pd.DataFrame]:
        """(trace, jobs) as the run's tables, restricted to the range."""
        return trace_frame(self.trace.rows), jobs_frame(self.jobs.rows)
