"""EDF on one processor: the processor-demand criterion (with QPA) and Spuri's response times.

The demand bound h(t) with release jitter (Baruah, Rosier & Howell 1990; Zhang & Burns 2009),
its limit L = min(L_a, L_b) and QPA (Zhang & Burns 2009, Theorems 2, 3 and 5), Spuri's (1996)
per-task bound (``bound = "spuri"``, or ``"deadline"`` where his search does not close and
the criterion accepts the set), Δt counted as computation, SRP blocking B(t) from
`rtsim.analysis.blocking`. Equations, limits and numerics: docs/analysis-beyond.md (EDF).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

from rtsim.analysis.blocking import check_protocol, edf_blocking
from rtsim.analysis.common import CEIL_TOL, DEADLINE_TOL, ceil_div, stretches
from rtsim.analysis.rta import analysis_inputs
from rtsim.errors import TaskSetError
from rtsim.model.task import Task

if TYPE_CHECKING:
    from rtsim.model.taskset import TaskSet

__all__ = [
    "EdfTask",
    "EdfTaskResult",
    "EdfAnalysis",
    "demand",
    "utilization",
    "limit_la",
    "busy_period",
    "deadline_points",
    "edf_arrivals",
    "qpa",
    "spuri_wcrt",
    "analyze_edf",
    "edf_tasks",
    "MAX_STEPS",
]

#: (C, T, D, J) in ms.
EdfTask = tuple[float, float, float, float]
#: Fixed-point and QPA steps before giving up (a pathological set near U = 1).
MAX_STEPS = 200_000
#: Steps of the synchronous busy period before it is taken as not closing (at U = 1 it
#: closes at the hyperperiod, which need not exist for periods that are floats).
MAX_BUSY_STEPS = 100_000


def floor_div(x: float, p: float) -> int:
    """⌊x/p⌋ for times (ms), x taken CEIL_TOL ms higher (a boundary within 1e-9 ms counts)."""
    return math.floor((x + CEIL_TOL) / p)


def utilization(tasks: Sequence[EdfTask]) -> float:
    """U = Σ C_i/T_i."""
    return math.fsum(c / t for c, t, _, _ in tasks)


def demand(t: float, tasks: Sequence[EdfTask]) -> float:
    """h(t) = Σ_i max(0, ⌊(t + J_i − D_i)/T_i⌋ + 1)·C_i (module doc)."""
    return math.fsum(max(0, floor_div(t + j - d, p) + 1) * c for c, p, d, j in tasks)


def limit_la(tasks: Sequence[EdfTask]) -> float:
    """L_a = max(max_i (D_i − J_i), Σ (T_i − D_i + J_i)·U_i/(1 − U)), for U < 1 (else inf)."""
    u = utilization(tasks)
    if u >= 1.0:
        return math.inf
    s = math.fsum((p - d + j) * c / p for c, p, d, j in tasks)
    return max(max(d - j for _, _, d, j in tasks), s / (1.0 - u))


def busy_period(
    tasks: Sequence[EdfTask], cap: float = math.inf, extra: float = 0.0
) -> float | None:
    """L_b: least L = Σ ⌈(L + J_i)/T_i⌉·C_i from Σ C_i (the synchronous busy period with
    jitter); None if it does not close (U > 1, or U = 1 with jitter) within MAX_STEPS, or
    passes ``cap``. ``extra``: work added once (a blocking section)."""
    if utilization(tasks) > 1.0:
        return None
    w = math.fsum(c for c, _, _, _ in tasks)
    if extra:
        w += extra
    for _ in range(MAX_BUSY_STEPS):
        if w > cap:
            return None
        nxt = math.fsum(ceil_div(w + j, p) * c for c, p, _, j in tasks)
        if extra:
            nxt += extra
        if nxt <= w + CEIL_TOL:
            return w
        w = nxt
    return None


def _point_below(t: float, tasks: Sequence[EdfTask]) -> float:
    """The largest deadline point k·T_i + D_i − J_i strictly below t (−inf if none)."""
    best = -math.inf
    for _, p, d, j in tasks:
        base = d - j
        if base >= t - CEIL_TOL:
            continue
        k = ceil_div(t - base, p) - 1
        best = max(best, base + k * p)
    return best


def deadline_points(tasks: Sequence[EdfTask], limit: float) -> list[float]:
    """Every deadline point k·T_i + D_i − J_i ≤ ``limit``, sorted, duplicates removed."""
    pts: set[float] = set()
    for _, p, d, j in tasks:
        base = d - j
        k = 0
        while base + k * p <= limit + CEIL_TOL:
            pts.add(base + k * p)
            k += 1
    return sorted(pts)


@dataclass(frozen=True)
class QpaResult:
    """The demand criterion's verdict, the limit it used, and the point that failed."""

    schedulable: bool
    limit: float | None
    limit_kind: str
    failed_at: float | None
    steps: int


