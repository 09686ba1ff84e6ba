"""Scheduling policies of the virtual CPU: the ready queue's order and the preemption test.

A policy is a specification (no engine, no SimPy) that `rtsim.sim.cpu` applies: `order` gives
a job's ``(key, tie)`` once at its creation, `preempts` decides whether the first eligible job
takes the CPU, and a time-sliced policy adds `quantum` and `requeue`. Built in and registered
in `SCHEDULERS` (see `resolve_scheduler`): ``fp``, ``edf``, ``rr``, each with its analysis and
window lower bounds. The specification, the table of keys and ties and a policy of one's own
in one file: docs/scheduling.md.
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
