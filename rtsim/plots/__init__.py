"""Figures: each function takes results or DataFrames and returns a matplotlib Figure.

``gantt`` and ``response_histogram`` for schedules; the scenario figures (the paper's
Figs 2, 8–15 and the mode comparisons) for ``windows.csv`` tables; the validation figures.
"""

from rtsim.notebook import enable_figure_display
from rtsim.plots.gantt import gantt
from rtsim.plots.histogram import response_histogram
from rtsim.plots.scenario import (
    SCENARIO_FIGURES,
    figure_data,
    plot_bounds,
    plot_modes,
    plot_operating_space,
    plot_paths,
    plot_speed,
    plot_window_slack,
    save_figure,
    write_scenario_figures,
)
from rtsim.plots.validation import bounds_vs_n, pessimism_heatmap

enable_figure_display()  # a Figure returned as a notebook cell's value shows as a PNG

__all__ = [
    "SCENARIO_FIGURES",
    "bounds_vs_n",
    "figure_data",
    "gantt",
    "pessimism_heatmap",
    "plot_bounds",
    "plot_modes",
    "plot_operating_space",
    "plot_paths",
    "plot_speed",
    "plot_window_slack",
    "response_histogram",
    "save_figure",
    "write_scenario_figures",
]
