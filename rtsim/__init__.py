"""rtsim: a discrete-event real-time scheduling simulator coupled to a robot-group world.

The first case is Qadi, Goddard, Huang & Farritor, "Using Dynamic Processing Windows for
Robot Group Control". Times are in ms, lengths in cm, speeds in cm/s, angles in radians.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("rtsim")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"

from typing import Any

from rtsim.errors import InputError, RtsimError, ScenarioError, SweepError, TaskSetError

_MODEL = ("Segment", "Task", "TaskSet", "WindowSpec")


def __getattr__(name: str) -> Any:
    """The model's classes, imported on first use (the command line starts without numpy,
    so that it handles Ctrl-C and SIGTERM from its first instant)."""
    if name in _MODEL:
        import rtsim.model

        return getattr(rtsim.model, name)
    raise AttributeError(f"module 'rtsim' has no attribute {name!r}")

__all__ = [
    "__version__",
    "InputError",
    "RtsimError",
    "ScenarioError",
    "SweepError",
    "TaskSetError",
    "Segment",
    "Task",
    "TaskSet",
    "WindowSpec",
]
