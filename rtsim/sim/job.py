"""Jobs and the CPU's per-task bookkeeping (internal to `rtsim.sim.cpu`)."""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np

from rtsim.model.task import Segment, Task
from rtsim.sim.records import TaskStats

__all__ = ["Job", "JobHook", "PeriodProvider", "SegmentHook"]

#: Hooks the CPU calls at a segment's start or end and at a job's end, and the callable that
#: gives a task's current period (a window chosen at run time).
SegmentHook = Callable[["Job", Segment], None]
JobHook = Callable[["Job"], None]
PeriodProvider = Callable[[], float]

#: Timer kinds, in their order at one instant (docs/cpu-events.md).
_RESUME, _ABORT, _RELEASE_W, _RELEASE = 0, 1, 2, 3
#: Timer kind of a jittered release (ordered by its task's release rank).
_JREL = 4
#: Timer kind and rank of the end of a time slice (after every release of its instant).
_SLICE = 5


class _Totals:
    """The CPU's running totals, which the dispatcher adds to at every job: in a slotted object
    of their own (the CPU has too many attributes for CPython's fast instance layout, and its
    attributes cost ≈ 6 % of `benchmarks/bench_sim.py` here)."""

    __slots__ = ("busy", "switches")

    def __init__(self) -> None:
        self.busy = 0.0  # CPU time given to jobs, overheads included (ms)
        self.switches = 0  # context switches


class Job:
    """One job: read its fields in hooks; only the CPU changes them.

    ``name`` is the task name, ``index`` counts releases from 0, ``arrival``/``release``/
    ``deadline`` are absolute (ms): the job arrives at offset + k·period, is released (ready)
    up to the task's jitter later, and its deadline counts from the arrival; ``held`` while
    arrived but not yet released. ``period`` is the period in force at the arrival.
    ``segment`` is the current segment, ``seg_exec`` its drawn execution time,
    ``start``/``finish`` are None until they happen. ``key``/``tie``: its place in the ready
    queue, set by the CPU's scheduling policy (`rtsim.sim.policy`) at creation.
    """

    __slots__ = (
        "_st",
        "task",
        "name",
        "priority",
        "index",
        "release",
        "deadline",
        "period",
        "seq",
        "seg_index",
        "rem",
        "seg_start",
        "seg_exec",
        "start",
        "finish",
        "preemptions",
        "aborted",
        "executed",
        "arrival",
        "held",
        "key",
        "tie",
        "blocked",
    )  # blocked: set only by a CPU with critical sections
    blocked: float  # time spent blocked (ms); unset until the job first is (critical sections)

    def __init__(
        self,
        st: _TaskState,
        index: int,
        release: float,
        deadline: float,
        period: float,
        seq: int,
        arrival: float | None = None,
    ) -> None:
        self._st = st
        self.task: Task = st.task
        self.name: str = st.name
        self.priority: int = st.priority
        self.index = index
        self.release = release
        self.deadline = deadline
        self.period = period
        self.seq = seq
        self.seg_index = 0
        self.rem: float | None = None
        self.seg_start: float | None = None
        self.seg_exec: float | None = None
        self.start: float | None = None
        self.finish: float | None = None
        self.preemptions = 0
        self.aborted = False
        self.executed = 0.0
        self.arrival = release if arrival is None else arrival
        self.held = False
        if st.by_priority:  # (FixedPriority.order, without its call)
            self.key, self.tie = st.priority, seq
        else:
            self.key, self.tie = st.order(self)

    @property
    def segment(self) -> Segment | None:
        """The current segment (None once the job has completed)."""
        segs = self._st.segs
        return segs[self.seg_index] if self.seg_index < len(segs) else None

    @property
    def response(self) -> float | None:
        """finish − arrival, once finished."""
        return None if self.finish is None else self.finish - self.arrival

    def __repr__(self) -> str:
        return f"Job({self.name}#{self.index}, release={self.release:g})"


class _TaskState:
    """Per-task bookkeeping of the CPU (internal)."""

    __slots__ = (
        "task",
        "name",
        "priority",
        "segs",
        "idle_kind",
        "offset",
        "period",
        "deadline",
        "provider",
        "per_window",
        "is_window",
        "rank",
        "k",
        "first",
        "next_release",
        "pending",
        "stats",
        "rng",
        "exec_fns",
        "const_exec",
        "start_hooks",
        "end_hooks",
        "release_hooks",
        "job_end_hooks",
        "policy",
        "simple",
        "fast_release",
        "fast_start",
        "fast_top",
        "seg_const",
        "plain_next",
        "hooked_next",
        "idle_next",
        "last_plain",
        "zero_tail",
        "index",
        "jitter",
        "jrng",
        "order",
        "by_priority",
        "stream_t",
        "stream_k",
        "stream_p",
        "res",
    )

    def __init__(self, task: Task, provider: PeriodProvider | None, is_window: bool) -> None:
        self.task = task
        self.name = task.name
        self.priority = task.priority
        self.segs: tuple[Segment, ...] = task.chain()
        self.idle_kind: list[bool] = []
        self.offset = task.offset
        self.period = task.period
        self.deadline: float = task.deadline  # type: ignore[assignment]
        self.provider = provider
        self.per_window = task.per_window
        self.is_window = is_window
        self.rank = _RELEASE_W if is_window else _RELEASE
        self.k = 0
        self.first = task.offset  # the first arrival, t0 + offset (CPU.start)
        self.next_release = task.offset
        self.pending: deque[Job] = deque()
        self.stats = TaskStats(task.name, task.priority)
        self.rng: np.random.Generator | None = None
        self.exec_fns: list[Callable[..., float]] = []
        self.const_exec: list[float | None] = []
        self.start_hooks: list[list[SegmentHook]] = []
        self.end_hooks: list[list[SegmentHook]] = []
        self.release_hooks: list[JobHook] = []
        self.job_end_hooks: list[JobHook] = []
        self.policy = task.overload
        self.simple = False  # one segment, constant time, no segment-end hooks
        self.fast_release = False  # fixed period, finish-late, no release hooks
        self.fast_start: float | None = None  # the constant time of a simple segment
        self.fast_top = False  # highest priority, fast release and start, no hooks at all
        self.seg_const: list[float | None] = []  # constant time of segment i, no start hooks
        self.plain_next: list[bool] = []  # segment i has no end hooks, i + 1 is a CPU segment
        # segment i's end hooks where i + 1 is a CPU segment (else None)
        self.hooked_next: list[list[SegmentHook] | None] = []
        self.idle_next: list[bool] = []  # segment i + 1 is an idle suspension (no empty step)
        self.last_plain: list[bool] = []  # segment i is the last, without end hooks
        # segment i > 0 and every one after it are empty (no time, no resource): run at once
        self.zero_tail: list[bool] = []
        self.index = 0  # the order in which the CPU got the task
        self.jitter = 0.0  # release jitter in force (0 under jitter="none")
        self.jrng: np.random.Generator | None = None  # release delays, own stream
        self.order: Callable[[Job], tuple[Any, Any]] = _unset_order  # the policy's (key, tie)
        self.by_priority = False  # the order is the fixed-priority one: (priority, seq)
        # a provided or per-window period: the arrival (and its index) where the period in
        # force, stream_p, started (cpu.CPU._release)
        self.stream_t = 0.0
        self.stream_k = 0
        self.stream_p = math.nan
        self.res: list[str | None] = []  # the resource segment i holds (critical sections)


def _unset_order(job: Job) -> tuple[Any, Any]:
    raise RuntimeError("a job was created before the CPU resolved its scheduling policy")
