"""rtsim: a discrete-event real-time scheduling simulator coupled to a robot-group world.

The first case is Qadi, Goddard, Huang & Farritor, "Using Dynamic Processing Windows for
Robot Group Control". Times are in ms, lengths in cm, speeds in cm/s, angles in radians.

The top level is a facade over the subpackages; the entry points load on first use, so
``import rtsim`` stays light:

- [`run_scenario`][rtsim.run_scenario] (``rtsim.coupling``): one coupled robot run, schedule and
world;
- [`run_sweep`][rtsim.run_sweep]: a scenario over a grid (followers × Hough radii …), a DataFrame;
- `load_scenario` (``rtsim.config.scenario``): a scenario file, or a shipped one by name, with
  dotted overrides;
- [`simulate`][rtsim.simulate] (``rtsim.sim``): a task set on the virtual CPU;
- [`analyze`][rtsim.analyze] (``rtsim.analysis``): exact response-time analysis of a task set;
- `load_taskset` (``rtsim.config.taskset``), [`window_bounds`][rtsim.window_bounds]: a
  task-set file, the window's bounds.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from rtsim._version import __version__
from rtsim.errors import (
    InputError,
    OverrideError,
    RtsimError,
    ScenarioError,
    SweepError,
    TaskSetError,
)

if TYPE_CHECKING:  # pragma: no cover
    from rtsim._facade import run_sweep
    from rtsim.analysis import analyze, window_bounds
    from rtsim.config.scenario import load_scenario
    from rtsim.config.taskset import load_taskset
    from rtsim.coupling import run_scenario
    from rtsim.model import Segment, Task, TaskSet, WindowSpec
    from rtsim.sim import simulate

#: The entry points the facade loads on first use, by the subpackage that defines them.
#: (The model's classes too: the command line starts without numpy, so that it handles
#: Ctrl-C and SIGTERM from its first instant.)
_LAZY: dict[str, str] = {
    "Segment": "rtsim.model",
    "Task": "rtsim.model",
    "TaskSet": "rtsim.model",
    "WindowSpec": "rtsim.model",
    "run_scenario": "rtsim.coupling",
    "load_scenario": "rtsim.config.scenario",
    "load_taskset": "rtsim.config.taskset",
    "simulate": "rtsim._facade",  # these three take a task-set file too
    "analyze": "rtsim._facade",
    "window_bounds": "rtsim._facade",
    "run_sweep": "rtsim._facade",  # a grid of runs in one call (not the rtsim.sweep package)
}

__all__ = [
    "__version__",
    "InputError",
    "OverrideError",
    "RtsimError",
    "ScenarioError",
    "SweepError",
    "TaskSetError",
    "Segment",
    "Task",
    "TaskSet",
    "WindowSpec",
    "analyze",
    "load_scenario",
    "load_taskset",
    "run_scenario",
    "run_sweep",
    "simulate",
    "window_bounds",
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'rtsim' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
