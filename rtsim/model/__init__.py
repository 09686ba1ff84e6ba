"""Specs of tasks, task sets and processing-window chains (no engine)."""

from rtsim.model.task import OVERLOAD_POLICIES, OverloadPolicy, Segment, SegmentKind, Task
from rtsim.model.taskset import TaskSet
from rtsim.model.window import WindowSpec

__all__ = [
    "OVERLOAD_POLICIES",
    "OverloadPolicy",
    "Segment",
    "SegmentKind",
    "Task",
    "TaskSet",
    "WindowSpec",
]
