"""Figures of the validation report (`rtsim.validate`), drawn from its table.

- [`bounds_vs_n`][rtsim.plots.validation.bounds_vs_n]: w_sch, w_rta and the two w_sim against n, one
panel per r_H;
- [`pessimism_heatmap`][rtsim.plots.validation.pessimism_heatmap]: w_sch / w_sim over (n, r_H), one
panel per search mode;
- `scheduler_bounds`: the paper set's w_sch, w_rta and w_edf against n, per r_H (from
  the analytic table of `rtsim.validate.runner.scheduler_table`).

Each has a ``*_data`` companion returning the exact numbers drawn (written beside the PNG).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from rtsim.plots.figure import new_figure
from rtsim.plots.style import PAGE_IN, few, paper

__all__ = [
    "bounds_vs_n_data",
    "bounds_vs_n",
    "pessimism_data",
    "pessimism_heatmap",
    "scheduler_bounds",
]

_MODES = ("wcet-cpu", "counted-idle")
#: Panels per row of the figures with one panel per r_H.
_COLUMNS = 3


def _panels(count: int, aspect: float = 0.8) -> tuple[Figure, list]:
    """A page-wide figure of ``count`` panels, at most `_COLUMNS` a row (sharing both axes),
    each ``aspect`` times as high as wide; panels left over in the last row are hidden."""
    cols = min(count, _COLUMNS)
    rows = -(-count // cols)
    height = aspect * PAGE_IN / _COLUMNS * rows + 0.8
    fig = new_figure(figsize=(PAGE_IN, height), layout="constrained")
    grid = fig.subplots(rows, cols, sharex=True, sharey=True, squeeze=False)
    axes = list(grid.flat)
    for ax in axes[count:]:
        ax.set_visible(False)
    for ax in axes[:count]:  # tick labels on every shown panel (a hidden one may be below)
        ax.xaxis.set_tick_params(labelbottom=True)
    return fig, axes[:count]


def _legend_below(fig: Figure, ax: object) -> None:
    """The panels' common legend below them, off the data."""
    handles, labels = few(*ax.get_legend_handles_labels())  # type: ignore[attr-defined]
    fig.legend(
        handles,
        labels,
        loc="outside lower center",
        ncols=min(len(handles), 2),
        fontsize="small",
        frameon=False,
    )


def bounds_vs_n_data(df: pd.DataFrame) -> pd.DataFrame:
    """One row per (r_H, n): w_sch, w_rta, w_sim_wcet_cpu, w_sim_counted_idle (ms)."""
    paper = df[df["source"] == "paper"]
    base = paper.drop_duplicates(["r_H", "n"])[["r_H", "n", "w_sch", "w_rta"]]
    out = base.set_index(["r_H", "n"])
    for mode in _MODES:
        sub = paper[paper["mode"] == mode].drop_duplicates(["r_H", "n"])
        out[f"w_sim_{mode.replace('-', '_')}"] = sub.set_index(["r_H", "n"])["w_sim"]
    return out.reset_index().sort_values(["r_H", "n"], ignore_index=True)


@paper
def bounds_vs_n(df: pd.DataFrame, r_H: Sequence[float] | None = None) -> Figure:
    """w_sch, w_rta and w_sim (both searches) against n, one panel per r_H (ms)."""
    data = bounds_vs_n_data(df)
    radii = sorted(data["r_H"].unique()) if r_H is None else list(r_H)
    fig, axes = _panels(len(radii))
    styles = {
        "w_sch": ("w_sch (Eq 7/11)", "-", "o"),
        "w_rta": ("w_rta (exact RTA)", "--", "s"),
        "w_sim_wcet_cpu": ("w_sim: WCET, Δt on CPU", ":", "^"),
        "w_sim_counted_idle": ("w_sim: counted beams, Δt idle", "-.", "v"),
    }
    for k, (ax, r) in enumerate(zip(axes, radii, strict=True)):
        sub = data[data["r_H"] == r]
        for col, (label, ls, mk) in styles.items():
            ax.plot(sub["n"], sub[col], ls=ls, marker=mk, ms=4, label=label)
        ax.set_title(f"r_H = {r:g} cm")
        ax.set_xlabel("followers n (count)")
        if k % _COLUMNS == 0:
            ax.set_ylabel("window (ms)")
        ax.grid(alpha=0.3)
    _legend_below(fig, axes[0])
    return fig


