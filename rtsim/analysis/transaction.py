"""Offset-based response times: the window chain and its per-window tasks as one transaction.

Tindell (1994) and Palencia & González Harbour (1998): one transaction of period L·w holds the
window jobs and the tasks with a period m·w, every other task is its own; a job's stretches
after a suspension have dynamic offsets; the interference W_ik (their Eq. 3) and its bound
W*_i = max_k W_ik enter a busy-window fixed point per stretch. Fixed-priority preemptive, one
job of a task at a time (checked). Model, equations and numerics: docs/analysis.md (the
window chain and the command task as a transaction).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from rtsim.analysis.rta import CEIL_TOL, DEADLINE_TOL, analyze, ceil_div
from rtsim.io.work import _WHAT, LIMITS, TooMuchWork, check_work
from rtsim.model.task import Segment, Task

if TYPE_CHECKING:
    from rtsim.analysis.rta import Analysis
    from rtsim.model.taskset import TaskSet

__all__ = [
    "with_transaction_bounds",
    "Job",
    "Step",
    "Transaction",
    "analyze_transactions",
    "transactions_of",
    "transaction_bounds",
    "transaction_work",
    "MAX_JOBS",
]

#: Largest number of window jobs in one transaction (L); beyond it per-window tasks are
#: analysed as transactions of their own (sound, without the offsets).
MAX_JOBS = 64
#: Fixed-point steps of one response before giving up.
_MAX_STEPS = 100_000
_PHASE_TOL = 1e-9


@dataclass(frozen=True)
class Job:
    """One job of a task inside a transaction: its arrival (ms after the activation), its
    release jitter, the time to the next job of its task and its relative deadline."""

    task: str
    priority: int
    arrival: float
    jitter: float
    spacing: float
    deadline: float
    segments: tuple[Segment, ...]
    bcet_scale: float | None = None  # a task-level bcet scaled per segment (see Uniform)


@dataclass(frozen=True)
class Transaction:
    """A stream of activations with period ``period`` and the jobs of one activation."""

    period: float
    jobs: tuple[Job, ...]


@dataclass(frozen=True)
class Step:
    """One compute stretch of one job: best-case release Φ, jitter J, WCET C (ms)."""

    task: str
    priority: int
    offset: float
    jitter: float
    wcet: float


def _phase(phi_j: float, phi_k: float, j_k: float, period: float) -> float:
    """(Φ_j − Φ_k − J_k) mod T in [0, T), a value within 1e-9 ms of T or 0 taken as 0."""
    ph = math.fmod(phi_j - phi_k - j_k, period)
    if ph < 0.0:
        ph += period
    if ph < _PHASE_TOL or ph > period - _PHASE_TOL:
        return 0.0
    return ph


class _Budget:
    """The interference terms (one step of one W_ik) the analysis may still evaluate
    (``None``: no limit); over it, `TooMuchWork` naming ``where``."""

    def __init__(self, limit: float | None, where: str) -> None:
        self.left = math.inf if limit is None else limit
        self.limit, self.where = limit, where

    def spend(self, n: int) -> None:
        self.left -= n
        if self.left < 0:
            raise TooMuchWork(
                f"{self.where}: more than {self.limit:.3g} {_WHAT['interference']} (the limit "
                f"is {LIMITS['interference']:.3g}); use --force (force=True in Python) to "
                "run it anyway"
            )


_NO_BUDGET = _Budget(None, "")


def _work(
    steps: Sequence[Step],
    period: float,
    k: Step,
    t: float,
    cost: float,
    budget: _Budget = _NO_BUDGET,
) -> float:
    """W_ik(t) (module doc): the work of ``steps`` of one transaction released in [t_c, t_c + t)
    when step ``k`` is released at t_c after its largest jitter; ``cost`` is added per job."""
    budget.spend(len(steps))
    total = 0.0
    for s in steps:
        ph = _phase(s.offset, k.offset, k.jitter, period)
        n = math.floor((ph + s.jitter + _PHASE_TOL) / period)
        if t > ph:
            n += max(ceil_div(t - ph, period), 0)
        total += n * (s.wcet + cost)
    return total


def _segments_best(job: Job, seg: Segment) -> float:
    if seg.bcet is not None:
        return seg.bcet
    if job.bcet_scale is not None:
        return seg.wcet * job.bcet_scale
    return 0.0


def _stretches(job: Job, suspension: str) -> list[tuple[str, float, float]]:
    """The job's chain as ("c" | "s", worst, best) runs, compute merged; suspensions are
    computation under ``suspension="cpu"``."""
    out: list[tuple[str, float, float]] = []
    for seg in job.segments:
        kind = "c" if seg.kind == "compute" or suspension == "cpu" else "s"
        best = _segments_best(job, seg)
        if out and out[-1][0] == kind:
            _, w, b = out[-1]
            out[-1] = (kind, w + seg.wcet, b + best)
        else:
            out.append((kind, seg.wcet, best))
    return out


def _step_response(
    own: Step,
    own_period: float,
    own_hp: Sequence[Step],
    others: Sequence[tuple[float, Sequence[Step]]],
    overhead: float,
    limit: float,
    budget: _Budget = _NO_BUDGET,
) -> float | None:
    """Worst completion of ``own`` after its earliest release (module doc), or None past
    ``limit`` (ms after the earliest release) or when the busy period does not close."""
    c = own.wcet + overhead
    cost = 2.0 * overhead

    def others_work(t: float) -> float:
        return math.fsum(
            max(_work(hp, per, k, t, cost, budget) for k in hp) for per, hp in others if hp
        )

    util = math.fsum((s.wcet + cost) / per for per, hp in others for s in hp)
    util += math.fsum((s.wcet + cost) / own_period for s in own_hp)
    if util >= 1.0:
        return None
    worst = 0.0
    for k in (*own_hp, own):
        phase = _phase(own.offset, k.offset, k.jitter, own_period)

        def hp_work(t: float, k: Step = k) -> float:
            return _work(own_hp, own_period, k, t, cost, budget) + others_work(t)

        def fixpoint(start: float, extra: float) -> float | None:
            w = start
            for _ in range(_MAX_STEPS):
                nxt = max(extra + hp_work(w), start)
                if nxt <= w:
                    return w
                if nxt > limit + start + own_period:
                    return None
                w = nxt
            return None

        releases: list[float] = []  # the stretch's earliest release, relative to t_c
        back = math.floor((phase + own.jitter + _PHASE_TOL) / own_period)
        if back >= 1:  # an earlier activation's release delayed to t_c
            releases.append(phase - back * own_period)
        busy = fixpoint(2.0 * CEIL_TOL, 0.0) if own_hp or any(hp for _, hp in others) else 0.0
        if busy is None:
            return None
        m = 0
        while True:
            e = phase + m * own_period
            if m > 0 and e >= busy - CEIL_TOL:
                break
            releases.append(e)
            m += 1
            if m > _MAX_STEPS:
                return None
        for e in releases:
            f = fixpoint(max(e, 0.0) + c, c)
            if f is None:
                return None
            r = f - e
            if r > limit + DEADLINE_TOL:
                return None
            worst = max(worst, r)
    return worst


def analyze_transactions(
    transactions: Sequence[Transaction],
    *,
    overhead: float = 0.0,
    suspension: str = "idle",
    known: Mapping[str, float | None] | None = None,
    budget: float | None = None,
    where: str = "transaction analysis",
) -> dict[str, float | None]:
    """Offset-based bounds of every task in ``transactions`` (module doc): task name → the
    largest response of its jobs from their arrivals (ms), or None where the task's bound
    passes the next arrival of its task (the analysis does not apply to it and to every
    task below it). Deadlines are not checked here. ``budget``: the most interference terms
    to evaluate (None: no limit); beyond it `TooMuchWork` naming
    ``where``.

    ``known``: sound bounds (ms from arrival) that other analyses give for some tasks. A job
    completes by its arrival plus that bound, so a stretch completes by it less the best
    case of what follows it: the latest releases (jitters) of the stretches after it, and
    the task's own result, are capped there."""
    if suspension not in ("cpu", "idle"):
        raise ValueError(f"suspension must be 'cpu' or 'idle', got {suspension!r}")
    o = float(overhead)
    known = known or {}
    spend = _Budget(budget, where)
    # each level's jobs by transaction, and each transaction's analysed steps, kept as the
    # levels go down (O(n) per level: no list of the finished steps is rebuilt)
    at: dict[int, dict[int, list[Job]]] = {}
    for a, tx in enumerate(transactions):
        for job in tx.jobs:
            at.setdefault(job.priority, {}).setdefault(a, []).append(job)
    prios = sorted(at)
    done: dict[int, list[Step]] = {}  # transaction index -> steps of analysed tasks
    out: dict[str, float | None] = {}
    failed = False
    for prio in prios:
        names = sorted({j.task for jobs in at[prio].values() for j in jobs})
        if failed:
            for nm in names:
                out[nm] = None
            continue
        new: list[tuple[int, Step]] = []
        worst: dict[str, float] = {}
        ok = True
        for a, jobs in at[prio].items():
            tx = transactions[a]
            own_hp = list(done.get(a, ()))
            others = [(transactions[b].period, st) for b, st in done.items() if b != a and st]
            for job in jobs:
                if not ok:
                    continue
                cap = known.get(job.task)
                runs = _stretches(job, suspension)
                after = [math.fsum(bc for _, _, bc in runs[i + 1 :]) for i in range(len(runs))]
                best, late = job.arrival, job.arrival + job.jitter
                for i, (kind, wc, bc) in enumerate(runs):
                    if kind == "s":
                        best, late = best + bc, late + wc
                        continue
                    step = Step(job.task, prio, best, late - best, wc)
                    limit = job.arrival + job.spacing - best
                    r = _step_response(step, tx.period, own_hp, others, o, limit, spend)
                    end = math.inf if r is None else best + r
                    if cap is not None:
                        end = min(end, job.arrival + cap - after[i])
                    if not math.isfinite(end):
                        ok = False
                        break
                    new.append((a, step))
                    best, late = best + bc, end
                if not ok:
                    break
                resp = late - job.arrival
                if cap is not None:
                    resp = min(resp, cap)
                if resp > job.spacing + DEADLINE_TOL:
                    ok = False
                    break
                worst[job.task] = max(worst.get(job.task, 0.0), resp)
        if not ok:
            failed = True
            for nm in names:
                out[nm] = None
            continue
        for nm in names:
            out[nm] = worst.get(nm)
        for a, step in new:
            done.setdefault(a, []).append(step)
    return out


