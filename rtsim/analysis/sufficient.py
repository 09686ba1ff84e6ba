"""The paper's sufficient lower bound on the processing window, w_sch = max(Eq 7, Eq 11)
(docs/model/lower-bound.md; the general form is described in `rtsim.analysis.bounds`):
Eq 7 for the chain, Eq 11 over the tasks below it, both from ⌈x⌉ ≤ x + 1, the ceiling kept
exact where both periods scale with w or both are fixed."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from typing import TYPE_CHECKING

from rtsim.analysis.common import CEIL_TOL
from rtsim.errors import TaskSetError
from rtsim.model.task import Task
from rtsim.model.taskset import TaskSet

if TYPE_CHECKING:
    from rtsim.model.window import WindowSpec

__all__ = ["as_taskset", "w_eq7_of", "w_eq11_of", "w_sch_of", "window_or_w_sch"]


def as_taskset(ts: object, function: str) -> TaskSet:
    """``ts`` if it is a [`TaskSet`][rtsim.model.taskset.TaskSet]; else a
    `TaskSetError` naming ``function`` (the analyses take task sets; a
    file is read above them: `rtsim.load_taskset`, or the facade's [`rtsim.analyze`][rtsim.analyze]
    and [`rtsim.window_bounds`][rtsim.window_bounds], which take a path too)."""
    if isinstance(ts, TaskSet):
        return ts
    if isinstance(ts, str | os.PathLike):
        raise TaskSetError(
            f"{function}: expected a TaskSet, got the path {os.fspath(ts)!r} "
            f"(read the file with rtsim.load_taskset)"
        )
    raise TaskSetError(
        f"{function}: expected a TaskSet or the path of a task-set file, got {type(ts).__name__}"
    )


def _need_window(ts: TaskSet) -> WindowSpec:
    if ts.window is None:
        label = ts.source or ts.name or "task set"
        raise TaskSetError(f"{label}: has no [window]; window bounds need a processing-window set")
    return ts.window


def _entries(ts: TaskSet) -> list[tuple[Task, bool]]:
    """Every task in priority order with whether its period scales with w; chain at w = 1."""
    assert ts.window is not None
    chain = ts.window_task(1.0)
    out = [(t, t.per_window) for t in ts.tasks] + [(chain, True)]
    return sorted(out, key=lambda e: e[0].priority)


def _sufficient(task: Task, scaled: bool, higher: Sequence[tuple[Task, bool]]) -> float:
    """Least w passing the ⌈x⌉ ≤ x + 1 test for ``task`` at t = min(D, p) (module doc).

    Release jitter (ms, also on tasks whose period scales with w): the task's own J shortens
    the time its job has, t = D − J; a higher task's J_j adds at most ⌈J_j/P_j⌉ jobs, since
    ⌈(t + J_j)/P_j⌉ ≤ ⌈t/P_j⌉ + ⌈J_j/P_j⌉ and ⌈t/P_j⌉ ≤ ⌈min(D, p)/P_j⌉. For a period that
    scales with w, P_j is taken at the jitter-free result w0 ≤ w (so ⌈J_j/P_j(w)⌉ is at most
    the count used). With no jitter this is the paper's form exactly.
    """
    assert task.deadline is not None
    d = min(task.deadline, task.period)  # in units of w when ``scaled``, else ms
    const = task.wcet  # demand terms that do not depend on w
    per_w = 0.0  # scaled task: demand ∝ w; fixed task: demand ∝ 1/w
    for t, t_scaled in higher:
        if scaled == t_scaled:  # both scale with w, or both fixed: exact ceiling
            const += math.ceil(d / t.period - CEIL_TOL) * t.wcet
        else:
            const += t.wcet
            per_w += t.wcet / t.period

    def solve(const: float, own_j: float) -> float:
        if scaled:  # const + w·d·per_w ≤ d·w − J
            return math.inf if per_w >= 1.0 else (const + own_j) / (d * (1.0 - per_w))
        # fixed deadline d ms: const + (d/w)·per_w ≤ d − J
        if const >= d - own_j:
            return math.inf
        return d * per_w / (d - own_j - const)

    w0 = solve(const, 0.0)
    jittered = [(t, s) for t, s in higher if t.jitter > 0]
    if not jittered and task.jitter == 0:
        return w0
    if not math.isfinite(w0):
        return math.inf
    extra = math.fsum(
        math.ceil(t.jitter / (t.period * w0 if s else t.period) - CEIL_TOL) * t.wcet
        for t, s in jittered
    )
    return solve(const + extra, task.jitter)


def w_eq7_of(ts: TaskSet) -> float:
    """Eq 7: the chain alone, w ≥ (g + Σ_hp e_j)/(1 − Σ_hp e_j/p_j) for fixed-period T_hp."""
    win = _need_window(ts)
    entries = _entries(ts)
    i = next(k for k, (t, _) in enumerate(entries) if t.priority == win.priority)
    return _sufficient(*entries[i], entries[:i])


def w_eq11_of(ts: TaskSet) -> float:
    """Eq 11 over T_lp (``-inf`` without T_lp): (½Σ_{lp∪hp} e_j + g)/(1 − U_hp) for p = 2w."""
    _need_window(ts)
    entries = _entries(ts)
    assert ts.window is not None
    bounds = [
        _sufficient(t, s, entries[:k])
        for k, (t, s) in enumerate(entries)
        if t.priority > ts.window.priority
    ]
    return max(bounds, default=-math.inf)


def w_sch_of(ts: TaskSet) -> float:
    """The analytic lower bound w_sch = max(Eq 7, Eq 11) (docs/model/lower-bound.md); ``inf`` if
    none exists."""
    ts = as_taskset(ts, "w_sch_of")
    return max(w_eq7_of(ts), w_eq11_of(ts))


def window_or_w_sch(ts: TaskSet, w: float | None = None) -> float:
    """The window a processing-window set is analysed or simulated at: ``w`` when given, else
    the analytic bound w_sch (the one place that decides it). An infinite w_sch is a
    `TaskSetError`: T_hp saturates the CPU, a window must be given."""
    if w is not None:
        return w
    w_sch = w_sch_of(ts)
    if not math.isfinite(w_sch):
        label = ts.source or ts.name or "task set"
        raise TaskSetError(
            f"{label}: the analytic bound w_sch is infinite (T_hp saturates the "
            f"CPU); choose a window w explicitly"
        )
    return w_sch
