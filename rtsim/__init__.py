"""rtsim: a discrete-event real-time scheduling simulator coupled to a robot-group world.

The first case is Qadi, Goddard, Huang & Farritor, "Using Dynamic Processing Windows for
Robot Group Control". Times are in ms, lengths in cm, speeds in cm/s, angles in radians.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("rtsim")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"

from rtsim.errors import InputError, RtsimError, ScenarioError, SweepError, TaskSetError
from rtsim.model import Segment, Task, TaskSet, WindowSpec

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