def _hyperperiod(tasks: Sequence[EdfTask]) -> float | None:
    """The least common multiple of the periods if they are whole ms (else None)."""
    if not all(float(p).is_integer() and p < 1e9 for _, p, _, _ in tasks):
        return None
    return float(math.lcm(*(int(p) for _, p, _, _ in tasks)))


def qpa(tasks: Sequence[EdfTask]) -> QpaResult:
    """The processor-demand criterion by QPA (module doc): U > 1 fails at once; else checks
    h(t) ≤ t at the deadline points below L = min(L_a, L_b)."""
    u = utilization(tasks)
    if u > 1.0:  # as computed (math.fsum): a set at U = 1 that rounds above fails (safe)
        return QpaResult(False, None, "U > 1", None, 0)
    if any(d - j <= 0 for _, _, d, j in tasks):  # a job due before it can be released
        t = min(d - j for _, _, d, j in tasks)
        return QpaResult(False, None, "D - J <= 0", t, 0)
    if all(d - j >= p for _, p, d, j in tasks):
        # h(t) ≤ Σ ⌊t/T_i⌋·C_i ≤ U·t ≤ t (Liu & Layland 1973 for D = T): no point to check
        return QpaResult(True, None, "U <= 1, D - J >= T", None, 0)
    la = limit_la(tasks)
    lb = busy_period(tasks, cap=la)  # only needed where it is below L_a
    cands = [(x, k) for x, k in ((la, "L_a"), (lb, "L_b")) if x is not None and math.isfinite(x)]
    if not cands:  # U = 1 and the busy period does not close (jitter): one hyperperiod
        hyper = _hyperperiod(tasks)
        if hyper is None:
            return QpaResult(False, None, "U = 1, no hyperperiod", None, 0)
        cands = [(max(d - j for _, _, d, j in tasks) + hyper, "max(D - J) + H")]
    limit, kind = min(cands)
    limit = float(limit)
    d_min = min(d - j for _, _, d, j in tasks)
    # deadline points strictly below L (a deadline at L itself: Zhang & Burns check d < L;
    # checking d ≤ L as well costs one point and is never less safe)
    t = _point_below(limit + 2 * CEIL_TOL, tasks)
    if not math.isfinite(t):  # no deadline point up to L
        return QpaResult(True, limit, kind, None, 0)
    steps = 0
    h = demand(t, tasks)
    while h <= t + DEADLINE_TOL and h > d_min + DEADLINE_TOL:
        steps += 1
        if steps > MAX_STEPS:  # pragma: no cover - QPA converges in far fewer steps
            return QpaResult(False, limit, kind, t, steps)
        t = h if h < t - DEADLINE_TOL else _point_below(t, tasks)
        h = demand(t, tasks)
    if h <= d_min + DEADLINE_TOL and h <= t + DEADLINE_TOL:
        return QpaResult(True, limit, kind, None, steps)
    return QpaResult(False, limit, kind, t, steps)


def blocking_check(tasks: Sequence[EdfTask], blocking: Callable[[float], float]) -> float | None:
    """Baker's SRP condition beside the demand criterion: the first deadline point t with
    h(t) + B(t) > t (None: none). Points only below the largest t where B(t) > 0 matter
    (beyond it the plain criterion decides); B is non-increasing in t."""
    top = max((d for _, _, d, _ in tasks), default=0.0)
    if (
        blocking(0.0) <= 0.0
        and blocking(top) <= 0.0
        and all(blocking(d - j) <= 0.0 for _, _, d, j in tasks)
    ):
        return None
    steps = 0
    for t in deadline_points(tasks, top):
        b = blocking(t)
        if b <= 0.0:
            continue
        steps += 1
        if steps > MAX_STEPS:  # pragma: no cover - absurdly many deadlines below max D
            return t
        if demand(t, tasks) + b > t + DEADLINE_TOL:
            return t
    return None


