"""Lower bounds on the processing window: the paper's w_sch (Eqs 1, 5–7, 11, in a general form
with jitter), and the least windows that the exact analysis (w_rta), the suspension-aware one
(w_susp) and the EDF demand criterion (w_edf) accept. The equations, and why w_rta can be
found by search and snapped to a closed form: docs/model/lower-bound.md.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from rtsim.analysis.common import DEADLINE_TOL, ceil_div, stretches
from rtsim.analysis.edf import analyze_edf, edf_tasks, qpa
from rtsim.analysis.rta import analyze, response_time
from rtsim.analysis.search import smallest_passing
from rtsim.analysis.sufficient import (
    _entries,
    _need_window,
    as_taskset,
    w_eq7_of,
    w_eq11_of,
    w_sch_of,
)
from rtsim.analysis.suspension import compute_time, suspension_aware
from rtsim.analysis.transaction import transaction_bounds
from rtsim.errors import InputError
from rtsim.model.task import Task
from rtsim.model.window import TIMES

if TYPE_CHECKING:
    from rtsim.model.taskset import TaskSet

__all__ = [
    "WindowBounds",
    "window_bounds",
    "w_rta",
    "w_susp",
    "w_edf",
    "w_txn",
    "w_sch_of",
    "w_eq7_of",
    "w_eq11_of",
    "lower_bound",
    "LOWER_BOUNDS",
    "BOUND_SCHEDULER",
]

#: The window lower bounds an adjustment policy can use ([adjust] lower_bound).
LOWER_BOUNDS: tuple[str, ...] = ("w_sch", "w_rta", "w_susp", "w_edf", "w_txn")
#: The scheduler each lower bound assumes.
BOUND_SCHEDULER: dict[str, str] = {
    "w_sch": "fp",
    "w_rta": "fp",
    "w_susp": "fp",
    "w_edf": "edf",
    "w_txn": "fp",
}

#: Largest window w_rta searches (ms); beyond it the set is reported as never schedulable.
W_MAX = 1e9


def _deadline(t: Task) -> float:
    """The task's relative deadline (set to the period when the file gives none)."""
    assert t.deadline is not None
    return t.deadline


def _feasible(ts: TaskSet, w: float) -> bool:
    return analyze(ts, w).schedulable


def _snap(ts: TaskSet, hi: float) -> float:
    """The exact left end of the feasible piece containing ``hi`` (module doc)."""
    entries = _entries(ts)
    resolved = ts.at_window(hi).tasks
    scale = {t.name: (t.period, _deadline(t)) for t, s in entries if s}
    best = 0.0
    for i, task in enumerate(resolved):
        r = response_time(task, resolved[:i])
        assert r is not None and task.deadline is not None
        if r > task.period + DEADLINE_TOL:  # several jobs in the busy period: keep hi
            best = max(best, hi)
            continue
        cands = [r / scale[task.name][1]] if task.name in scale else []
        for j in resolved[:i]:
            if j.name in scale:  # ⌈(R + J_j)/(m·c_j·w)⌉ steps at w = (R + J_j)/(m·c_j)
                m = ceil_div(r + j.jitter, j.period)
                cands.append((r + j.jitter) / (m * scale[j.name][0]))
        best = max(best, *cands) if cands else best
    return best


def _bracket(ts: TaskSet, feasible: Callable[[float], bool]) -> tuple[float, float]:
    """(lo, hi): infeasible at lo (or lo = 0), feasible at hi, hi − lo ≤ 1e-13·hi; hi = inf
    when nothing up to W_MAX is feasible. Feasibility is monotone in w (module doc)."""
    assert ts.window is not None
    g = ts.window.g()
    hi = max(g, 1e-6)
    while not feasible(hi):
        if hi >= W_MAX:
            return math.inf, math.inf
        hi *= 2.0
    lo = hi / 2.0 if hi > g else 0.0
    while hi - lo > 1e-13 * hi:
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if feasible(mid):
            hi = mid
        else:
            lo = mid
    return lo, hi


