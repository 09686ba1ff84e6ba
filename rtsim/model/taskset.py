"""Task sets: ordinary periodic tasks, optionally around one processing-window chain."""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

from rtsim._numbers import is_real
from rtsim.errors import TaskSetError
from rtsim.model.task import RESOURCE_PROTOCOLS, Task
from rtsim.model.window import WindowSpec

__all__ = ["TaskSet"]


#: `TaskSet.window_task`'s tasks kept per process (a sweep's points build their CPU from
#: the same prepared task set): by the set (the object, alive while kept), w and the Hough
#: time; a Task is immutable, so a CPU may share it
WINDOW_TASKS_KEPT = 16
_WINDOW_TASKS: dict[tuple[Any, ...], tuple[TaskSet, Task]] = {}
_WINDOW_TASKS_LOCK = threading.Lock()


@dataclass(frozen=True)
class TaskSet:
    """A validated, immutable task set, tasks sorted by priority (highest first).

    With a ``window`` (the paper's T_w), the tasks above its priority form T_hp and those
    below form T_lp; tasks with ``per_window`` periods follow w (the command task's 2w).
    ``overhead`` is the context-switch cost (ms) that the analysis charges and the simulator
    spends by default (docs/model/beyond.md). ``scheduler`` names the CPU's scheduling policy that
    the
    simulator uses by default (``fp``, ``edf``, or any policy of `rtsim.sim.policy`);
    priorities are required either way (under EDF they only break ties). ``resources`` is
    the protocol for tasks' critical sections (``pcp``, ``srp`` or ``npr``,
    docs/resources.md); None: the scheduler's default (`resource_protocol`).
    ``quantum`` (ms): the time slice of a time-sliced scheduler (``rr``); with one, tasks
    may share a priority (they keep the given order among themselves).
    """

    tasks: tuple[Task, ...]
    name: str = ""
    window: WindowSpec | None = None
    assumptions: Mapping[str, str] = field(default_factory=dict)
    source: str | None = None
    overhead: float = 0.0
    scheduler: str = "fp"
    resources: str | None = None
    quantum: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.scheduler, str) or not self.scheduler:
            raise TaskSetError(f"scheduler must be a policy name, got {self.scheduler!r}")
        if self.resources is not None and self.resources not in RESOURCE_PROTOCOLS:
            raise TaskSetError(
                f"resources must be one of {', '.join(RESOURCE_PROTOCOLS)}, got {self.resources!r}"
            )
        o = self.overhead
        if not is_real(o) or not math.isfinite(o) or o < 0:
            raise TaskSetError(f"overhead must be a non-negative number of ms, got {o!r}")
        object.__setattr__(self, "overhead", float(o))
        q = self.quantum
        if q is not None:
            if not is_real(q) or not math.isfinite(q) or q <= 0:
                raise TaskSetError(f"quantum must be a positive number of ms, got {q!r}")
            object.__setattr__(self, "quantum", float(q))
        tasks = tuple(sorted(self.tasks, key=lambda t: t.priority))
        object.__setattr__(self, "tasks", tasks)
        if not tasks and self.window is None:
            raise TaskSetError("task set has no tasks")
        names: dict[str, str] = {}
        prios: dict[int, str] = {}
        entries = [(t.name, t.priority) for t in tasks]
        if self.window is not None:
            entries.append((self.window.name, self.window.priority))
        for nm, pr in entries:
            if nm in names:
                raise TaskSetError(f"task '{nm}': duplicate task name")
            if pr in prios and self.quantum is None:
                raise TaskSetError(
                    f"task '{nm}': priority {pr} is already used by task '{prios[pr]}' "
                    f"(tasks share a priority only under a time-sliced policy: "
                    f'[scheduler] policy = "rr" with a quantum)'
                )
            names[nm] = nm
            prios[pr] = nm
        if self.window is None:
            for t in tasks:
                if t.per_window:
                    raise TaskSetError(
                        f"task '{t.name}': period is relative to w but the set has no [window]"
                    )

    # -- structure -------------------------------------------------------------------
    @property
    def hp(self) -> tuple[Task, ...]:
        """T_hp: tasks above the window's priority (all tasks when there is no window)."""
        if self.window is None:
            return self.tasks
        return tuple(t for t in self.tasks if t.priority < self.window.priority)

    @property
    def lp(self) -> tuple[Task, ...]:
        """T_lp: tasks below the window's priority."""
        if self.window is None:
            return ()
        return tuple(t for t in self.tasks if t.priority > self.window.priority)

    @property
    def has_sections(self) -> bool:
        """Whether some task has a critical section."""
        return any(t.resources for t in self.tasks)

    def resource_protocol(self, scheduler: str | None = None) -> str | None:
        """The resource protocol in force under ``scheduler`` (default the set's): the set's
        ``resources``, else ``srp`` under ``edf`` and ``pcp`` otherwise; None when no task
        has a critical section."""
        if not self.has_sections:
            return None
        if self.resources is not None:
            return self.resources
        return "srp" if (scheduler or self.scheduler) == "edf" else "pcp"

    def task(self, name: str) -> Task:
        """The task called ``name``."""
        for t in self.tasks:
            if t.name == name:
                return t
        raise KeyError(name)

    def with_window(self, **changes: Any) -> TaskSet:
        """A copy whose window constants are changed (e.g. ``n=5, r_H=30``)."""
        if self.window is None:
            raise TaskSetError(f"task set '{self.name}' has no [window]")
        return replace(self, window=self.window.with_(**changes))

    def window_task(self, w: float, e_hough_ms: float | None = None) -> Task:
        """The window chain as one task of period and deadline ``w`` and cost g (Eq 5), with
        the window's jitter and offset."""
        if self.window is None:
            raise TaskSetError(f"task set '{self.name}' has no [window]")
        key = (id(self), type(w), w, type(e_hough_ms), e_hough_ms)
        hit = _WINDOW_TASKS.get(key)
        if hit is not None and hit[0] is self:
            return hit[1]
        task = self._window_task(w, e_hough_ms)
        with _WINDOW_TASKS_LOCK:  # (points may run in threads: a Dask worker's)
            _WINDOW_TASKS[key] = (self, task)
            while len(_WINDOW_TASKS) > WINDOW_TASKS_KEPT:
                del _WINDOW_TASKS[next(iter(_WINDOW_TASKS))]
        return task

    def _window_task(self, w: float, e_hough_ms: float | None) -> Task:
        """`window_task`, made."""
        assert self.window is not None
        segs = self.window.segments(e_hough_ms)
        return Task(
            self.window.name,
            wcet=sum(s.wcet for s in segs),
            period=w,
            priority=self.window.priority,
            segments=segs,
            jitter=self.window.jitter,
            offset=self.window.offset,
        )

    def at_window(self, w: float, e_hough_ms: float | None = None) -> TaskSet:
        """A plain task set for a fixed window ``w``.

        The chain becomes one task of cost g; per-window periods are resolved.
        """
        if self.window is None:
            return self
        tasks = tuple(t.at_window(w) for t in self.tasks) + (self.window_task(w, e_hough_ms),)
        return replace(self, tasks=tasks, window=None)
