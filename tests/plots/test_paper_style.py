"""Figures fit for a paper by default (issue 34, item 7): histograms with integer count ticks,
one figure per run with a panel per task at print resolution, legends of a handful of
entries."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from rtsim.plots.histogram import response_histogram, response_histograms
from rtsim.plots.style import DPI, MAX_LEGEND, PAGE_IN, few


def _legend_texts(fig) -> list[str]:  # type: ignore[no-untyped-def]
    legends = [*fig.legends, *(ax.get_legend() for ax in fig.axes)]
    return [t.get_text() for lg in legends if lg is not None for t in lg.get_texts()]


def test_count_ticks_are_integers() -> None:
    fig = response_histogram([1.0, 2.0, 2.5], lines={"deadline": 3.0}, bins=4)
    ticks = fig.axes[0].get_yticks()
    assert len(ticks) >= 2 and np.all(ticks == np.round(ticks))


def test_one_figure_a_panel_per_task_page_wide() -> None:
    panels = {f"task{k}": (np.arange(10.0) + k, {"deadline": 20.0}) for k in range(3)}
    fig = response_histograms(panels, bins=5)
    shown = [ax for ax in fig.axes if ax.get_visible()]
    assert [ax.get_title() for ax in shown] == ["task0", "task1", "task2"]
    assert fig.get_size_inches()[0] == pytest.approx(PAGE_IN)
    for ax in shown:
        ticks = ax.get_yticks()
        assert np.all(ticks == np.round(ticks))


def test_few_keeps_a_handful_of_legend_entries() -> None:
    handles, labels = list(range(11)), [f"f{k}" for k in range(11)]
    h, lab = few(handles, labels)
    assert len(h) == len(lab) == MAX_LEGEND
    assert lab[:-1] == labels[: MAX_LEGEND - 1] and lab[-1] == "+6 more (in the CSV)"
    assert few(handles[:3], labels[:3]) == (handles[:3], labels[:3])


def test_scenario_figures_keep_their_legends_short() -> None:
    from rtsim.coupling import run_scenario
    from rtsim.plots.scenario import (
        plot_bounds,
        plot_msb,
        plot_paths,
        plot_speed,
        plot_window_slack,
    )

    run = run_scenario("test2", overrides={"formation.followers": 6}, duration_s=4, seed=0)
    for plot in (plot_bounds, plot_msb, plot_paths, plot_speed, plot_window_slack):
        texts = _legend_texts(plot(run.windows))
        assert len(texts) <= MAX_LEGEND, (plot.__name__, texts)


def _png_size(path: Path) -> tuple[int, int]:
    head = path.read_bytes()[:24]
    return struct.unpack(">II", head[16:24])


def test_rtsim_histogram_writes_the_run_in_one_figure_at_print_resolution(
    tmp_path: Path,
) -> None:
    from rtsim.cli import main

    out = tmp_path / "h"
    assert main(["histogram", "example", "--horizon", "2000", "--out", str(out), "-q"]) == 0
    width, _ = _png_size(out / "histograms.png")
    assert width == pytest.approx(PAGE_IN * DPI, abs=2)