def w_rta(ts: TaskSet) -> float:
    """The least window w at which the exact analysis finds every task schedulable (ms).

    ``inf`` when no w up to ``W_MAX`` is schedulable (e.g. T_hp alone is not). Exact up to
    float rounding: the analysis passes at the result and fails 1e-6 ms below it.
    """
    ts = as_taskset(ts, "w_rta")
    _need_window(ts)
    lo, hi = _bracket(ts, lambda w: _feasible(ts, w))
    if not math.isfinite(hi):
        return math.inf
    snapped = _snap(ts, hi)
    if snapped > lo and _feasible(ts, snapped):
        return snapped
    return hi


def w_susp(ts: TaskSet, overhead: float | None = None) -> float:
    """The least window w at which the suspension-aware analysis accepts every task (ms).

    Bisected like [`w_rta`][rtsim.analysis.bounds.w_rta], then checked against the closed forms
    where the verdict can
    change (a scaled deadline d·w met by a bound R: R/d; a window-scaled higher task's ceiling
    ⌈(R + J)/(m·c)⌉ stepping: (R + J)/(m·c), for its own jitter and for R_w − C_w): the
    result is the least such candidate within 1e-8 ms of the bisection's end at which the
    analysis passes, else that end (either way verified to pass).
    ``inf`` when no w up to ``W_MAX`` passes.
    """
    ts = as_taskset(ts, "w_susp")
    _need_window(ts)

    def feasible(w: float) -> bool:
        return analyze(ts, w, overhead=overhead, suspension="idle").schedulable

    lo, hi = _bracket(ts, feasible)
    if not math.isfinite(hi):
        return math.inf
    o = ts.overhead if overhead is None else overhead
    scale = {t.name: (t.period, _deadline(t)) for t, s in _entries(ts) if s}
    resolved = ts.at_window(hi).tasks
    bounds = suspension_aware(resolved, o)
    cands: list[float] = []
    for i, (task, b) in enumerate(zip(resolved, bounds, strict=True)):
        for r in (b.oblivious, b.other):
            if r is None:
                continue
            if task.name in scale:
                cands.append(r / scale[task.name][1])
            for k, j in enumerate(resolved[:i]):
                if j.name not in scale:
                    continue
                jits = {j.jitter}
                wcrt = bounds[k].wcrt
                if wcrt is not None:
                    jits.add(max(wcrt - compute_time(j), 0.0))
                for jj in jits:
                    m = ceil_div(r + jj, j.period)
                    if m > 0:
                        cands.append((r + jj) / (m * scale[j.name][0]))
    # the closed form nearest the bisection's end (it can sit up to the 1e-9 ms deadline
    # tolerance above hi, as w_rta's snap does)
    best = hi
    for c in sorted(set(cands)):
        if lo < c <= hi + 1e-8 and feasible(c):
            best = c
            break
    if not feasible(best):  # pragma: no cover - the bisection's hi passed
        raise AssertionError(f"w_susp: the analysis fails at {best!r}")
    return best


