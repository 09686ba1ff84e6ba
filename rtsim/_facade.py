"""The top level's entry points that take a task-set file as well as a task set.

The analyses and the simulator take task sets (:class:`~rtsim.model.taskset.TaskSet`); reading
a file is the configuration layer's work, above them. For convenience at the top level,
:func:`rtsim.analyze`, :func:`rtsim.window_bounds` and :func:`rtsim.simulate` also take the
path of a task-set file or the name of a packaged one (``"example"``), read with
:func:`rtsim.io.taskset.load_taskset`. This module sits with :mod:`rtsim` above every layer.
"""

from __future__ import annotations

import functools
import os
from typing import Any

from rtsim.analysis.bounds import window_bounds as _window_bounds
from rtsim.analysis.rta import analyze as _analyze
from rtsim.io.taskset import as_taskset
from rtsim.sim.run import simulate as _simulate

__all__ = ["analyze", "simulate", "window_bounds"]


def _read(ts: Any, function: str) -> Any:
    return as_taskset(ts, function) if isinstance(ts, str | os.PathLike) else ts


@functools.wraps(_analyze)
def analyze(ts: Any, *args: Any, **kwargs: Any) -> Any:
    return _analyze(_read(ts, "analyze"), *args, **kwargs)


@functools.wraps(_window_bounds)
def window_bounds(ts: Any, *args: Any, **kwargs: Any) -> Any:
    return _window_bounds(_read(ts, "window_bounds"), *args, **kwargs)


@functools.wraps(_simulate)
def simulate(ts: Any, *args: Any, **kwargs: Any) -> Any:
    return _simulate(_read(ts, "simulate"), *args, **kwargs)


for _f in (analyze, window_bounds, simulate):
    _f.__doc__ = (_f.__doc__ or "") + (
        f"\n\n    At the top level (``rtsim.{_f.__name__}``), ``ts`` may also be the path of a "
        f"task-set file or the name of a packaged set.")
