"""Utilization-based schedulability tests for rate-monotonic scheduling.

- Liu & Layland (1973): U = Σ e_i/p_i ≤ n(2^{1/n} − 1).
- Hyperbolic bound, Bini, Buttazzo & Buttazzo (2003): Π (U_i + 1) ≤ 2.

Both are *sufficient* tests, and only for independent periodic tasks with implicit deadlines
(D_i = p_i) under rate-monotonic priorities (a shorter period never has a lower priority).
When a set is not of that kind the tests do not apply and both functions return ``False``,
which always means "not proven schedulable by this test", never "unschedulable";
[`rm_implicit`][rtsim.analysis.utilization.rm_implicit] tells the two cases apart. The exact answer
is
[`rtsim.analysis.rta.analyze`][rtsim.analysis.rta.analyze].

The functions take any objects with ``period``, ``deadline``, ``priority`` and
``utilization`` attributes: [`Task`][rtsim.model.task.Task] (periods in ms) or
[`TaskResult`][rtsim.analysis.rta.TaskResult].
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Protocol

__all__ = [
    "hyperbolic",
    "hyperbolic_product",
    "liu_layland",
    "liu_layland_bound",
    "rm_implicit",
    "total_utilization",
]

#: Slack allowed in the comparisons against the bounds (float rounding of sums and products).
TOLERANCE = 1e-12


class Periodic(Protocol):
    """What the tests need to know about a task."""

    @property
    def period(self) -> float: ...
    @property
    def deadline(self) -> float | None: ...
    @property
    def priority(self) -> int: ...
    @property
    def utilization(self) -> float: ...


def total_utilization(tasks: Sequence[Periodic]) -> float:
    """U = Σ e_i / p_i."""
    return math.fsum(t.utilization for t in tasks)


def liu_layland_bound(n: int) -> float:
    """n(2^{1/n} − 1): 1 for n = 1, falling towards ln 2 ≈ 0.693."""
    if n < 1:
        raise ValueError(f"n must be at least 1, got {n!r}")
    return n * (2.0 ** (1.0 / n) - 1.0)


def hyperbolic_product(tasks: Sequence[Periodic]) -> float:
    """Π (U_i + 1)."""
    return math.prod(t.utilization + 1.0 for t in tasks)


def rm_implicit(tasks: Sequence[Periodic]) -> bool:
    """True when every deadline equals its period and the priorities are rate-monotonic."""
    for t in tasks:
        d = t.period if t.deadline is None else t.deadline
        if not math.isclose(d, t.period, rel_tol=1e-12, abs_tol=0.0):
            return False
    ordered = sorted(tasks, key=lambda t: t.priority)
    return all(a.period <= b.period for a, b in zip(ordered, ordered[1:], strict=False))


def liu_layland(tasks: Sequence[Periodic]) -> bool:
    """Liu–Layland test: U ≤ n(2^{1/n} − 1); ``False`` when it does not apply (see module)."""
    if not tasks:
        return True
    if not rm_implicit(tasks):
        return False
    return total_utilization(tasks) <= liu_layland_bound(len(tasks)) + TOLERANCE


def hyperbolic(tasks: Sequence[Periodic]) -> bool:
    """Hyperbolic test: Π(U_i + 1) ≤ 2; ``False`` when it does not apply (see module)."""
    if not tasks:
        return True
    if not rm_implicit(tasks):
        return False
    return hyperbolic_product(tasks) <= 2.0 + TOLERANCE