def spuri_wcrt(
    i: int, tasks: Sequence[EdfTask], blocking: Callable[[float], float] | None = None
) -> float | None:
    """Spuri's worst-case response time of task ``tasks[i]`` under EDF (module doc), from
    arrival; None when the synchronous busy period does not close (U > 1, or U = 1 with
    jitter: the search over arrivals has no end). ``blocking``: B(t) of
    [`rtsim.analysis.blocking.edf_blocking`][rtsim.analysis.blocking.edf_blocking]; the job due at d
    = a + D_i is delayed by
    at most one section of a job due after d that started before the busy period, so
    L_i(a) gains B(d) (and the busy period the largest B)."""
    bmax = 0.0 if blocking is None else blocking(min(d - j for _, _, d, j in tasks))
    lb = busy_period(tasks, extra=bmax)
    if lb is None:
        return None
    ci, ti, di, ji = tasks[i]
    hi = lb - ci
    cands: set[float] = set()
    for k, (_, p, d, j) in enumerate(tasks):
        base = (-ji) if k == i else d - j - di
        if base < -ji:
            m = ceil_div(-ji - base, p)  # first k·T + base ≥ −J_i
            base += m * p
        a = base
        while a <= hi + CEIL_TOL:
            cands.add(a)
            a += p
    if not cands:
        cands.add(-ji)
    worst = ci + ji
    others = [x for k, x in enumerate(tasks) if k != i]
    for a in sorted(cands):
        dl = a + di
        own = (floor_div(a + ji, ti) + 1) * ci
        if blocking is not None:
            own += blocking(dl)
        inter = [
            (c, p, floor_div(dl - d + j, p) + 1, j)
            for c, p, d, j in others
            if d - j <= dl + CEIL_TOL
        ]
        t = own + math.fsum(c for c, _, _, _ in inter)
        for _ in range(MAX_STEPS):
            nxt = own + math.fsum(min(ceil_div(t + j, p), cap) * c for c, p, cap, j in inter)
            if nxt <= t + CEIL_TOL:
                break
            t = nxt
        else:  # pragma: no cover - bounded by the busy period
            return None
        worst = max(worst, t - a)
    return worst


def edf_arrivals(ts: TaskSet, w: float | None = None, overhead: float | None = None) -> float:
    """The arrivals [`spuri_wcrt`][rtsim.analysis.edf.spuri_wcrt] examines for ``ts`` at window
    ``w``, an upper bound
    computed before the search: for each task, every arrival of every task in the
    synchronous busy period L_b, tasks × Σ (L_b / T + 1) (0 when L_b does not close: the
    bound is then not searched). Computing L_b is itself bounded (MAX_BUSY_STEPS)."""
    _, _, o, tasks = analysis_inputs(ts, w, overhead, "cpu", "analyze_edf")
    et = edf_tasks(tasks, o)
    lb = busy_period(et)
    if lb is None:
        return 0.0
    return float(len(et) * math.fsum(lb / p + 1.0 for _, p, _, _ in et))


def edf_tasks(tasks: Sequence[Task], overhead: float = 0.0) -> list[EdfTask]:
    """(C, T, D, J) of resolved tasks; C includes suspensions (suspension-oblivious) and
    2·o per compute stretch (module doc)."""
    o = float(overhead)
    out = []
    for t in tasks:
        if t.per_window:
            raise TaskSetError(
                f"task '{t.name}': period is a multiple of w; resolve it with at_window(w) first"
            )
        assert t.deadline is not None
        c = t.wcet + 2.0 * o * stretches(t) if o else t.wcet
        out.append((c, t.period, t.deadline, t.jitter))
    return out


@dataclass(frozen=True)
class EdfTaskResult:
    """One task under EDF: its parameters at the analysed window and its WCRT bound (ms).

    ``bound`` says which bound ``wcrt`` is: ``"spuri"`` (Spuri's response-time bound),
    ``"deadline"`` (the relative deadline D: the demand criterion accepts the set, so every
    job meets its deadline, but Spuri's search does not close — the synchronous busy period is
    unbounded at U = 1 with jitter or with periods that have no common multiple) or ``"none"``
    (no bound: ``wcrt`` is None).
    """

    name: str
    priority: int
    wcet: float
    period: float
    deadline: float
    jitter: float
    utilization: float
    wcrt: float | None
    schedulable: bool
    bound: str = "spuri"
    blocking: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        """Plain dict."""
        return asdict(self)


