"""Exact response-time analysis for fixed-priority preemptive scheduling on one CPU.

The least fixed point R = e_i + Σ_hp ⌈R/p_j⌉·e_j (Joseph & Pandya 1986; Audsley et al. 1993),
with the level-i busy window for deadlines beyond the period, release jitter
w_i(q) = (q+1)·C_i + Σ_hp ⌈(w_i(q) + J_j)/T_j⌉·C_j, R_i = J_i + max_q (w_i(q) − q·T_i)
(Tindell, Burns & Wellings 1994), overhead 2·o per higher and o per own compute stretch, and
ceilings ⌈(x − ε)/p⌉ with ε = 1e-9 ms: docs/model/beyond.md. A processing-window set is
analysed at a fixed w with Δt as CPU time
([`TaskSet.at_window`][rtsim.model.taskset.TaskSet.at_window]).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from typing import TYPE_CHECKING, Any

from rtsim._numbers import is_real
from rtsim.analysis import utilization as util
from rtsim.analysis.blocking import check_protocol, fp_blocking
from rtsim.analysis.common import (
    CEIL_TOL,
    DEADLINE_TOL,
    busy_window,
    ceil_div,
    stretches,
)
from rtsim.analysis.sufficient import as_taskset, window_or_w_sch
from rtsim.analysis.suspension import suspension_aware
from rtsim.errors import TaskSetError
from rtsim.model.task import Task

if TYPE_CHECKING:  # the model package imports rtsim.analysis: no runtime import of it here
    from rtsim.model.taskset import TaskSet

__all__ = [
    "Analysis",
    "TaskResult",
    "analyze",
    "analysis_inputs",
    "suspends_with_sections",
    "busy_window",
    "ceil_div",
    "response_time",
    "stretches",
    "CEIL_TOL",
    "DEADLINE_TOL",
]


def _check_resolved(task: Task) -> None:
    if task.per_window:
        raise TaskSetError(
            f"task '{task.name}': period is a multiple of w; resolve it with at_window(w) first"
        )


def response_time(
    task: Task, higher: Sequence[Task], overhead: float = 0.0, blocking: float = 0.0
) -> float | None:
    """Worst-case response time of ``task`` below the tasks ``higher`` (ms, from arrival).

    Exact for independent tasks without offsets (release jitter, arbitrary deadlines; see
    [`busy_window`][rtsim.analysis.rta.busy_window]), with the context-switch ``overhead`` charged
    as in the module doc.
    Returns ``None`` as soon as a response passes the task's deadline (not schedulable); at
    once when the level-i utilization exceeds 1 and the busy window cannot close; and if a
    level-i busy period has not closed after ``MAX_BUSY_JOBS`` jobs (only possible at a
    level-i utilization of 1 up to rounding with a huge hyperperiod). Near utilization 1 a
    D > p busy period can be long, and the analysis slow (seconds). ``blocking``: the task's
    blocking term B (ms,
    [`rtsim.analysis.blocking.fp_blocking`][rtsim.analysis.blocking.fp_blocking]), charged once.
    """
    _check_resolved(task)
    for t in higher:
        _check_resolved(t)
    o = float(overhead)
    deadline = task.period if task.deadline is None else task.deadline
    c = task.wcet + o * stretches(task) if o else task.wcet
    hp = [(t.wcet + 2.0 * o * stretches(t) if o else t.wcet, t.period, t.jitter) for t in higher]
    return busy_window(c, task.period, task.jitter, deadline, hp, blocking)


@dataclass(frozen=True)
class TaskResult:
    """One task's verdict: its parameters at the analysed window and its WCRT (ms)."""

    name: str
    priority: int
    wcet: float
    period: float
    deadline: float
    utilization: float
    wcrt: float | None
    schedulable: bool
    blocking: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        """Plain dict (``wcrt`` is ``None`` where the iteration passed the deadline;
        ``blocking``: the blocking term B included in it, ms)."""
        return asdict(self)