def _multiple(x: float) -> int | None:
    m = round(x)
    return m if m >= 1 and abs(x - m) <= 1e-9 * max(1.0, x) else None


def _bcet_scale(task: Task) -> float | None:
    return task.bcet / task.wcet if task.bcet is not None and not task.segments else None


def transactions_of(
    ts: TaskSet, w: float | None, shifts: Mapping[str, float] | None = None
) -> list[Transaction]:
    """The transactions of ``ts`` at window ``w`` (module doc); a set without a window has
    one transaction per task. ``shifts``: extra arrival offsets (ms, either sign) of tasks
    whose period is a multiple of w, against the window's arrivals."""
    shifts = shifts or {}
    out: list[Transaction] = []
    linked: list[tuple[Task, int]] = []
    if ts.window is not None:
        assert w is not None
        for t in ts.tasks:
            m = _multiple(t.period) if t.per_window else None
            if t.per_window and m is not None:
                linked.append((t, m))
        lcm = 1
        for _, m in linked:
            lcm = lcm * m // math.gcd(lcm, m)
        if lcm > MAX_JOBS:
            linked, lcm = [], 1
        period = lcm * w
        chain = ts.window_task(w)
        jobs = [
            Job(chain.name, chain.priority, k * w, chain.jitter, w, w, chain.chain())
            for k in range(lcm)
        ]
        for t, m in linked:
            assert t.deadline is not None
            jobs += [
                Job(
                    t.name,
                    t.priority,
                    (t.offset + shifts.get(t.name, 0.0)) % (m * w) + i * m * w,
                    t.jitter,
                    m * w,
                    t.deadline * w,
                    t.chain(),
                    _bcet_scale(t),
                )
                for i in range(lcm // m)
            ]
        out.append(Transaction(period, tuple(jobs)))
    names = {t.name for t, _ in linked}
    for t in ts.tasks:
        if t.name in names:
            continue
        r = t.at_window(w) if t.per_window and w is not None else t
        assert r.deadline is not None
        out.append(
            Transaction(
                r.period,
                (
                    Job(
                        r.name,
                        r.priority,
                        0.0,
                        r.jitter,
                        r.period,
                        r.deadline,
                        r.chain(),
                        _bcet_scale(r),
                    ),
                ),
            )
        )
    return out


def transaction_bounds(
    ts: TaskSet,
    w: float | None,
    *,
    overhead: float | None = None,
    suspension: str = "idle",
    shifts: Mapping[str, float] | None = None,
    force: bool = False,
) -> dict[str, float | None]:
    """Offset-based WCRT of every task of ``ts`` at window ``w`` (ms from arrival; None where
    it passes the task's deadline or the analysis does not apply, as for a set with
    critical sections), fixed priority. ``shifts``: as for `transactions_of` (a
    simulation whose releases put per-window tasks' arrivals elsewhere than their offsets
    from the window's, e.g. jitter "worst", which moves every task's arrivals by the largest
    jitter less its own).

    Work limit (the command line's, `rtsim.io.work.LIMITS` ``interference``): the
    least work of the analysis, `transaction_work`, is checked before it starts, and
    the terms it evaluates are counted as it runs; above the limit
    `TooMuchWork` (one line, exit 2 on the command line) unless
    ``force=True`` (``--force``)."""
    o = ts.overhead if overhead is None else overhead
    if ts.has_sections:  # the offset-based analysis has no blocking term: it does not apply
        return {t.name: None for t in analyze(ts, w, overhead=o, suspension=suspension).tasks}
    txs = transactions_of(ts, w, shifts)
    where = f"{ts.source or ts.name or 'task set'}: the offset-based (transaction) analysis"
    check_work("interference", _least_work(txs, suspension), where, force=force)
    known = {t.name: t.wcrt for t in analyze(ts, w, overhead=o, suspension=suspension).tasks}
    raw = analyze_transactions(
        txs,
        overhead=o,
        suspension=suspension,
        known=known,
        budget=None if force else LIMITS["interference"],
        where=where,
    )
    deadlines = {j.task: j.deadline for tx in txs for j in tx.jobs}
    return {
        name: (r if r is not None and r <= deadlines[name] + DEADLINE_TOL else None)
        for name, r in raw.items()
    }


def with_transaction_bounds(ts: TaskSet, res: Analysis, *, force: bool = False) -> Analysis:
    """``res`` (a fixed-priority `rtsim.analysis.rta.analyze` of ``ts``) with each task's
    offset-based bound (`transaction_bounds`, at its window, overhead and suspension model)
    in ``transaction``, as `rtsim analyze` reports it; unchanged for a set with critical
    sections (the offset-based analysis has no blocking term) or an ``"either"`` result.
    Work limit and ``force`` as `transaction_bounds`."""
    from dataclasses import replace

    if ts.has_sections or res.suspension not in ("cpu", "idle"):
        return res
    txn = transaction_bounds(
        ts, res.w, overhead=res.overhead, suspension=res.suspension, force=force
    )
    return replace(res, transaction=txn)


def _least_work(transactions: Sequence[Transaction], suspension: str) -> float:
    """The interference terms
    [`analyze_transactions`][rtsim.analysis.transaction.analyze_transactions] evaluates at the
    least: for each
    compute stretch, one fixed-point step per candidate instant of its own transaction
    (its higher steps there, and itself) over every higher step of every transaction (the
    other transactions' W*_i take the maximum over their steps, |steps|² terms). A bound
    from below: every further fixed-point step costs as much again (counted as it runs)."""
    n = [0] * len(transactions)
    squares = 0
    total = 0.0
    for _, a, job in sorted(
        ((j.priority, a, j) for a, tx in enumerate(transactions) for j in tx.jobs),
        key=lambda x: x[0],
    ):
        k = sum(1 for kind, _, _ in _stretches(job, suspension) if kind == "c")
        total += k * (n[a] + 1) * (squares - n[a] * n[a] + n[a])
        squares += (n[a] + k) ** 2 - n[a] ** 2
        n[a] += k
    return total


def transaction_work(ts: TaskSet, w: float | None, *, suspension: str = "idle") -> float:
    """The least work of [`transaction_bounds`][rtsim.analysis.transaction.transaction_bounds] for
    ``ts`` at ``w`` (interference terms,
    `_least_work`), the estimate its work limit checks before it starts."""
    return _least_work(transactions_of(ts, w), suspension)