@dataclass(frozen=True)
class EdfAnalysis:
    """The EDF analysis of a task set: the demand criterion's verdict for the whole set
    (``schedulable``, with ``limit``/``limit_kind`` and the deadline point that failed) and
    Spuri's bound per task. ``suspension`` is recorded; suspensions always count as
    computation here (module doc)."""

    tasks: tuple[EdfTaskResult, ...]
    utilization: float
    schedulable: bool
    limit: float | None
    limit_kind: str
    failed_at: float | None
    qpa_steps: int
    w: float | None = None
    name: str = ""
    overhead: float = 0.0
    offsets_ignored: bool = False
    suspension: str = "cpu"
    scheduler: str = "edf"
    resources: str | None = None

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "name": self.name,
            "scheduler": self.scheduler,
            "w": self.w,
            "tasks": [t.as_dict() for t in self.tasks],
            "utilization": self.utilization,
            "schedulable": self.schedulable,
            "limit": self.limit,
            "limit_kind": self.limit_kind,
            "failed_at": self.failed_at,
            "qpa_steps": self.qpa_steps,
            "overhead": self.overhead,
            "offsets_ignored": self.offsets_ignored,
            "suspension": self.suspension,
            "resources": self.resources,
        }


def analyze_edf(
    ts: TaskSet,
    w: float | None = None,
    *,
    overhead: float | None = None,
    suspension: str = "cpu",
    resources: str | None = None,
) -> EdfAnalysis:
    """The EDF analysis of ``ts`` (at window ``w`` for a processing-window set: default the
    analytic w_sch, as [`rtsim.analysis.rta.analyze`][rtsim.analysis.rta.analyze]). ``overhead``
    defaults to the
    set's; ``suspension`` ("cpu" or "idle") is recorded, the analysis is
    suspension-oblivious either way (sound for both).

    Critical sections (``resources``: ``srp`` or ``npr``, default the set's protocol): the
    demand criterion adds Baker's blocking term, h(t) + B(t) ≤ t
    ([`rtsim.analysis.blocking.edf_blocking`][rtsim.analysis.blocking.edf_blocking]), and Spuri's
    bound B(a + D_i); each
    task's ``blocking`` is B(D_i − J_i), the most a job of it can be blocked. Under
    ``suspension="idle"`` a job can be blocked once per compute stretch; this analysis
    charges it once and refuses a set whose tasks with sections or below them suspend."""
    ts, w, overhead, tasks = analysis_inputs(ts, w, overhead, suspension, "analyze_edf")
    et = edf_tasks(tasks, overhead)
    protocol = (
        ts.resource_protocol("edf") if resources is None or not ts.has_sections else resources
    )
    blocking = None
    if protocol is not None:
        check_protocol(
            protocol, "edf", f"{ts.source or ts.name or 'task set'}: [scheduler] resources"
        )
        if suspension == "idle" and any(stretches(t) > 1 for t in tasks):
            raise TaskSetError(
                f"{ts.source or ts.name or 'task set'}: critical sections "
                f"under edf with suspensions that leave the CPU idle have no "
                f'analysis here; use suspension "cpu"'
            )
        blocking = edf_blocking(tasks, protocol, overhead)
    verdict = qpa(et)
    if blocking is not None and verdict.schedulable:
        failed = blocking_check(et, blocking)
        if failed is not None:
            verdict = QpaResult(
                False, verdict.limit, verdict.limit_kind + " + B(t)", failed, verdict.steps
            )
    results = []
    for i, task in enumerate(tasks):
        r = spuri_wcrt(i, et, blocking)
        assert task.deadline is not None
        kind = "spuri" if r is not None else "none"
        if verdict.schedulable and (r is None or r > task.deadline):
            # the demand criterion is exact: every job meets its deadline, so R <= D
            r, kind = task.deadline, "deadline"
        ok = r is not None and r <= task.deadline + DEADLINE_TOL
        b = 0.0 if blocking is None else blocking(task.deadline - task.jitter)
        results.append(
            EdfTaskResult(
                task.name,
                task.priority,
                task.wcet,
                task.period,
                task.deadline,
                task.jitter,
                task.wcet / task.period,
                r,
                ok,
                kind,
                b,
            )
        )
    return EdfAnalysis(
        tasks=tuple(results),
        utilization=utilization(et),
        schedulable=verdict.schedulable,
        limit=verdict.limit,
        limit_kind=verdict.limit_kind,
        failed_at=verdict.failed_at,
        qpa_steps=verdict.steps,
        w=w,
        name=ts.name,
        overhead=float(overhead),
        offsets_ignored=any(t.offset > 0 for t in tasks),
        suspension=suspension,
        resources=protocol,
    )
