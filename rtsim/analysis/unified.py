"""The unifying response-time bound for dynamic self-suspending tasks (Chen, Nelissen & Huang,
"A Unifying Response Time Analysis Framework for Dynamic Self-suspending Tasks", ECRTS 2016,
Theorem 1), the form that the review of Chen, Nelissen, Huang, Yang, Brandenburg, Bletsas et
al., "Many suspensions, many problems: a review of self-suspending tasks in real-time
systems", Real-Time Systems 55 (2019), presents as sound (its treatment of suspension as
release jitter R_i − C_i, or as computation with the carry-in that the Q term below adds; the
flawed variants it lists — jitter S_i, or suspension-as-computation without that carry-in —
are not used).

Tasks by priority, τ_k under analysis with compute time C_k and suspension S_k per job; each
higher-priority τ_i has C_i, S_i, period T_i and a sound bound R_i ≤ T_i. For any vector
x ∈ {0, 1}^{hp}, the worst-case response time of τ_k (from its release) is at most the least
t > 0 with

    C_k + S_k + Σ_{i ∈ hp(k)} ⌈(t + Q_i + (1 − x_i)(R_i − C_i)) / T_i⌉ · C_i ≤ t,
    Q_i = Σ_{j ∈ hp(k), j at or below i} S_j · x_j.

x_i = 0 treats τ_i's suspension as release jitter R_i − C_i; x_i = 1 as computation, paid for
by Q. This is the case that rtsim's other suspension-aware bounds leave to the
suspension-oblivious one: a suspending task below suspending tasks (the task's own
suspension is counted as computation here, so the bound also covers tasks that suspend).

rtsim's use of it ([`unified_bound`][rtsim.analysis.unified.unified_bound]):

- x_i = 1 only for a higher task without release jitter (the theorem is for sporadic
  releases); a jittered one always gets x_i = 0, its R_i counted from arrival (its compute
  then lies within R_i of its arrival, so the jitter term holds);
- vectors: all of them while there are at most 2^10, else the three of the paper's
  Section 6 (all zero; x_i = 1 iff S_i ≤ C_i; and its linear rule x_i = 1 iff
  U_i (R_i − C_i) > S_i Σ_{j ≤ i} U_j); the least result is taken;
- it applies only when every higher task has a bound R_i ≤ T_i and τ_k has D_k ≤ T_k, and its
  result (plus τ_k's own release jitter J_k, from arrival) is kept only when it is at most
  min(D_k, T_k), so that no two jobs of τ_k are ever pending together;
- context-switch overhead o as in `rtsim.analysis.rta`: C_i + 2·o·s_i per higher job,
  C_k + o·s_k for τ_k (s: compute stretches); the jitter stays R_i − C_i with the bare C_i.
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