def pessimism_data(df: pd.DataFrame, ratio: str = "w_sch_over_w_sim") -> pd.DataFrame:
    """One row per (mode, r_H, n) with the ratio (default w_sch / w_sim)."""
    paper = df[df["source"] == "paper"].drop_duplicates(["mode", "r_H", "n"])
    return paper[["mode", "r_H", "n", ratio]].sort_values(["mode", "r_H", "n"], ignore_index=True)


@paper
def pessimism_heatmap(df: pd.DataFrame, ratio: str = "w_sch_over_w_sim") -> Figure:
    """Heat map of ``ratio`` over (n, r_H), one panel per search mode, values annotated."""
    data = pessimism_data(df, ratio)
    modes = [m for m in _MODES if m in set(data["mode"])]
    fig = new_figure(figsize=(PAGE_IN, 2.9), layout="constrained")
    axes = fig.subplots(1, len(modes), squeeze=False)
    vals = data[ratio].to_numpy(dtype=float)
    vmin, vmax = float(np.nanmin(vals)), float(np.nanmax(vals))
    if vmax - vmin < 1e-9:
        vmin, vmax = vmin - 0.01, vmax + 0.01
    im = None
    for ax, mode in zip(axes[0], modes, strict=True):
        grid = data[data["mode"] == mode].pivot(index="r_H", columns="n", values=ratio)
        im = ax.imshow(
            grid.to_numpy(dtype=float),
            origin="lower",
            aspect="auto",
            cmap="viridis",
            vmin=vmin,
            vmax=vmax,
        )
        ax.set_xticks(range(grid.shape[1]), [f"{c:g}" for c in grid.columns])
        ax.set_yticks(range(grid.shape[0]), [f"{r:g}" for r in grid.index])
        ax.set_xlabel("followers n (count)")
        ax.set_ylabel("r_H (cm)")
        ax.set_title(f"{ratio.replace('_over_', ' / ')} — {mode}")
        if grid.size <= 80:
            for (i, j), v in np.ndenumerate(grid.to_numpy(dtype=float)):
                if np.isfinite(v):
                    ax.text(
                        j,
                        i,
                        f"{v:.3f}",
                        ha="center",
                        va="center",
                        fontsize=6 if grid.shape[1] > 6 else 7,
                        color="w" if v < (vmin + vmax) / 2 else "k",
                    )
    if im is not None:
        bar = fig.colorbar(im, ax=list(axes[0]), shrink=0.9)
        bar.set_label(f"{ratio.replace('_over_', ' / ')} (ratio)")
    return fig


@paper
def scheduler_bounds(table: pd.DataFrame) -> Figure:
    """w_sch, w_rta (fixed priority) and w_edf (EDF) against n, one panel per r_H (ms), with
    the relative gain 1 − w_edf/w_rta on a second axis. ``table``: columns n, r_H, w_sch,
    w_rta, w_edf."""
    radii = sorted(table["r_H"].unique())
    fig, axes = _panels(len(radii))
    styles = {
        "w_sch": ("w_sch (Eq 7/11, FP)", "-", "o"),
        "w_rta": ("w_rta (exact RTA, FP)", "--", "s"),
        "w_edf": ("w_edf (EDF demand)", ":", "^"),
    }
    last_in_row = {min(k + _COLUMNS - 1 - k % _COLUMNS, len(radii) - 1) for k in range(len(radii))}
    for k, (ax, r) in enumerate(zip(axes, radii, strict=True)):
        sub = table[table["r_H"] == r].sort_values("n")
        for col, (label, ls, mk) in styles.items():
            ax.plot(sub["n"], sub[col], ls=ls, marker=mk, ms=4, label=label)
        gain = ax.twinx()
        gain.bar(
            sub["n"],
            100 * (1 - sub["w_edf"] / sub["w_rta"]),
            color="0.8",
            alpha=0.5,
            width=0.5,
            zorder=0,
        )
        gain.set_ylim(0, 5)
        if k in last_in_row:
            gain.set_ylabel("1 − w_edf / w_rta (%)")
        else:
            gain.set_yticklabels([])
        ax.set_zorder(gain.get_zorder() + 1)
        ax.patch.set_visible(False)
        ax.set_title(f"r_H = {r:g} cm")
        ax.set_xlabel("followers n (count)")
        if k % _COLUMNS == 0:
            ax.set_ylabel("window (ms)")
        ax.grid(alpha=0.3)
    _legend_below(fig, axes[0])
    return fig
