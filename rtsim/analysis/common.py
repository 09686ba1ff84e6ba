"""What the analyses share: the tolerances of their comparisons, ⌈x/p⌉ with them, the compute
stretches of a job, and the level-i busy window (the numerics are described in
`rtsim.analysis.rta`, Numerics)."""

from __future__ import annotations

import math
from collections.abc import Sequence

from rtsim.model.task import Task

__all__ = ["CEIL_TOL", "DEADLINE_TOL", "MAX_BUSY_JOBS", "busy_window", "ceil_div", "stretches"]

#: ⌈x/p⌉ is computed as ⌈(x − CEIL_TOL)/p⌉ (absolute, ms): R = 3·p + 4e-14 counts 3 jobs.
CEIL_TOL = 1e-9
#: A response time up to DEADLINE_TOL ms above the deadline still meets it.
DEADLINE_TOL = 1e-9
#: Jobs of one level-i busy period examined before giving up (returning None).
MAX_BUSY_JOBS = 100_000


def ceil_div(x: float, p: float) -> int:
    """⌈x/p⌉ for times x, p (ms), x taken CEIL_TOL ms lower (module doc: Numerics)."""
    return math.ceil((x - CEIL_TOL) / p)


def stretches(task: Task) -> int:
    """Compute stretches of one job: runs of compute segments between suspensions (≥ 1)."""
    n, inside = 0, False
    for s in task.chain():
        if s.kind == "compute":
            if not inside:
                n += 1
            inside = True
        else:
            inside = False
    return max(n, 1)


def busy_window(
    c: float,
    t: float,
    j: float,
    d: float,
    hp: Sequence[tuple[float, float, float]],
    blocking: float = 0.0,
) -> float | None:
    """WCRT from arrival of a task (C, T, J, D) below ``hp`` = [(C_j, T_j, J_j)], or None.

    The level-i busy window with release jitter and arbitrary deadlines (module doc;
    Tindell, Burns & Wellings 1994). None once a response passes D (+ 1e-9 ms), at once when
    the level-i utilization exceeds 1 and the window cannot close, or after MAX_BUSY_JOBS jobs.
    ``blocking`` B (ms) is charged once per busy window, w = B + (q+1)·C + Σ ⌈(w + J_j)/T_j⌉·C_j
    (a lower-priority critical section, [`rtsim.analysis.blocking`][rtsim.analysis.blocking]).
    """
    limit = d + DEADLINE_TOL
    if c / t + math.fsum(cj / tj for cj, tj, _ in hp) > 1.0 + 1e-12 and (d > t or j > 0):
        return None  # level-i work grows without bound: some job misses any deadline
    worst = 0.0
    w = c + math.fsum(cj for cj, _, _ in hp)  # job 0 starts from C + Σ C_j
    if blocking:
        w += blocking
    for q in range(MAX_BUSY_JOBS):
        while True:
            if j + w - q * t > limit:
                return None
            nxt = (q + 1) * c + math.fsum(ceil_div(w + jj, tj) * cj for cj, tj, jj in hp)
            if blocking:
                nxt += blocking
            if nxt <= w:
                break
            w = nxt
        worst = max(worst, j + w - q * t)
        if w <= (q + 1) * t - j + DEADLINE_TOL:  # the busy window closes with job q
            return worst
        w += c  # job q+1 needs at least one more C
    return None
