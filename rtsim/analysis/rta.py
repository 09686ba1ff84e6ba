"""Exact response-time analysis for fixed-priority preemptive scheduling on one CPU.

For a task i with wcet e_i and the set hp(i) of higher-priority tasks, released together
(the critical instant, Liu & Layland 1973), the worst-case response time is the least fixed
point of (Joseph & Pandya 1986; Audsley et al. 1993)

    R = e_i + Σ_{j ∈ hp(i)} ⌈R / p_j⌉ · e_j,

found by iteration from R = e_i + Σ e_j and abandoned once R passes the deadline.

Deadlines above the period are analysed with the level-i busy period (Lehoczky 1990;
Tindell, Burns & Wellings 1994): job q = 0, 1, … of the busy period finishes at the least
fixed point of w_q = (q+1)·e_i + Σ_j ⌈w_q / p_j⌉ e_j, its response is w_q − q·p_i, and the
busy period ends with the first job that finishes by the next release, w_q ≤ (q+1)·p_i.
For D_i ≤ p_i that is job 0 alone, i.e. the recurrence above.

Numerics: R/p_j is often an integer up to float rounding (e.g. R = 3·p_j built from a sum),
so ceilings are taken as ⌈x − 1e-9⌉; and a response within 1e-9 ms of the deadline counts as
meeting it (SPEC: a job misses its deadline when it finishes later than D + 1e-9 ms).

A processing-window set is analysed at a fixed window w, its chain counted as one task of
cost g, the radio round trip Δt included as if it used the CPU (suspension-oblivious, as the
paper does); see :meth:`rtsim.model.taskset.TaskSet.at_window`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

from rtsim.analysis import utilization as util
from rtsim.errors import TaskSetError
from rtsim.model.task import Task

if TYPE_CHECKING:  # the model package imports rtsim.analysis: no runtime import of it here
    from rtsim.model.taskset import TaskSet

__all__ = ["Analysis", "TaskResult", "analyze", "response_time", "CEIL_TOL", "DEADLINE_TOL"]

#: ⌈x⌉ is computed as ⌈x − CEIL_TOL⌉ so that R/p = 3 + 4e-16 counts as 3.
CEIL_TOL = 1e-9
#: A response time up to DEADLINE_TOL ms above the deadline still meets it.
DEADLINE_TOL = 1e-9
#: Jobs of one level-i busy period examined before giving up (returning None).
MAX_BUSY_JOBS = 100_000


def _ceil(x: float) -> int:
    return math.ceil(x - CEIL_TOL)


def _check_resolved(task: Task) -> None:
    if task.per_window:
        raise TaskSetError(
            f"task '{task.name}': period is a multiple of w; resolve it with at_window(w) first"
        )


def response_time(task: Task, higher: Sequence[Task]) -> float | None:
    """Worst-case response time of ``task`` below the tasks ``higher`` (ms), exact.

    Returns ``None`` as soon as the iteration passes the task's deadline (the task is not
    schedulable); at once when D > p and the level-i utilization exceeds 1; and if a level-i
    busy period has not closed after ``MAX_BUSY_JOBS`` jobs (only possible at a level-i
    utilization of 1 up to rounding with a huge hyperperiod). Near utilization 1 a D > p
    busy period can be long, and the analysis slow (seconds).
    """
    _check_resolved(task)
    for t in higher:
        _check_resolved(t)
    e, p = task.wcet, task.period
    deadline = p if task.deadline is None else task.deadline
    limit = deadline + DEADLINE_TOL
    hp = [(t.wcet, t.period) for t in higher]
    if deadline > p and e / p + math.fsum(ej / pj for ej, pj in hp) > 1.0 + 1e-12:
        return None  # level-i work grows without bound: some job misses any deadline
    worst = 0.0
    w = e + math.fsum(ej for ej, _ in hp)  # job 0 starts from e + Σ e_j
    for q in range(MAX_BUSY_JOBS):
        while True:
            if w - q * p > limit:
                return None
            nxt = (q + 1) * e + math.fsum(_ceil(w / pj) * ej for ej, pj in hp)
            if nxt <= w:
                break
            w = nxt
        worst = max(worst, w - q * p)
        if w <= (q + 1) * p + DEADLINE_TOL:  # the busy period closes with job q
            return worst
        w += e  # job q+1 needs at least one more e
    return None


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

    def as_dict(self) -> dict[str, Any]:
        """Plain dict (``wcrt`` is ``None`` where the iteration passed the deadline)."""
        return asdict(self)


@dataclass(frozen=True)
class Analysis:
    """The exact analysis of a task set, with the utilization tests beside it.

    ``w`` is the processing window the set was analysed at (``None`` without a window).
    ``liu_layland`` and ``hyperbolic`` are ``False`` where those tests do not apply (see
    :mod:`rtsim.analysis.utilization`); ``schedulable`` is the exact verdict.
    """

    tasks: tuple[TaskResult, ...]
    utilization: float
    liu_layland: bool
    hyperbolic: bool
    schedulable: bool
    w: float | None = None
    name: str = ""

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
        return {
            "name": self.name,
            "w": self.w,
            "tasks": [t.as_dict() for t in self.tasks],
            "utilization": self.utilization,
            "rm_implicit": self.rm_implicit,
            "liu_layland": self.liu_layland,
            "liu_layland_bound": self.liu_layland_bound,
            "hyperbolic": self.hyperbolic,
            "hyperbolic_product": self.hyperbolic_product,
            "schedulable": self.schedulable,
        }


def analyze(ts: TaskSet, w: float | None = None) -> Analysis:
    """Exact response-time analysis of every task of ``ts``.

    A set with a ``[window]`` is analysed at window ``w`` (default: the analytic w_sch of
    :func:`rtsim.analysis.bounds.w_sch_of`), the chain as one task of cost g with period
    and deadline w, per-window periods resolved. ``w`` is an error for a set without one.
    """
    label = ts.source or ts.name or "task set"
    if ts.window is None:
        if w is not None:
            raise TaskSetError(f"{label}: has no [window], so a window w does not apply")
        tasks = ts.tasks
    else:
        if w is None:
            from rtsim.analysis.bounds import w_sch_of

            w = w_sch_of(ts)
            if not math.isfinite(w):
                raise TaskSetError(
                    f"{label}: the analytic bound w_sch is infinite (T_hp saturates the CPU); "
                    "choose a window w explicitly"
                )
        tasks = ts.at_window(w).tasks
    results = []
    for i, task in enumerate(tasks):
        r = response_time(task, tasks[:i])
        assert task.deadline is not None
        results.append(TaskResult(task.name, task.priority, task.wcet, task.period,
                                  task.deadline, task.wcet / task.period, r, r is not None))
    return Analysis(
        tasks=tuple(results),
        utilization=util.total_utilization(tasks),
        liu_layland=util.liu_layland(tasks),
        hyperbolic=util.hyperbolic(tasks),
        schedulable=all(r.schedulable for r in results),
        w=w,
        name=ts.name,
    )