def w_edf(ts: TaskSet, overhead: float | None = None) -> float:
    """The least window w at which the EDF demand criterion accepts the set (ms; module doc).

    Feasibility is monotone in w (every period and deadline is non-decreasing in w, so each
    ⌊(t + J − D)/T⌋ and h(t) are non-increasing), so the result is bisected like
    [`w_rta`][rtsim.analysis.bounds.w_rta] to 1e-13 relative and checked: the criterion passes at
    the result and fails
    just below it. Where U(w) = 1 binds (implicit deadlines, as the paper's set) the result
    is the closed form w = Σ_scaled(C/c)/(1 − U_fixed), to the ulp: the least float at which
    the criterion, taking U as computed, passes. ``inf`` when no w up to ``W_MAX`` passes.
    """
    _need_window(ts)
    o = ts.overhead if overhead is None else overhead

    if ts.has_sections:  # Baker's condition with the blocking term (srp unless npr)
        protocol = "npr" if ts.resources == "npr" else "srp"

        def feasible(w: float) -> bool:
            return analyze_edf(ts, w, overhead=o, resources=protocol).schedulable
    else:

        def feasible(w: float) -> bool:
            return qpa(edf_tasks(ts.at_window(w).tasks, o)).schedulable

    lo, hi = _bracket(ts, feasible)
    if not math.isfinite(hi):
        return math.inf
    # the closed form where U(w) = 1 binds (U_fixed + Σ_scaled (C/c)/w = 1), moved by a few
    # ulps to the least float at which the criterion (U as computed) passes
    fixed = [t for t, s in _entries(ts) if not s]
    scaled = [t for t, s in _entries(ts) if s]
    u_fixed = math.fsum(_edf_c(t, o) / t.period for t in fixed)
    if u_fixed < 1.0:
        cand = math.fsum(_edf_c(t, o) / t.period for t in scaled) / (1.0 - u_fixed)
        for _ in range(64):
            if cand > hi:
                break
            if lo < cand and feasible(cand):
                hi = cand
                for _ in range(64):
                    below = math.nextafter(hi, 0.0)
                    if below <= lo or not feasible(below):
                        break
                    hi = below
                break
            cand = math.nextafter(cand, math.inf)
    if not feasible(hi):  # pragma: no cover - the bisection's hi passed
        raise AssertionError(f"w_edf: the EDF analysis fails at {hi!r}")
    return hi


def w_txn(
    ts: TaskSet,
    *,
    overhead: float | None = None,
    suspension: str = "idle",
    tol: float = 1e-6,
    force: bool = False,
) -> float:
    """The least window w (ms, to ``tol``) at which every task of the processing-window set
    ``ts`` has a bound within its deadline, each task taking the least of its sound bounds
    ([`transaction_bounds`][rtsim.analysis.transaction.transaction_bounds]). Feasibility need not be
    monotone in w (the offsets move
    with it), so the search is `rtsim.analysis.search.smallest_passing`: bisection
    from above the suspension-aware w_susp (or w_rta under ``suspension="cpu"``), which
    passes, with a scan of 20 windows above the result. ``inf`` when that start is."""

    hi = w_susp(ts, overhead) if suspension == "idle" else w_rta(ts)
    if not math.isfinite(hi):
        return math.inf

    def passes(w: float) -> bool:
        bounds = transaction_bounds(ts, w, overhead=overhead, suspension=suspension, force=force)
        return all(r is not None for r in bounds.values())

    lo = 0.5 * hi
    while passes(lo):
        lo *= 0.5
    return smallest_passing(passes, lo, hi, tol=tol, scan=20).w


def _edf_c(task: Task, overhead: float) -> float:
    """A task's C in the EDF analysis: WCET (suspensions included) + 2·o per stretch."""
    return task.wcet + 2.0 * overhead * stretches(task) if overhead else task.wcet


def lower_bound(
    ts: TaskSet,
    name: str,
    *,
    scheduler: str = "fp",
    suspension: str = "idle",
    where: str = "lower_bound",
    force: bool = False,
) -> float:
    """The window lower bound ``name`` (`LOWER_BOUNDS`) for a CPU run with ``scheduler``
    and ``suspension``; a bound whose model does not match is an input error: w_sch, w_rta,
    w_susp and w_txn (the offset-based bound,
    [`rtsim.analysis.bounds.w_txn`][rtsim.analysis.bounds.w_txn], under
    ``suspension``) are fixed-priority analyses, w_edf an EDF one, and w_susp is sound only
    with Δt leaving the CPU idle. ``force`` runs w_txn past its work limit."""
    if name not in LOWER_BOUNDS:
        raise InputError(
            f"{where}: lower_bound: must be one of {', '.join(LOWER_BOUNDS)}, got {name!r}"
        )
    if scheduler != BOUND_SCHEDULER[name]:
        kind = "a fixed-priority" if BOUND_SCHEDULER[name] == "fp" else "an EDF"
        raise InputError(
            f"{where}: lower_bound: {name} is {kind} bound, but the scheduler is {scheduler!r}"
        )
    if name == "w_susp" and suspension != "idle":
        raise InputError(
            f"{where}: lower_bound: w_susp assumes the radio round trip leaves "
            f"the CPU idle, but suspension is {suspension!r}"
        )
    if name == "w_sch":
        return w_sch_of(ts)
    if name == "w_edf":
        return w_edf(ts)
    if name == "w_txn":
        return w_txn(ts, suspension=suspension, force=force)
    return w_rta(ts) if name == "w_rta" else w_susp(ts)


