"""Time slices of a time-sliced scheduling policy (``rr``): a room of the virtual CPU.

The dispatcher (`rtsim.sim.cpu`) calls in here only when its policy has a
``quantum`` (docs/cpu-events.md: Time slices; docs/scheduling.md: Round robin). When a job
gets the CPU its slice starts — the rest of its slice if a higher level preempted it
before, else ``quantum`` ms — and a timer of kind ``_SLICE`` is set at its end, ranked after
every release of that instant. At the timer the running job goes to the tail of its key
(`requeue`) if another job of its key is ready,
else it gets a new slice without a switch.
"""

from __future__ import annotations

import copy
import heapq
import math
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

from rtsim.errors import InputError
from rtsim.sim.job import _SLICE, Job
from rtsim.sim.policy import SchedulingPolicy

__all__ = ["TimeSlices", "with_quantum"]


def with_quantum(policy: SchedulingPolicy, quantum: float | None) -> SchedulingPolicy:
    """``policy`` with the time slice ``quantum`` (ms); a time-sliced policy needs one and
    only such a policy takes one (a copy: the caller's instance is left as it is)."""
    name = policy.name or type(policy).__name__
    if quantum is not None:
        if not policy.takes_quantum:
            raise InputError(f"quantum: the {name} policy is not time-sliced (rr is)")
        if not (
            isinstance(quantum, int | float)
            and not isinstance(quantum, bool)
            and math.isfinite(quantum)
            and quantum > 0
        ):
            raise InputError(f"quantum must be a positive number of ms, got {quantum!r}")
        policy = copy.copy(policy)
        policy.quantum = float(quantum)
    if policy.takes_quantum and policy.quantum is None:
        raise InputError(f"the {name} policy needs a time slice: [scheduler] quantum (ms)")
    return policy


class TimeSlices:
    """The CPU's time slices (module doc); a mixin of `rtsim.sim.cpu.CPU`."""

    policy: SchedulingPolicy
    quantum: float | None
    _timers: list[tuple[Any, ...]]
    _ready: list[tuple[Any, Any, Job]]
    _seq: Iterator[int]

    if TYPE_CHECKING:

        def _preempt(
            self,
            job: Job,
            now: float,
            now_lag: float,
            piece_start: float,
            work_start: float,
            work_lag: float,
        ) -> None: ...

    def _init_slices(self) -> None:
        self._slice_left: dict[Job, float] = {}  # a preempted job's rest of its slice
        self._slice_job: Job | None = None  # the job whose slice runs
        self._slice_end = 0.0
        self._slice_seq = -1  # its timer's sequence number (an older timer is stale)

    def _new_slice(self, running: Job | None, now: float) -> float:
        """``running`` got the CPU at ``now`` (or nothing runs): the job whose slice ran
        keeps the rest of it if it was preempted; ``running``'s slice starts. Returns the
        next timer's time (inf: none)."""
        old = self._slice_job
        if old is not None and old.finish is None and not old.aborted:
            self._slice_left[old] = self._slice_end - now
        self._slice_job = running
        if running is not None:
            assert self.quantum is not None
            self._arm_slice(running, now + self._slice_left.pop(running, self.quantum))
        return self._timers[0][0] if self._timers else math.inf

    def _arm_slice(self, running: Job, end: float) -> None:
        """``running``'s slice ends at ``end``: its timer (an older one becomes stale)."""
        self._slice_end = end
        self._slice_seq = next(self._seq)
        heapq.heappush(self._timers, (end, _SLICE, 0, self._slice_seq, _SLICE, running))

    def _slice_ends(
        self,
        entry: tuple[Any, ...],
        running: Job | None,
        now: float,
        now_lag: float,
        piece_start: float,
        work_start: float,
        work_lag: float,
    ) -> bool:
        """A slice timer is due: True if ``running`` goes to the tail of its key (it leaves
        the CPU); a stale timer, or a job alone at its key (a new slice), give False."""
        if entry[5] is not running or entry[3] != self._slice_seq:
            return False  # the slice of a job that has left the CPU
        assert running is not None
        key = running.key
        if any(e[0] == key and not e[2].aborted for e in self._ready):
            running.key, running.tie = self.policy.requeue(running, next(self._seq))
            self._preempt(running, now, now_lag, piece_start, work_start, work_lag)
            self._slice_job = None
            return True
        self._arm_slice(running, now + self.quantum)  # type: ignore[operator]
        return False

    def _requeue_resumed(self, job: Job) -> None:
        """``job`` is back from an idle suspension: the tail of its key, a fresh slice."""
        self._slice_left.pop(job, None)
        job.key, job.tie = self.policy.requeue(job, next(self._seq))
