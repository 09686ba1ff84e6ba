"""Specs of tasks, task sets and processing-window chains (no engine), and task-set generators."""

from rtsim.model.generate import (
    PeriodSpec,
    draw_periods,
    parse_periods,
    random_taskset,
    uunifast,
    uunifast_discard,
)
from rtsim.model.task import OVERLOAD_POLICIES, OverloadPolicy, Segment, SegmentKind, Task
from rtsim.model.taskset import TaskSet
from rtsim.model.window import WindowSpec

__all__ = [
    "OVERLOAD_POLICIES",
    "OverloadPolicy",
    "PeriodSpec",
    "Segment",
    "SegmentKind",
    "Task",
    "TaskSet",
    "WindowSpec",
    "draw_periods",
    "parse_periods",
    "random_taskset",
    "uunifast",
    "uunifast_discard",
]
