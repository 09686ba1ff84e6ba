"""The unifying response-time bound for dynamic self-suspending tasks (Chen, Nelissen & Huang,
ECRTS 2016, Theorem 1, in the form the 2019 review of self-suspension presents as sound):
each higher task's suspension counted as jitter or as computation with its carry-in, the
least over the choices ([`unified_bound`][rtsim.analysis.unified.unified_bound]). The
equation and rtsim's choices: docs/analysis-beyond.md.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

from rtsim.analysis.common import DEADLINE_TOL, ceil_div

__all__ = ["HigherTask", "unified_bound", "MAX_VECTORS"]

#: Every vector x is tried while there are at most this many.
MAX_VECTORS = 1 << 10
_MAX_STEPS = 1_000_000


@dataclass(frozen=True)
class HigherTask:
    """A higher-priority task as the bound sees it (ms): compute C (bare), the cost per job
    charged as interference (C plus overhead), suspension S, period T, release jitter J and
    its sound response bound R (from arrival)."""

    c: float
    cost: float
    s: float
    period: float
    jitter: float
    wcrt: float


def _least(c_own: float, hp: Sequence[HigherTask], x: Sequence[int], limit: float) -> float | None:
    """The least t of the theorem for vector x (module doc), None past ``limit``."""
    q = [0.0] * len(hp)
    acc = 0.0
    for i in range(len(hp) - 1, -1, -1):  # Q_i: suspensions of x-tasks at or below i
        acc += hp[i].s * x[i]
        q[i] = acc
    shift = [q[i] + (1 - x[i]) * (hp[i].wcrt - hp[i].c) for i in range(len(hp))]
    t = c_own + math.fsum(h.cost for h in hp)
    for _ in range(_MAX_STEPS):
        if t > limit:
            return None
        nxt = c_own + math.fsum(
            ceil_div(t + sh, h.period) * h.cost for h, sh in zip(hp, shift, strict=True)
        )
        if nxt <= t:
            return t
        t = nxt
    return None


def _vectors(hp: Sequence[HigherTask]) -> list[tuple[int, ...]]:
    free = [i for i, h in enumerate(hp) if h.jitter == 0.0]
    if 2 ** len(free) <= MAX_VECTORS:
        out = []
        for bits in itertools.product((0, 1), repeat=len(free)):
            x = [0] * len(hp)
            for i, b in zip(free, bits, strict=True):
                x[i] = b
            out.append(tuple(x))
        return out
    zero = tuple(0 for _ in hp)
    small = tuple(int(h.jitter == 0.0 and h.s <= h.c) for h in hp)
    lin = []
    u_sum = 0.0
    for h in hp:
        u = h.c / h.period
        u_sum += u
        lin.append(int(h.jitter == 0.0 and u * (h.wcrt - h.c) > h.s * u_sum))
    return [zero, small, tuple(lin)]


def unified_bound(
    c: float, s: float, period: float, deadline: float, jitter: float, hp: Sequence[HigherTask]
) -> float | None:
    """Response bound from arrival of a task with compute c (overhead included), suspension
    s, period, deadline and release jitter below ``hp`` (highest priority first), or None
    where the theorem does not apply or the bound passes min(deadline, period) (module doc).
    """
    if deadline > period + DEADLINE_TOL:
        return None
    if any(h.wcrt > h.period + DEADLINE_TOL for h in hp):
        return None
    limit = min(deadline, period) + DEADLINE_TOL - jitter
    best: float | None = None
    for x in _vectors(hp):
        r = _least(c + s, hp, x, limit if best is None else min(limit, best))
        if r is not None and (best is None or r < best):
            best = r
    return None if best is None else jitter + best
