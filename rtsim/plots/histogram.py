"""Response-time histogram with labelled vertical lines (analytic WCRT, deadline, w_sch, …).

Takes either raw response times (a sequence, array or pandas Series, e.g. from the job table)
or the running [`rtsim.sim.ResponseHistogram`][rtsim.sim.ResponseHistogram] a run keeps without job
records.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import matplotlib
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from rtsim.plots.figure import new_figure
from rtsim.plots.style import PAGE_IN, PAPER_RC, few
from rtsim.sim.records import ResponseHistogram

__all__ = ["response_histogram", "response_histograms"]

_LINE_STYLES = ("-", "--", "-.", ":")


def response_histogram(
    data: ResponseHistogram | Sequence[float] | np.ndarray,
    *,
    lines: Mapping[str, float | None] | None = None,
    bins: int | Sequence[float] = 50,
    ax: Axes | None = None,
    title: str | None = None,
    xlabel: str = "response time (ms)",
    legend: str = "beside",
) -> Figure:
    """Histogram of response times with one labelled vertical line per ``lines`` entry.

    The count axis has integer ticks; ``legend``: ``"beside"`` the axes or ``"inside"`` them
    (a panel of `response_histograms`).

    Example: ``lines={"WCRT (analysis)": 229.0, "deadline": 237.4, "w_sch": 237.4}``;
    a ``None`` value (no finite bound) is left out of the plot but kept in the legend text.
    ``bins`` applies to raw data only (a ResponseHistogram has its own bins).
    """
    own = ax is None
    if ax is None:
        fig = new_figure(figsize=(7, 4))
        ax = fig.subplots()
    else:
        fig = ax.figure  # type: ignore[assignment]
    if isinstance(data, ResponseHistogram):
        edges, counts = data.arrays()
        ax.stairs(counts, edges, fill=True, alpha=0.6, label=f"simulated ({counts.sum()} jobs)")
    else:
        values = np.asarray(data, dtype=float)
        values = values[np.isfinite(values)]
        ax.hist(values, bins=bins, alpha=0.6, label=f"simulated ({values.size} jobs)")
    colors = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, (label, x) in enumerate((lines or {}).items()):
        if x is None or not np.isfinite(x):
            ax.plot([], [], " ", label=f"{label}: none")
            continue
        ax.axvline(
            x,
            color=colors[(i + 1) % len(colors)],
            ls=_LINE_STYLES[i % len(_LINE_STYLES)],
            lw=1.5,
            label=f"{label} = {x:.6g}",
        )
    ax.set_xlabel(xlabel)
    ax.set_ylabel("jobs (count)")
    from matplotlib.ticker import MaxNLocator

    ax.yaxis.set_major_locator(MaxNLocator(integer=True))  # counts: no 2.5 jobs

    shown = few(*ax.get_legend_handles_labels())
    if legend == "inside":
        ax.legend(*shown, fontsize="small", loc="best", frameon=False)
    else:  # beside the axes, never over the bars or the lines
        ax.legend(
            *shown,
            fontsize="small",
            loc="upper left",
            bbox_to_anchor=(1.01, 1.0),
            borderaxespad=0.0,
            frameon=False,
        )
    if title:
        ax.set_title(title)
    if own:
        fig.tight_layout()
    return fig


def response_histograms(
    panels: Mapping[str, tuple[Sequence[float] | np.ndarray, Mapping[str, float | None]]],
    *,
    bins: int | Mapping[str, Sequence[float]] = 50,
    title: str | None = None,
    columns: int = 2,
) -> Figure:
    """One figure for a run: a panel per task (``panels``: task → (response times, lines)),
    ``columns`` panels across, as wide as a paper's page (`rtsim.plots.style`), text at
    caption size. ``bins``: a count, or each task's bin edges."""
    import matplotlib as mpl

    names = list(panels)
    cols = max(1, min(columns, len(names)))
    rows = max(1, -(-len(names) // cols))
    with mpl.rc_context(PAPER_RC):  # type: ignore[arg-type]
        fig = new_figure(figsize=(PAGE_IN, 1.9 * rows + 0.5), layout="constrained")
        axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
        for ax, name in zip(axes, names, strict=False):
            values, lines = panels[name]
            b = bins[name] if isinstance(bins, Mapping) else bins
            response_histogram(values, lines=lines, bins=b, ax=ax, title=name, legend="inside")
        for ax in axes[len(names) :]:
            ax.set_visible(False)
        if title:
            fig.suptitle(title)
    return fig
