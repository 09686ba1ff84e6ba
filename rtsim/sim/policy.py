"""Scheduling policies of the virtual CPU: the ready queue's order and the preemption test.

A policy is a specification (no engine, no SimPy); `rtsim.sim.cpu` applies it. The engine owns
time, the policy owns the order (as SimPy's ``PriorityResource`` changes only
its queue's sort key). The dispatcher of `rtsim.sim.cpu` keeps one ready heap of eligible
jobs (a task's oldest pending job, once released and not suspended), each entry
``(job.key, job.tie, job)``; a policy decides

- [`SchedulingPolicy.order`][rtsim.sim.policy.SchedulingPolicy.order]: the job's ``(key, tie)``,
computed once when the job is
  created (job-level static priorities: fixed priority, EDF, and any policy whose order of
  two jobs does not change while both wait). The smaller runs first; ``(key, tie)`` must be
  unique among eligible jobs (the heap never compares two jobs);
- [`SchedulingPolicy.preempts`][rtsim.sim.policy.SchedulingPolicy.preempts]: whether the first
eligible job (its ``key``) takes the
  CPU from the running job. The default, ``key < running.key``, is preemptive scheduling by
  the key; the dispatcher evaluates it inline unless a subclass overrides ``preempts``, and
  only then books jobs of the top task inline (`rtsim.sim.cpu`), checking that such a
  job comes first unless ``top_task_first`` promises it.

Registered policies (`SCHEDULERS`, a `Registry`: by name, by an
installed entry point of the group ``rtsim.schedulers``, or ``"package.module:Name"`` for a class
of one's own, see [`resolve_scheduler`][rtsim.sim.policy.resolve_scheduler]). Each entry carries its
analysis
(`SchedulingPolicy.analysis`, for ``rtsim analyze`` and the simulator's report) and the
window lower bounds that hold under it (`SchedulingPolicy.lower_bounds`, for
``[adjust] lower_bound``); a policy of one's own has neither unless it sets them (a subclass
does not inherit them: the analysis of preemptive FP says nothing of a non-preemptive one):

- ``fp``: fixed-priority preemptive. key = the task's priority (smaller = higher), tie = the
  job's creation sequence. ``top_task_first``: a job of the highest-priority task with no
  backlog always gets the CPU at its release.
- ``edf``: earliest deadline first, preemptive. key = the absolute deadline (from the
  arrival, ``arrival + D``), tie = the job's creation sequence, which is the order of
  arrivals and, at one instant, the order in which the CPU handles releases: the window task
  first, then by priority (for a set without a window: the task with the smaller priority
  number; the file's order when a set gives no priorities). So equal deadlines go to the job
  that arrived first, then by that task order. A running job is preempted only by a strictly
  earlier deadline: never by one with the same deadline. Deadlines are compared as floats,
  without a tolerance.

- ``rr``: POSIX ``SCHED_RR``, fixed priority across levels and round robin within one
  level, with a time slice ``quantum`` (ms; ``[scheduler] quantum``). key = the priority,
  tie = the sequence at which the job joined its level's queue: at its creation (jobs
  released together in the order the CPU handles releases: the file's task order among
  equal priorities), again when its slice ends while another job of its level is ready
  (it goes to the tail) and when it comes back from an idle suspension (the tail, a fresh
  slice). A job preempted by a higher level keeps its place at the head and the rest of
  its slice. Tasks may share a priority (the only built-in policy that allows it).

Time-sliced policies (`SchedulingPolicy.quantum` not None) get two more things from
the dispatcher: a timer at the end of the running job's slice, and
`SchedulingPolicy.requeue`, the job's new ``(key, tie)`` when its slice ends with
another job of its key ready (and when it resumes from a suspension).

A third policy is one class in one file (docs/scheduling.md shows a non-preemptive FP)::

    from rtsim.sim.policy import FixedPriority, register_scheduler

    @register_scheduler
    class NonPreemptiveFP(FixedPriority):
        name = "np-fp"

        def preempts(self, key, running):
            return False
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, ClassVar, TypeVar

from rtsim.analysis.edf import analyze_edf
from rtsim.analysis.rta import analyze
from rtsim.errors import InputError
from rtsim.registry import Registry

if TYPE_CHECKING:
    from rtsim.sim.job import Job

__all__ = [
    "SchedulingPolicy",
    "FixedPriority",
    "EarliestDeadlineFirst",
    "RoundRobin",
    "SCHEDULERS",
    "register_scheduler",
    "resolve_scheduler",
    "PolicySpec",
]


class SchedulingPolicy:
    """The ready queue's order and the preemption test of one CPU (module doc).

    Subclasses set `name` and implement `order`; override `preempts` for a
    test other than "strictly smaller key". The built-ins keep no state (one instance may serve
    several CPUs).
    """

    #: the name it is registered under (``--scheduler``, ``[scheduler] policy``)
    name: ClassVar[str] = ""
    #: a job of the highest-priority task always comes first and preempts (true of ``fp``
    #: only): the dispatcher's inline top-task path skips its check
    top_task_first: ClassVar[bool] = False
    #: the analysis of a task set under this policy, ``analysis(ts, w=None, *, overhead=None,
    #: suspension="cpu")`` returning a result with ``schedulable`` and per-task ``wcrt``; None:
    #: no analysis (not inherited)
    analysis: ClassVar[Callable[..., Any] | None] = None
    #: the window lower bounds (``[adjust] lower_bound``) that hold under this policy, the
    #: first its default (not inherited)
    lower_bounds: ClassVar[tuple[str, ...]] = ()
    #: how preemption levels of critical sections' protocols are ordered (docs/resources.md):
    #: ``"priority"`` (a smaller priority number is a higher level) or ``"deadline"`` (a
    #: shorter relative deadline is a higher level, as SRP under EDF)
    resource_levels: ClassVar[str] = "priority"
    #: tasks may share a priority (the policy orders the jobs of one level itself)
    shared_priorities: ClassVar[bool] = False
    #: whether the policy takes a time slice (``[scheduler] quantum``)
    takes_quantum: ClassVar[bool] = False
    #: the time slice (ms) of a time-sliced policy, None for one that is not (module doc)
    quantum: float | None = None

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "analysis" not in cls.__dict__:
            cls.analysis = None
        if "lower_bounds" not in cls.__dict__:
            cls.lower_bounds = ()

    def order(self, job: Job) -> tuple[Any, Any]:
        """``(key, tie)`` of a newly created job: its place in the ready heap."""
        raise NotImplementedError

    def preempts(self, key: Any, running: Job) -> bool:
        """Whether the first eligible job, of key ``key``, takes the CPU from ``running``."""
        return bool(key < running.key)

    def requeue(self, job: Job, seq: int) -> tuple[Any, Any]:
        """``(key, tie)`` of a job going to the tail of its key's queue (a time-sliced
        policy: its slice ended, or it resumed from a suspension); ``seq`` is larger than
        every tie given so far. Default: the same key, ``seq`` as the tie."""
        return job.key, seq

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


class FixedPriority(SchedulingPolicy):
    """Fixed-priority preemptive: key = task priority, tie = job creation order."""

    name = "fp"
    top_task_first = True
    analysis = staticmethod(analyze)
    lower_bounds = ("w_sch", "w_rta", "w_susp", "w_txn")

    def order(self, job: Job) -> tuple[int, int]:
        """(priority, sequence): the task priority; jobs of one task are FIFO anyway."""
        return job.priority, job.seq


class EarliestDeadlineFirst(SchedulingPolicy):
    """Preemptive EDF: key = absolute deadline, tie = job creation order (module doc)."""

    name = "edf"
    resource_levels = "deadline"
    analysis = staticmethod(analyze_edf)
    lower_bounds = ("w_edf",)

    def order(self, job: Job) -> tuple[float, int]:
        """(deadline, sequence): arrival order, then the release order of one instant."""
        return job.deadline, job.seq


class RoundRobin(FixedPriority):
    """POSIX ``SCHED_RR`` (module doc): fixed priority across levels, round robin with a
    time slice of ``quantum`` ms within one level."""

    name = "rr"
    top_task_first = False
    shared_priorities = True
    takes_quantum = True

    def __init__(self, quantum: float | None = None) -> None:
        if quantum is not None and not (
            isinstance(quantum, int | float)
            and not isinstance(quantum, bool)
            and math.isfinite(quantum)
            and quantum > 0
        ):
            raise InputError(f"quantum must be a positive number of ms, got {quantum!r}")
        self.quantum = None if quantum is None else float(quantum)

    def __repr__(self) -> str:
        return f"RoundRobin(quantum={self.quantum!r})"


P = TypeVar("P", bound=type[SchedulingPolicy])


def _policy_class(obj: Any, spec: str, where: str) -> type[SchedulingPolicy]:
    if isinstance(obj, type) and issubclass(obj, SchedulingPolicy):
        if obj.order is SchedulingPolicy.order:  # the base itself, or a class without it
            raise InputError(
                f"{where} does not implement order(job); give a subclass of "
                f"SchedulingPolicy that does"
            )
        return obj
    raise InputError(f"{where} is not a SchedulingPolicy subclass")


#: The registered scheduling policies by name (a `Registry` of classes;
#: entry-point group ``rtsim.schedulers``).
SCHEDULERS: Registry[type[SchedulingPolicy]] = Registry(
    "scheduling policy", "rtsim.schedulers", _policy_class
)


def register_scheduler(cls: P) -> P:
    """Register a policy class under its ``name`` (usable as a decorator); replaces one of
    the same name."""
    if not (isinstance(cls, type) and issubclass(cls, SchedulingPolicy)):
        raise TypeError(f"register_scheduler: need a SchedulingPolicy subclass, got {cls!r}")
    if not isinstance(cls.name, str) or not cls.name:
        raise TypeError(f"register_scheduler: {cls.__name__}.name must be a non-empty string")
    SCHEDULERS.register(cls.name, cls)
    return cls


register_scheduler(FixedPriority)
register_scheduler(EarliestDeadlineFirst)
register_scheduler(RoundRobin)

#: What [`resolve_scheduler`][rtsim.sim.policy.resolve_scheduler] accepts.
PolicySpec = str | SchedulingPolicy | type[SchedulingPolicy]


def resolve_scheduler(
    spec: PolicySpec, where: str = "scheduler", *, allow_code: bool | None = None
) -> SchedulingPolicy:
    """A policy instance from a registered name, an entry point, ``"package.module:Name"``
    (code: `rtsim.registry.load_code`), a class or an instance; an unknown name is an
    `InputError` naming ``where``."""
    if isinstance(spec, SchedulingPolicy):
        return spec
    if isinstance(spec, type) and issubclass(spec, SchedulingPolicy):
        return spec()
    return SCHEDULERS.resolve(spec, where, allow_code=allow_code)()


#: Deprecated aliases (the CPU's policies were once called "policies", as adjustment policies
#: still are): use `SCHEDULERS`, [`register_scheduler`][rtsim.sim.policy.register_scheduler],
#: [`resolve_scheduler`][rtsim.sim.policy.resolve_scheduler].
