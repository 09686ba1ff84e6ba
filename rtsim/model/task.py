"""Periodic tasks and the segments of a processing-window chain (specs, no engine).

Times are in milliseconds. Priorities are integers; a smaller number is a higher priority.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal

from rtsim._numbers import is_int, is_real
from rtsim.errors import TaskSetError

__all__ = [
    "Task",
    "Segment",
    "SegmentKind",
    "OverloadPolicy",
    "OVERLOAD_POLICIES",
    "CriticalSection",
    "RESOURCE_PROTOCOLS",
    "ResourceProtocol",
]

SegmentKind = Literal["compute", "suspend"]
OverloadPolicy = Literal["finish-late", "abort", "skip"]
OVERLOAD_POLICIES: tuple[str, ...] = ("finish-late", "abort", "skip")
ResourceProtocol = Literal["pcp", "srp", "npr"]
#: Resource access protocols (docs/resources.md): the immediate priority ceiling protocol,
#: the stack resource policy, non-preemptive critical sections.
RESOURCE_PROTOCOLS: tuple[str, ...] = ("pcp", "srp", "npr")


def check_time(where: str, field: str, value: object, *, allow_zero: bool = False) -> float:
    """Return ``value`` as a float if it is a finite positive (or non-negative) number.

    Raises `TaskSetError` naming ``where`` and ``field`` otherwise.
    """
    if not is_real(value):
        raise TaskSetError(f"{where}: {field} must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise TaskSetError(f"{where}: {field} must be finite, got {value!r}")
    if v < 0 or (v == 0 and not allow_zero):
        bound = "non-negative" if allow_zero else "positive"
        raise TaskSetError(f"{where}: {field} must be {bound}, got {value!r}")
    return v


@dataclass(frozen=True)
class Segment:
    """One step of a job's chain.

    A ``compute`` segment needs the CPU and can be preempted; a ``suspend`` segment (the
    radio round trip Δt) leaves the CPU free, unless the simulator is told to count
    suspensions as CPU time (the paper's suspension-oblivious view).

    ``role`` names what the step does (``scan``, ``hough``, ``estimate``, ``send``,
    ``radio``, ``recv``, ``sched`` for the paper's chain; anything for user chains) and
    ``follower`` is the 1-based follower a per-follower step serves.
    """

    name: str
    wcet: float
    kind: SegmentKind = "compute"
    bcet: float | None = None
    role: str = ""
    follower: int | None = None
    resource: str | None = None

    def __post_init__(self) -> None:
        where = f"segment '{self.name}'"
        object.__setattr__(self, "wcet", check_time(where, "wcet", self.wcet, allow_zero=True))
        if self.kind not in ("compute", "suspend"):
            raise TaskSetError(f"{where}: kind must be 'compute' or 'suspend', got {self.kind!r}")
        if self.resource is not None:
            if not isinstance(self.resource, str) or not self.resource:
                raise TaskSetError(
                    f"{where}: resource must be a non-empty string, got {self.resource!r}"
                )
            if self.kind != "compute":
                raise TaskSetError(f"{where}: a suspension cannot hold a resource")
        if self.bcet is not None:
            bcet = check_time(where, "bcet", self.bcet, allow_zero=True)
            if bcet > self.wcet:
                raise TaskSetError(f"{where}: bcet {bcet:g} is above wcet {self.wcet:g}")
            object.__setattr__(self, "bcet", bcet)


@dataclass(frozen=True)
class CriticalSection:
    """A stretch of a job's execution that holds the shared ``resource`` exclusively.

    ``start``: the execution time (ms) the job has consumed when the section begins;
    ``length``: how long it holds the resource (ms of execution). Sections of one task do not
    overlap or nest; the task's resource protocol (``[scheduler] resources``,
    docs/resources.md) decides how jobs wait for it.
    """

    resource: str
    start: float
    length: float

    def __post_init__(self) -> None:
        if not isinstance(self.resource, str) or not self.resource.strip():
            raise TaskSetError(
                f"critical section: resource: must be a non-empty string, got {self.resource!r}"
            )
        where = f"critical section on '{self.resource}'"
        object.__setattr__(self, "start", check_time(where, "start", self.start, allow_zero=True))
        object.__setattr__(self, "length", check_time(where, "length", self.length))

    @property
    def end(self) -> float:
        """start + length: the execution time consumed when the section ends."""
        return self.start + self.length


@dataclass(frozen=True)
class Task:
    """A periodic task: validated, immutable.

    ``period`` and ``deadline`` are in ms, or, when ``per_window`` is true, multiples of
    the processing window w (the paper's command task has period 2w: ``period=2,
    per_window=True``). ``deadline`` defaults to the period. ``segments`` is empty for
    an ordinary task (one compute segment of ``wcet``); for a chain its compute and
    suspension segments add up to ``wcet``. ``jitter`` J (ms, docs/model/beyond.md): job k
    *arrives* at
    offset + k·period and is released (ready) in [arrival, arrival + J]; its deadline and
    response time count from the arrival.
    """

    name: str
    wcet: float
    period: float
    deadline: float | None = None
    priority: int = 0
    offset: float = 0.0
    bcet: float | None = None
    per_window: bool = False
    overload: OverloadPolicy = "finish-late"
    segments: tuple[Segment, ...] = ()
    jitter: float = 0.0
    critical_sections: tuple[CriticalSection, ...] = ()

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise TaskSetError(f"task {self.name!r}: name must be a non-empty string")
        where = f"task '{self.name}'"
        set_ = object.__setattr__
        set_(self, "wcet", check_time(where, "wcet", self.wcet))
        set_(self, "period", check_time(where, "period", self.period))
        deadline = self.period if self.deadline is None else self.deadline
        set_(self, "deadline", check_time(where, "deadline", deadline))
        if not is_int(self.priority):
            raise TaskSetError(f"{where}: priority must be an integer, got {self.priority!r}")
        set_(self, "priority", int(self.priority))
        set_(self, "offset", check_time(where, "offset", self.offset, allow_zero=True))
        set_(self, "jitter", check_time(where, "jitter", self.jitter, allow_zero=True))
        if self.bcet is not None:
            bcet = check_time(where, "bcet", self.bcet, allow_zero=True)
            if bcet > self.wcet:
                raise TaskSetError(f"{where}: bcet {bcet:g} is above wcet {self.wcet:g}")
            set_(self, "bcet", bcet)
        if self.overload not in OVERLOAD_POLICIES:
            raise TaskSetError(
                f"{where}: overload must be one of {', '.join(OVERLOAD_POLICIES)}, "
                f"got {self.overload!r}"
            )
        if self.segments:
            total = sum(s.wcet for s in self.segments)
            if not math.isclose(total, self.wcet, rel_tol=1e-12, abs_tol=1e-12):
                raise TaskSetError(
                    f"{where}: segments add up to {total:g} ms but wcet is {self.wcet:g}"
                )
        if self.critical_sections:
            self._check_sections(where)

    def _check_sections(self, where: str) -> None:
        secs = tuple(self.critical_sections)
        object.__setattr__(self, "critical_sections", secs)
        if self.segments:
            raise TaskSetError(
                f"{where}: critical_sections: only for a task without its own "
                f"segments (mark a chain's segments with a resource instead)"
            )
        prev: CriticalSection | None = None
        for cs in secs:
            if not isinstance(cs, CriticalSection):
                raise TaskSetError(
                    f"{where}: critical_sections: need CriticalSection entries, got {cs!r}"
                )
            if cs.start >= self.wcet:
                raise TaskSetError(
                    f"{where}: critical_sections: the section on '{cs.resource}' starts at "
                    f"{cs.start:g} ms of execution, but the wcet is {self.wcet:g} ms (no "
                    f"execution left)"
                )
            if cs.end > self.wcet * (1 + 1e-12):
                raise TaskSetError(
                    f"{where}: critical_sections: the section on '{cs.resource}' ends at "
                    f"{cs.end:g} ms of execution, beyond the wcet {self.wcet:g} ms"
                )
            if prev is not None and cs.start < prev.end * (1 - 1e-12):
                raise TaskSetError(
                    f"{where}: critical_sections: the section on '{cs.resource}' (from "
                    f"{cs.start:g} ms) overlaps the one on '{prev.resource}' (to "
                    f"{prev.end:g} ms): give them in order, not overlapping"
                )
            prev = cs

    @property
    def utilization(self) -> float:
        """e/p (only meaningful for a task whose period is in ms)."""
        if self.per_window:
            raise TaskSetError(f"task '{self.name}': period is relative to w; resolve it first")
        return self.wcet / self.period

    def at_window(self, w: float) -> Task:
        """This task with its period and deadline in ms for window ``w`` (itself if fixed)."""
        if not self.per_window:
            return self
        assert self.deadline is not None
        return replace(self, period=self.period * w, deadline=self.deadline * w, per_window=False)

    def chain(self) -> tuple[Segment, ...]:
        """The task's segments: its own chain, or one compute segment of ``wcet``."""
        if self.segments:
            return self.segments
        if self.critical_sections:
            return self._section_chain()
        return (Segment(self.name, self.wcet, "compute", self.bcet, role=self.name),)

    def _section_chain(self) -> tuple[Segment, ...]:
        """The job split at its sections' ends: plain pieces named after the task, sections
        ``<task>[<resource>]`` (role: the task's name); each piece's bcet is the task's bcet
        in proportion to its length."""
        ratio = None if self.bcet is None else self.bcet / self.wcet
        segs: list[Segment] = []

        def piece(name: str, length: float, resource: str | None) -> None:
            length = max(length, 0.0)
            bcet = None if ratio is None else length * ratio
            segs.append(Segment(name, length, "compute", bcet, role=self.name, resource=resource))

        at = 0.0
        for cs in self.critical_sections:
            if cs.start > at:
                piece(self.name, cs.start - at, None)
            end = min(cs.end, self.wcet)
            piece(
                f"{self.name}[{cs.resource}]",
                cs.length if cs.end <= self.wcet else end - cs.start,
                cs.resource,
            )
            at = end
        if at < self.wcet:
            piece(self.name, self.wcet - at, None)
        return tuple(segs)

    @property
    def resources(self) -> frozenset[str]:
        """The shared resources the task's jobs lock (its chain's marked segments)."""
        return frozenset(s.resource for s in self.chain() if s.resource is not None)
