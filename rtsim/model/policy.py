"""Scheduling policies of the virtual CPU: the ready queue's order and the preemption test.

A policy is a specification (no engine, no SimPy: task-set files are checked against the
registry without loading the simulator); :mod:`rtsim.sim.cpu` applies it. The engine owns
time, the policy owns the order (as SimPy's ``PriorityResource`` changes only
its queue's sort key). The dispatcher of :mod:`rtsim.sim.cpu` keeps one ready heap of eligible
jobs (a task's oldest pending job, once released and not suspended), each entry
``(job.key, job.tie, job)``; a policy decides

- :meth:`SchedulingPolicy.order`: the job's ``(key, tie)``, computed once when the job is
  created (job-level static priorities: fixed priority, EDF, and any policy whose order of
  two jobs does not change while both wait). The smaller runs first; ``(key, tie)`` must be
  unique among eligible jobs (the heap never compares two jobs);
- :meth:`SchedulingPolicy.preempts`: whether the first eligible job (its ``key``) takes the
  CPU from the running job. The default, ``key < running.key``, is preemptive scheduling by
  the key; the dispatcher evaluates it inline unless a subclass overrides ``preempts``, and
  only then books jobs of the top task inline (:mod:`rtsim.sim.cpu`), checking that such a
  job comes first unless ``top_task_first`` promises it.

Registered policies (:data:`POLICIES`, by name; ``"package.module:Name"`` for a class of
one's own, see :func:`resolve_policy`):

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

A third policy is one class in one file (docs/scheduling.md shows a non-preemptive FP)::

    from rtsim.model.policy import FixedPriority, register_policy

    @register_policy
    class NonPreemptiveFP(FixedPriority):
        name = "np-fp"

        def preempts(self, key, running):
            return False
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any, ClassVar, TypeVar

from rtsim.errors import InputError

if TYPE_CHECKING:
    from rtsim.sim.job import Job

__all__ = ["SchedulingPolicy", "FixedPriority", "EarliestDeadlineFirst", "POLICIES",
           "SCHEDULERS", "register_policy", "resolve_policy", "PolicySpec"]


class SchedulingPolicy:
    """The ready queue's order and the preemption test of one CPU (module doc).

    Subclasses set :attr:`name` and implement :meth:`order`; override :meth:`preempts` for a
    test other than "strictly smaller key". The built-ins keep no state (one instance may serve
    several CPUs).
    """

    #: the name it is registered under (``--scheduler``, ``[scheduler] policy``)
    name: ClassVar[str] = ""
    #: a job of the highest-priority task always comes first and preempts (true of ``fp``
    #: only): the dispatcher's inline top-task path skips its check
    top_task_first: ClassVar[bool] = False

    def order(self, job: Job) -> tuple[Any, Any]:
        """``(key, tie)`` of a newly created job: its place in the ready heap."""
        raise NotImplementedError

    def preempts(self, key: Any, running: Job) -> bool:
        """Whether the first eligible job, of key ``key``, takes the CPU from ``running``."""
        return bool(key < running.key)

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


class FixedPriority(SchedulingPolicy):
    """Fixed-priority preemptive: key = task priority, tie = job creation order."""

    name = "fp"
    top_task_first = True

    def order(self, job: Job) -> tuple[int, int]:
        """(priority, sequence): the task priority; jobs of one task are FIFO anyway."""
        return job.priority, job.seq


class EarliestDeadlineFirst(SchedulingPolicy):
    """Preemptive EDF: key = absolute deadline, tie = job creation order (module doc)."""

    name = "edf"

    def order(self, job: Job) -> tuple[float, int]:
        """(deadline, sequence): arrival order, then the release order of one instant."""
        return job.deadline, job.seq


P = TypeVar("P", bound=type[SchedulingPolicy])

#: The registered policies by name.
POLICIES: dict[str, type[SchedulingPolicy]] = {}


def register_policy(cls: P) -> P:
    """Register a policy class under its ``name`` (usable as a decorator); replaces one of
    the same name."""
    if not (isinstance(cls, type) and issubclass(cls, SchedulingPolicy)):
        raise TypeError(f"register_policy: need a SchedulingPolicy subclass, got {cls!r}")
    if not isinstance(cls.name, str) or not cls.name:
        raise TypeError(f"register_policy: {cls.__name__}.name must be a non-empty string")
    POLICIES[cls.name] = cls
    return cls


register_policy(FixedPriority)
register_policy(EarliestDeadlineFirst)

#: The names of the built-in policies (the command line's documented choices).
SCHEDULERS: tuple[str, ...] = ("fp", "edf")

#: What :func:`resolve_policy` accepts.
PolicySpec = str | SchedulingPolicy | type[SchedulingPolicy]


def resolve_policy(spec: PolicySpec, where: str = "scheduler") -> SchedulingPolicy:
    """A policy instance from a registered name, ``"package.module:Name"``, a class or an
    instance; an unknown name is an :class:`InputError` naming ``where``."""
    if isinstance(spec, SchedulingPolicy):
        return spec
    if isinstance(spec, type) and issubclass(spec, SchedulingPolicy):
        return spec()
    if not isinstance(spec, str):
        raise InputError(f"{where}: must be a policy name, got {spec!r}")
    if spec in POLICIES:
        return POLICIES[spec]()
    if ":" in spec:
        mod, _, attr = spec.partition(":")
        try:
            obj = getattr(importlib.import_module(mod), attr)
        except (ImportError, AttributeError) as exc:
            raise InputError(f"{where}: cannot load policy {spec!r}: {exc}") from None
        if isinstance(obj, type) and issubclass(obj, SchedulingPolicy):
            if obj.order is SchedulingPolicy.order:  # the base itself, or a class without it
                raise InputError(f"{where}: {spec!r} does not implement order(job); give a "
                                 f"subclass of SchedulingPolicy that does")
            return obj()
        raise InputError(f"{where}: {spec!r} is not a SchedulingPolicy subclass")
    raise InputError(f"{where}: unknown scheduling policy {spec!r} (registered: "
                     f"{', '.join(sorted(POLICIES))}; or package.module:Name)")