@dataclass(frozen=True)
class Analysis:
    """The exact analysis of a task set, with the utilization tests beside it.

    ``w`` is the processing window the set was analysed at (``None`` without a window).
    ``liu_layland`` and ``hyperbolic`` are ``False`` where those tests do not apply (see
    `rtsim.analysis.utilization`); ``schedulable`` is the exact verdict. ``overhead`` is
    the context-switch cost charged (ms); ``offsets_ignored`` says that some task has an
    offset, which the analysis ignores (sound, possibly pessimistic). ``suspension`` is
    ``"cpu"`` (suspensions counted as computation), ``"idle"`` (suspension-aware,
    `rtsim.analysis.suspension`) or ``"either"`` (each task the larger of the two:
    [`analyze`][rtsim.analysis.rta.analyze]'s default for a set that suspends and has critical
    sections). ``transaction``: each task's offset-based (transaction) bound (ms from
    arrival) where it was computed
    (`rtsim.analysis.transaction.with_transaction_bounds`);
    None: not computed.
    """

    tasks: tuple[TaskResult, ...]
    utilization: float
    liu_layland: bool
    hyperbolic: bool
    schedulable: bool
    w: float | None = None
    name: str = ""
    overhead: float = 0.0
    offsets_ignored: bool = False
    suspension: str = "cpu"
    resources: str | None = None
    transaction: Mapping[str, float | None] | None = None

    @property
    def rm_implicit(self) -> bool:
        """Whether the utilization tests apply (implicit deadlines, RM priorities)."""
        return util.rm_implicit(self.tasks)

    @property
    def liu_layland_bound(self) -> float:
        """n(2^{1/n} − 1) for this set's n."""
        return util.liu_layland_bound(len(self.tasks))

    @property
    def hyperbolic_product(self) -> float:
        """Π(U_i + 1) for this set."""
        return util.hyperbolic_product(self.tasks)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict: ``tasks`` (list), totals, the utilization tests, the verdict."""
        tasks = [t.as_dict() for t in self.tasks]
        if self.transaction is not None:  # ms from arrival; None: passes the deadline
            for entry in tasks:
                entry["wcrt_transaction"] = self.transaction.get(entry["name"])
        return {
            "name": self.name,
            "w": self.w,
            "tasks": tasks,
            "utilization": self.utilization,
            "rm_implicit": self.rm_implicit,
            "liu_layland": self.liu_layland,
            "liu_layland_bound": self.liu_layland_bound,
            "hyperbolic": self.hyperbolic,
            "hyperbolic_product": self.hyperbolic_product,
            "schedulable": self.schedulable,
            "overhead": self.overhead,
            "offsets_ignored": self.offsets_ignored,
            "suspension": self.suspension,
            "resources": self.resources,
        }


def analysis_inputs(
    ts: TaskSet, w: float | None, overhead: float | None, suspension: str, caller: str
) -> tuple[TaskSet, float | None, float, tuple[Task, ...]]:
    """The checked inputs of an analysis of ``ts`` (a TaskSet or a task-set path): the set,
    the window w (default the analytic w_sch for a set with a ``[window]``), the overhead
    (default the set's) and the tasks to analyse (the window chain as one task at w)."""
    ts = as_taskset(ts, caller)
    label = ts.source or ts.name or "task set"
    if overhead is None:
        overhead = ts.overhead
    if suspension not in ("cpu", "idle"):
        raise TaskSetError(f"suspension must be 'cpu' or 'idle', got {suspension!r}")
    if not is_real(overhead) or not math.isfinite(overhead) or overhead < 0:
        raise TaskSetError(
            f"{label}: overhead must be a non-negative number of ms, got {overhead!r}"
        )
    if ts.window is None:
        if w is not None:
            raise TaskSetError(f"{label}: has no [window], so a window w does not apply")
        tasks = ts.tasks
    else:
        w = window_or_w_sch(ts, w)
        tasks = ts.at_window(w).tasks
    return ts, w, overhead, tuple(tasks)


def suspends_with_sections(ts: TaskSet, tasks: Sequence[Task]) -> bool:
    """Whether ``ts`` has critical sections and some of ``tasks`` (its analysed tasks, the
    window chain among them) a suspension: then only the suspension-aware analysis charges
    the blocking a suspension lets in ([`analyze`][rtsim.analysis.rta.analyze])."""
    return ts.has_sections and any(seg.kind == "suspend" for t in tasks for seg in t.chain())


def _either(cpu: Analysis, idle: Analysis) -> Analysis:
    """Each task's larger bound of the two analyses (None where either has none)."""
    tasks = []
    for a, b in zip(cpu.tasks, idle.tasks, strict=True):
        r = None if a.wcrt is None or b.wcrt is None else max(a.wcrt, b.wcrt)
        tasks.append(
            replace(a, wcrt=r, schedulable=r is not None, blocking=max(a.blocking, b.blocking))
        )
    return replace(
        cpu,
        tasks=tuple(tasks),
        schedulable=all(t.schedulable for t in tasks),
        suspension="either",
    )


def analyze(
    ts: TaskSet,
    w: float | None = None,
    *,
    overhead: float | None = None,
    suspension: str | None = None,
    resources: str | None = None,
) -> Analysis:
    """Exact response-time analysis of every task of ``ts`` (with jitter; ``overhead`` in ms,
    default the set's ``overhead``). ``suspension="idle"``: suspensions leave the CPU free and
    each task takes the smaller of its sound suspension-aware bounds
    ([`rtsim.analysis.suspension.suspension_aware`][rtsim.analysis.suspension.suspension_aware]);
    ``"cpu"``: they count as computation.
    Default (None): sound whichever the simulator runs. Counting a suspension as computation
    is sound for both unless a set with critical sections also suspends (a job can then be
    blocked once per compute stretch, which ``"cpu"`` does not charge): such a set gets each
    task's larger bound of the two (``suspension="either"`` in the result); any other ``"cpu"``.

    A set with a ``[window]`` is analysed at window ``w`` (default: the analytic w_sch of
    [`rtsim.analysis.bounds.w_sch_of`][rtsim.analysis.bounds.w_sch_of]), the chain as one task of
    cost g with period
    and deadline w, per-window periods resolved. ``w`` is an error for a set without one.

    Critical sections: each task's blocking term B
    ([`rtsim.analysis.blocking.fp_blocking`][rtsim.analysis.blocking.fp_blocking])
    under ``resources`` (``pcp``, ``srp``, ``npr``; default the set's protocol,
    [`resource_protocol`][rtsim.model.taskset.TaskSet.resource_protocol]) is part of its response
    time, once per compute stretch under ``suspension="idle"``, with the switch into the
    blocking section (``overhead``) included.
    """
    if suspension is None:
        ts, w, overhead, tasks = analysis_inputs(ts, w, overhead, "cpu", "analyze")
        if not suspends_with_sections(ts, tasks):
            suspension = "cpu"
        else:
            return _either(
                analyze(ts, w, overhead=overhead, suspension="cpu", resources=resources),
                analyze(ts, w, overhead=overhead, suspension="idle", resources=resources),
            )
    ts, w, overhead, tasks = analysis_inputs(ts, w, overhead, suspension, "analyze")
    protocol = ts.resource_protocol("fp") if resources is None or not ts.has_sections else resources
    if protocol is not None:
        check_protocol(
            protocol, "fp", f"{ts.source or ts.name or 'task set'}: [scheduler] resources"
        )
    block = fp_blocking(tasks, protocol, overhead)
    results = []
    aware = None
    if suspension == "idle":
        aware = suspension_aware(tasks, overhead, block if protocol else None)
    for i, task in enumerate(tasks):
        r = (
            aware[i].wcrt
            if aware is not None
            else response_time(task, tasks[:i], overhead, block[i])
        )
        assert task.deadline is not None
        results.append(
            TaskResult(
                task.name,
                task.priority,
                task.wcet,
                task.period,
                task.deadline,
                task.wcet / task.period,
                r,
                r is not None,
                block[i],
            )
        )
    return Analysis(
        tasks=tuple(results),
        utilization=util.total_utilization(tasks),
        liu_layland=util.liu_layland(tasks),
        hyperbolic=util.hyperbolic(tasks),
        schedulable=all(r.schedulable for r in results),
        w=w,
        name=ts.name,
        overhead=float(overhead),
        offsets_ignored=any(t.offset > 0 for t in tasks),
        suspension=suspension,
        resources=protocol,
    )
