"""Self-suspension (the radio round trip Δt with the CPU idle): suspension-aware response times.

Only treatments that the survey of Chen, Nelissen, Huang, Yang, Kim, Brandenburg, Bril et al.,
"Many suspensions, many problems: a review of self-suspending tasks in real-time systems",
Real-Time Systems 55 (2019), confirms sound are used (docs/model/beyond.md):

(a) **suspension-oblivious**: every suspension counted as computation (the paper's Eqs 7/11 and
    [`rtsim.analysis.rta.response_time`][rtsim.analysis.rta.response_time]); sound for every task,
    suspending or not.
(b) **segmented**, for a suspending task whose higher-priority tasks do not suspend: each
    compute stretch's response with its own critical instant, plus every suspension:
    R = J + Σ_s R_s + Σ S, with R_s the least fixed point of w = C_s + Σ_hp ⌈(w + J_j)/T_j⌉ C_j.
    Used only when R ≤ T (no job of the task is pending when the next one arrives).
(c) **suspension as release jitter**, for a non-suspending task below suspending ones: each
    higher suspending task j acts as a task of its compute time C_j (suspensions excluded) with
    release jitter R_j − C_j, R_j its own bound (from arrival, own jitter included). The
    flawed variants the survey lists (jitter S_j instead of R_j − C_j; dynamic-suspension
    analyses ignoring carry-in) are not used.

(d) **unified**, for any task below a suspending one, including a suspending task below
    suspending ones (which (b) and (c) leave to (a)): Theorem 1 of Chen, Nelissen & Huang,
    ECRTS 2016, each higher task's suspension either as jitter R_i − C_i or as computation
    with its carry-in, as the survey states it (`rtsim.analysis.unified`).

Each task takes the least of its sound bounds: (a) and, where they apply, (b) or (c), and (d)
— the jitter form can count one more window job than the oblivious one, so none dominates.
Context-switch overhead o is charged as in `rtsim.analysis.rta` (2·o per higher compute
stretch, o per own stretch). Offsets are ignored (sound).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from rtsim.analysis.common import DEADLINE_TOL, busy_window, ceil_div, stretches
from rtsim.analysis.unified import HigherTask, unified_bound
from rtsim.model.task import Task

__all__ = ["SuspensionBound", "suspension_aware", "compute_time", "suspends"]

#: Fixed-point steps of one segment's response before giving up.
_MAX_STEPS = 1_000_000


@dataclass(frozen=True)
class SuspensionBound:
    """One task's suspension-aware bound (ms, from arrival; None = above the deadline).

    ``oblivious`` is bound (a), ``other`` bound (b) or (c) where it applies (``kind`` names it:
    ``"segmented"``, ``"jitter"`` or ``""``), ``unified`` bound (d) where some higher task
    suspends, ``wcrt`` the least of them.
    """

    name: str
    wcrt: float | None
    oblivious: float | None
    other: float | None
    kind: str
    unified: float | None = None


def suspends(task: Task) -> bool:
    """Whether a job of ``task`` has a suspension segment of positive length."""
    return any(s.kind == "suspend" and s.wcet > 0 for s in task.chain())


def compute_time(task: Task) -> float:
    """C: the task's compute segments only (its suspensions left out)."""
    return math.fsum(s.wcet for s in task.chain() if s.kind == "compute")


def _compute_runs(task: Task) -> tuple[list[float], float]:
    """(the compute stretches' lengths, the total suspension) of one job."""
    runs: list[float] = []
    inside = False
    susp = 0.0
    for s in task.chain():
        if s.kind == "compute":
            if inside:
                runs[-1] += s.wcet
            else:
                runs.append(s.wcet)
            inside = True
        else:
            susp += s.wcet
            inside = False
    return runs or [0.0], susp


def _segment_response(
    c: float, hp: Sequence[tuple[float, float, float]], limit: float
) -> float | None:
    """Least w = c + Σ ⌈(w + J_j)/T_j⌉ C_j (one segment, critical instant), None past limit."""
    w = c + math.fsum(cj for cj, _, _ in hp)
    for _ in range(_MAX_STEPS):
        if w > limit:
            return None
        nxt = c + math.fsum(ceil_div(w + jj, tj) * cj for cj, tj, jj in hp)
        if nxt <= w:
            return w
        w = nxt
    return None


def _unified(
    task: Task, higher: Sequence[Task], done: Sequence[SuspensionBound], o: float, blk: float = 0.0
) -> float | None:
    """Bound (d) of ``task`` below ``higher`` (module doc), None where it does not apply."""
    hp = []
    for t, b in zip(higher, done, strict=True):
        if b.wcrt is None:
            return None
        c = compute_time(t)
        hp.append(HigherTask(c, c + 2.0 * o * stretches(t), t.wcet - c, t.period, t.jitter, b.wcrt))
    c = compute_time(task)
    d = task.period if task.deadline is None else task.deadline
    return unified_bound(
        c + (o + blk) * stretches(task), task.wcet - c, task.period, d, task.jitter, hp
    )


def suspension_aware(
    tasks: Sequence[Task], overhead: float = 0.0, blocking: Sequence[float] | None = None
) -> list[SuspensionBound]:
    """Bounds of every task of a resolved set, highest priority first (module doc).

    ``blocking``: each task's blocking term B (in the order of ``tasks``,
    [`rtsim.analysis.blocking`][rtsim.analysis.blocking]); a lower job can lock a resource while a
    job suspends, so
    each compute stretch of a job can be blocked once: every bound charges B per stretch."""
    o = float(overhead)
    order = sorted(range(len(tasks)), key=lambda k: tasks[k].priority)
    ordered = [tasks[k] for k in order]
    block = [0.0] * len(tasks) if blocking is None else [blocking[k] for k in order]
    out: list[SuspensionBound] = []
    for i, task in enumerate(ordered):
        higher = ordered[:i]
        d = task.period if task.deadline is None else task.deadline
        own = task.wcet + (o + block[i]) * stretches(task)
        obl_hp = [(t.wcet + 2.0 * o * stretches(t), t.period, t.jitter) for t in higher]
        obl = busy_window(own, task.period, task.jitter, d, obl_hp)
        other: float | None = None
        kind = ""
        hp_susp = [k for k, t in enumerate(higher) if suspends(t)]
        if suspends(task) and not hp_susp:
            kind = "segmented"
            runs, susp = _compute_runs(task)
            total = task.jitter + susp
            for c in runs:
                r = _segment_response(c + o + block[i], obl_hp, d + DEADLINE_TOL - total)
                if r is None:
                    total = math.inf
                    break
                total += r
            if total <= min(d, task.period) + DEADLINE_TOL:
                other = total
        elif hp_susp and not suspends(task):
            kind = "jitter"
            hp = list(obl_hp)
            usable = True
            for k in hp_susp:
                rk = out[k].wcrt
                if rk is None:
                    usable = False
                    break
                t = higher[k]
                c = compute_time(t)
                hp[k] = (c + 2.0 * o * stretches(t), t.period, max(rk - c, 0.0))
            if usable:
                other = busy_window(own, task.period, task.jitter, d, hp)
        unified = _unified(task, higher, out, o, block[i]) if hp_susp else None
        bounds = [b for b in (obl, other, unified) if b is not None]
        out.append(
            SuspensionBound(task.name, min(bounds) if bounds else None, obl, other, kind, unified)
        )
    return out
