"""Blocking on shared resources: preemption levels, resource ceilings and blocking terms.

The stack form of the ceiling protocols ``pcp`` (immediate ceiling), ``srp`` and ``npr``, which
`rtsim.sim.cpu` runs and this module bounds: B_i under fixed priority (Sha, Rajkumar &
Lehoczky 1990; once per compute stretch with idle suspensions, Rajkumar 1991) and B(t) for
EDF with SRP (Baker 1991 in Baruah's 2006 demand form), each plus the overhead o. The
protocols, the formulas and why they hold: docs/resources.md (What the analyses add).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from rtsim.errors import TaskSetError
from rtsim.model.task import RESOURCE_PROTOCOLS, Task

__all__ = [
    "sections",
    "uses",
    "levels",
    "ceilings",
    "fp_blocking",
    "edf_blocking",
    "check_protocol",
    "blocking_overhead",
    "LEVEL_BY",
]

#: How a policy orders preemption levels: ``fp`` by priority, ``edf`` by relative deadline.
LEVEL_BY = {"edf": "deadline"}


def sections(task: Task) -> list[tuple[str, float]]:
    """(resource, length) of every critical section of one job of ``task``."""
    return [(s.resource, s.wcet) for s in task.chain() if s.resource is not None]


def uses(tasks: Sequence[Task]) -> dict[str, list[int]]:
    """resource → the indices of the tasks that use it."""
    out: dict[str, list[int]] = {}
    for i, t in enumerate(tasks):
        for r in sorted(t.resources):
            out.setdefault(r, []).append(i)
    return out


def levels(tasks: Sequence[Task], by: str = "priority") -> list[float]:
    """Preemption levels (larger = higher): −priority, or −relative deadline (``deadline``)."""
    if by == "deadline":
        out = []
        for t in tasks:
            if t.per_window:
                raise TaskSetError(
                    f"task '{t.name}': period is a multiple of w; resolve it "
                    f"with at_window(w) first"
                )
            assert t.deadline is not None
            out.append(-float(t.deadline))
        return out
    return [-float(t.priority) for t in tasks]


def ceilings(tasks: Sequence[Task], protocol: str, by: str = "priority") -> dict[str, float]:
    """resource → its ceiling: the highest level of its users (``npr``: +inf)."""
    lv = levels(tasks, by)
    return {
        r: math.inf if protocol == "npr" else max(lv[i] for i in users)
        for r, users in uses(tasks).items()
    }


def check_protocol(protocol: str, scheduler: str, where: str = "resources") -> None:
    """Refuse an unknown protocol, and ``pcp`` under EDF (it needs fixed priorities)."""
    if protocol not in RESOURCE_PROTOCOLS:
        raise TaskSetError(
            f"{where}: must be one of {', '.join(RESOURCE_PROTOCOLS)}, got {protocol!r}"
        )
    if protocol == "pcp" and LEVEL_BY.get(scheduler) == "deadline":
        raise TaskSetError(
            f"{where}: pcp needs fixed priorities; under {scheduler} use srp "
            f"(the stack resource policy) or npr"
        )


def blocking_overhead(section: float, overhead: float) -> float:
    """One blocking of length ``section`` with the switch into it (module doc): |z| + o."""
    return section + overhead if overhead else section


def fp_blocking(tasks: Sequence[Task], protocol: str | None, overhead: float = 0.0) -> list[float]:
    """B_i of every task under fixed priorities (module doc): the longest section of a
    lower-priority task that can block i once, with the switch into it (``overhead``, ms).
    0 for every task when ``protocol`` is None."""
    n = len(tasks)
    if protocol is None:
        return [0.0] * n
    ceil = ceilings(tasks, protocol)
    secs = [sections(t) for t in tasks]
    out = []
    for ti in tasks:
        li = -float(ti.priority)
        b = 0.0
        for j, tj in enumerate(tasks):
            if tj.priority <= ti.priority:
                continue
            for r, length in secs[j]:
                if ceil[r] >= li:
                    b = max(b, length)
        out.append(blocking_overhead(b, overhead) if b > 0 else 0.0)
    return out


def edf_blocking(
    tasks: Sequence[Task], protocol: str | None, overhead: float = 0.0
) -> Callable[[float], float]:
    """B(t) under EDF (module doc), with the switch into the section (``overhead``, ms); the
    zero function when ``protocol`` is None."""
    if protocol is None or not any(t.resources for t in tasks):
        return lambda t: 0.0
    by_r = uses(tasks)
    dl = [float(t.deadline) for t in tasks]  # type: ignore[arg-type]
    min_user_d = {r: min(dl[i] for i in users) for r, users in by_r.items()}
    secs = [(dl[j], r, length) for j, t in enumerate(tasks) for r, length in sections(t)]
    due = sorted((d - t.jitter, d) for d, t in zip(dl, tasks, strict=True))
    tol = 1e-9

    def blocking(t: float) -> float:
        # the largest relative deadline among tasks with a job due by t (D_k − J_k ≤ t)
        reach = max((d for dj, d in due if dj <= t + tol), default=-math.inf)
        if reach == -math.inf:
            return 0.0
        b = 0.0
        for d_j, r, length in secs:
            if d_j > t and (protocol == "npr" or min_user_d[r] <= reach + tol):
                b = max(b, length)
        return blocking_overhead(b, overhead) if b > 0 else 0.0

    return blocking