@dataclass(frozen=True)
class WindowBounds:
    """The window bounds of one set at one (n, r_H), with every input used (ms, cm).

    ``inputs`` has n, r_H, e_cal, e_trans, k, e_scan, e_estimate, e_send, e_recv, delta_t,
    e_sched, ``hp`` (``[{name, e, p}]``, ``per_window`` instead of ``p`` for a multiple of w)
    and ``lp`` (``[{name, e, per_window}]``, or ``p`` in ms for a fixed period), each with
    its ``priority`` and, where it differs from the period, its ``deadline``.
    """

    inputs: dict[str, Any] = field(repr=False)
    e_hough: float
    g: float
    w_eq7: float
    w_eq11: float
    w_sch: float
    w_rta: float
    w_susp: float = math.nan
    w_edf: float = math.nan

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict; infinite bounds (none exists, or no T_lp for Eq 11) become None."""

        def fin(x: float) -> float | None:
            return x if math.isfinite(x) else None

        return {
            "inputs": self.inputs,
            "e_hough": fin(self.e_hough),
            "g": fin(self.g),
            "w_eq7": fin(self.w_eq7),
            "w_eq11": fin(self.w_eq11),
            "w_sch": fin(self.w_sch),
            "w_rta": fin(self.w_rta),
            "w_susp": fin(self.w_susp),
            "w_edf": fin(self.w_edf),
        }


def _task_input(t: Task) -> dict[str, Any]:
    out: dict[str, Any] = {"name": t.name, "e": t.wcet}
    out["per_window" if t.per_window else "p"] = t.period
    if t.deadline != t.period:
        out["deadline"] = t.deadline
    out["priority"] = t.priority
    return out


def window_bounds(ts: TaskSet, n: int | None = None, r_H: float | None = None) -> WindowBounds:
    """e_hough, g, Eq 7, Eq 11, w_sch, w_rta, w_susp and w_edf for ``ts`` (a TaskSet or the
    path of a task-set file; n followers, radius r_H)."""
    ts = as_taskset(ts, "window_bounds")
    _need_window(ts)
    changes: dict[str, Any] = {}
    if n is not None:
        changes["n"] = n
    if r_H is not None:
        changes["r_H"] = r_H
    if changes:
        ts = ts.with_window(**changes)
    win = ts.window
    assert win is not None
    keys = ("n", "r_H", *TIMES[:2], "k", *TIMES[2:])  # WindowSpec's field order
    inputs: dict[str, Any] = {k: getattr(win, k) for k in keys}
    inputs["priority"] = win.priority
    for key in ("jitter", "offset"):
        if getattr(win, key):
            inputs[key] = getattr(win, key)
    inputs["hp"] = [_task_input(t) for t in ts.hp]
    inputs["lp"] = [_task_input(t) for t in ts.lp]
    eq7, eq11 = w_eq7_of(ts), w_eq11_of(ts)
    return WindowBounds(
        inputs=inputs,
        e_hough=win.e_hough(),
        g=win.g(),
        w_eq7=eq7,
        w_eq11=eq11,
        w_sch=max(eq7, eq11),
        w_rta=w_rta(ts),
        w_susp=w_susp(ts),
        w_edf=w_edf(ts),
    )
