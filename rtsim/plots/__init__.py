"""Figures: each function takes results or DataFrames and returns a matplotlib Figure."""

from rtsim.plots.gantt import gantt
from rtsim.plots.histogram import response_histogram

__all__ = ["gantt", "response_histogram"]
