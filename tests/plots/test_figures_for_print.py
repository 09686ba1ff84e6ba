"""Every figure the commands draw is fit for a paper: each axis says what it shows and in which
unit, no legend sits on the plotted data, and every text is still readable when the figure is
printed at a paper's width (a column, 3.5 in, for figures up to 5 in wide; the page, 7.16 in,
for wider ones).

The figures are those of ``rtsim reproduce`` (the README's main command; the same functions
draw ``rtsim scenario``'s), of ``rtsim validate`` and of ``rtsim simulate``/``histogram``."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.text import Text  # noqa: E402

#: A unit in parentheses: ms, s, cm, cm/s, %, or count/ratio for dimensionless quantities.
UNIT = re.compile(r"\((ms|s|cm|cm/s|%|count|ratio)\)")
COLUMN_IN, PAGE_IN, MIN_PT = 3.5, 7.16, 6.0


def _reproduce_figures(tmp: Path) -> Iterator[tuple[str, Figure]]:
    from rtsim.reproduce import figure_tasks, make_figure, run_all, run_specs

    results = run_all(run_specs(tmp, seed=0, duration_s=10.0))
    windows = {key: res["windows"] for key, res in results.items()}
    for task in figure_tasks(windows, tmp / "figures", None):
        yield task["stem"], make_figure(task)[0]


def _validation_table() -> pd.DataFrame:
    rows = []
    for r in (10.0, 20.0, 30.0, 40.0, 50.0):
        for n in range(1, 11):
            w_sch = 100 + 12 * n + r
            for mode, sim in (("wcet-cpu", 0.97), ("counted-idle", 0.8)):
                rows.append(
                    {
                        "source": "paper",
                        "r_H": r,
                        "n": n,
                        "w_sch": w_sch,
                        "w_rta": 0.98 * w_sch,
                        "mode": mode,
                        "w_sim": sim * w_sch,
                        "w_sch_over_w_sim": 1 / sim,
                        "w_rta_over_w_sim": 0.98 / sim,
                    }
                )
    return pd.DataFrame(rows)


def _validation_figures(tmp: Path) -> Iterator[tuple[str, Figure]]:
    from rtsim.plots.validation import bounds_vs_n, pessimism_heatmap, scheduler_bounds

    table = _validation_table()
    yield "bounds_vs_n", bounds_vs_n(table)
    yield "pessimism_wsch", pessimism_heatmap(table, "w_sch_over_w_sim")
    yield "pessimism_wrta", pessimism_heatmap(table, "w_rta_over_w_sim")
    sched = table.drop_duplicates(["r_H", "n"])[["n", "r_H", "w_sch", "w_rta"]].copy()
    sched["w_edf"] = 0.97 * sched["w_rta"]
    yield "scheduler_bounds", scheduler_bounds(sched)


def _schedule_figures(tmp: Path) -> Iterator[tuple[str, Figure]]:
    from rtsim.cli.simulate import gantt_figure, histogram_figure
    from rtsim.config.taskset import load_taskset
    from rtsim.plots.histogram import response_histogram
    from rtsim.sim import simulate

    ts = load_taskset()
    res = simulate(ts, 20_000, record_jobs=True, record_trace=True, seed=1, exec_model="uniform")
    yield "gantt", gantt_figure(res, (0.0, 2000.0))
    yield (
        "simulate_histograms",
        histogram_figure(
            res,
            {t: 230.0 for t in res.tasks},
            {t: 240.0 for t in res.tasks},
            {"w_sch": 237.4, "w_rta": 225.0},
            ts.window.name if ts.window else None,
        ),
    )
    win = res.jobs[res.jobs["task"] == ts.window.name]["response"] if ts.window else []
    yield (
        "histogram",
        response_histogram(
            np.asarray(win, dtype=float),
            lines={"WCRT (exact RTA)": 222.7, "deadline": 237.4},
            title="window",
        ),
    )


@pytest.fixture(scope="module")
def figures(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Figure]:
    tmp = tmp_path_factory.mktemp("figures")
    out: dict[str, Figure] = {}
    for source in (_reproduce_figures, _validation_figures, _schedule_figures):
        for name, fig in source(tmp):
            FigureCanvasAgg(fig)
            fig.canvas.draw()
            out[name] = fig
    return out


def _data_axes(fig: Figure) -> list[Any]:
    return [
        ax
        for ax in fig.axes
        if ax.get_visible()
        and not hasattr(ax, "_colorbar")
        and (ax.lines or ax.collections or ax.patches or ax.images)
    ]


def _ticks_shown(axis: Any) -> list[str]:
    return [t.get_text() for t in axis.get_ticklabels() if t.get_visible() and t.get_text()]


def _numeric(labels: list[str]) -> bool:
    return all(re.fullmatch(r"[−\-+]?[\d.,]+(e[−\-+]?\d+)?%?", s.strip()) for s in labels)


def _label(ax: Any, which: str) -> str:
    """The axis label, or that of an axes sharing the axis (panels label one side only)."""
    group = ax.get_shared_x_axes() if which == "x" else ax.get_shared_y_axes()
    for other in [ax, *group.get_siblings(ax)]:
        text = other.get_xlabel() if which == "x" else other.get_ylabel()
        if text:
            return str(text)
    return ""


@pytest.mark.slow
def test_every_axis_says_what_it_shows_and_its_unit(figures: dict[str, Figure]) -> None:
    problems = []
    for name, fig in figures.items():
        for ax in fig.axes:
            if not ax.get_visible():
                continue
            if hasattr(ax, "_colorbar"):
                cb = ax._colorbar
                label = ax.get_ylabel() if cb.orientation == "vertical" else ax.get_xlabel()
                if not UNIT.search(label):
                    problems.append(f"{name}: colorbar label {label!r}")
                continue
            for which, axis in (("x", ax.xaxis), ("y", ax.yaxis)):
                shown = _ticks_shown(axis)
                if not shown:
                    continue  # a twin axis without tick labels, a panel's shared side
                label = _label(ax, which)
                if not _numeric(shown):
                    ok = bool(label)  # categories (tasks): named, no unit
                else:
                    ok = bool(UNIT.search(label))
                if not ok:
                    problems.append(f"{name}: {which} axis label {label!r}")
    assert not problems, "\n".join(problems)


def _overlap(a: Any, b: Any) -> float:
    w = min(a.x1, b.x1) - max(a.x0, b.x0)
    h = min(a.y1, b.y1) - max(a.y0, b.y0)
    return max(w, 0.0) * max(h, 0.0)


def test_no_legend_sits_on_the_plotted_data(figures: dict[str, Figure]) -> None:
    problems = []
    for name, fig in figures.items():
        renderer = fig.canvas.get_renderer()
        legends = list(fig.legends) + [
            ax.get_legend() for ax in fig.axes if ax.get_legend() is not None
        ]
        for leg in legends:
            box = leg.get_window_extent(renderer)
            for ax in _data_axes(fig):
                if _overlap(box, ax.get_window_extent(renderer)) > 1.0:  # px²
                    problems.append(f"{name}: legend over an axes' plotting area")
    assert not problems, "\n".join(problems)


def test_every_text_is_readable_at_a_papers_width(figures: dict[str, Figure]) -> None:
    problems = []
    for name, fig in figures.items():
        width = float(fig.get_size_inches()[0])
        scale = (COLUMN_IN if width <= 5.0 else PAGE_IN) / width
        texts = [t for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()]
        smallest = min(texts, key=lambda t: t.get_fontsize())
        printed = smallest.get_fontsize() * scale
        if printed < MIN_PT:
            problems.append(
                f"{name} ({width:.1f} in wide): {smallest.get_text()[:40]!r} "
                f"prints at {printed:.1f} pt"
            )
    assert not problems, "\n".join(problems)


def test_the_figures_checked_are_all_of_reproduces(figures: dict[str, Figure]) -> None:
    from rtsim.reproduce import figure_stems

    assert set(figure_stems()) <= set(figures)
