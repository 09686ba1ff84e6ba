"""Random task sets for experiments: UUniFast utilizations and log-uniform or listed periods.

- UUniFast (Bini & Buttazzo, "Measuring the performance of schedulability tests", 2005):
  n utilizations uniformly distributed on the simplex Σ u_i = U.
- UUniFast-Discard (Davis & Burns 2009): UUniFast, redrawn until every u_i ≤ 1 (needed when
  U > 1, e.g. for multiprocessor or overload experiments).
- Periods log-uniform in [lo, hi] (Emberson, Stafford & Davis 2010), optionally rounded to a
  granularity, or drawn uniformly from a given set (small hyperperiods).

Priorities are deadline-monotonic (ties by period, then index); wcet = u_i · p_i.
All randomness comes from the ``numpy.random.Generator`` passed in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rtsim._numbers import is_int, is_real
from rtsim.errors import InputError
from rtsim.io.ranges import parse_values
from rtsim.model.task import Task
from rtsim.model.taskset import TaskSet

__all__ = [
    "PeriodSpec",
    "parse_periods",
    "uunifast",
    "uunifast_discard",
    "draw_periods",
    "random_taskset",
]


def uunifast(n: int, u: float, rng: np.random.Generator) -> np.ndarray:
    """n utilizations summing to ``u``, uniform on the simplex (UUniFast)."""
    if not is_int(n) or n < 1:
        raise InputError(f"uunifast: n must be a positive integer, got {n!r}")
    if not (is_real(u) and math.isfinite(u) and u > 0):
        raise InputError(f"uunifast: utilization must be positive, got {u!r}")
    out = np.empty(n)
    remaining = float(u)
    for i in range(n - 1):
        nxt = remaining * rng.random() ** (1.0 / (n - 1 - i))
        out[i] = remaining - nxt
        remaining = nxt
    out[n - 1] = remaining
    return out


def uunifast_discard(
    n: int, u: float, rng: np.random.Generator, *, max_tries: int = 10_000
) -> np.ndarray:
    """UUniFast, redrawing any vector with a utilization above 1 (UUniFast-Discard)."""
    if u > n:
        raise InputError(f"uunifast-discard: utilization {u:g} is above n = {n}")
    for _ in range(max_tries):
        us = uunifast(n, u, rng)
        if np.all(us <= 1.0):
            return us
    raise InputError(
        f"uunifast-discard: no vector with every u_i <= 1 after {max_tries} tries (n={n}, U={u:g})"
    )


@dataclass(frozen=True)
class PeriodSpec:
    """Log-uniform in [lo, hi] (``choices`` empty) or uniform over ``choices`` (ms)."""

    lo: float = 10.0
    hi: float = 1000.0
    choices: tuple[float, ...] = ()
    granularity: float | None = None

    def __post_init__(self) -> None:
        if self.choices:
            if any(not (math.isfinite(c) and c > 0) for c in self.choices):
                raise InputError(f"periods: every period must be positive, got {self.choices}")
        elif not (0 < self.lo <= self.hi and math.isfinite(self.hi)):
            raise InputError(f"periods: need 0 < lo <= hi, got {self.lo:g}..{self.hi:g}")


def parse_periods(text: str) -> PeriodSpec:
    """``loguniform:LO..HI`` or a comma list ``10,20,40`` (ms)."""
    text = text.strip()
    if text.startswith("loguniform:"):
        body = text.split(":", 1)[1]
        if ".." not in body:
            raise InputError(f"--periods: expected loguniform:LO..HI, got {text!r}")
        lo_s, hi_s = body.split("..", 1)
        lo, hi = parse_values(lo_s, "--periods")[0], parse_values(hi_s, "--periods")[0]
        return PeriodSpec(lo, hi)
    if ".." in text:
        raise InputError(f"--periods: expected loguniform:LO..HI or a list, got {text!r}")
    return PeriodSpec(choices=tuple(parse_values(text, "--periods")))


def draw_periods(n: int, spec: PeriodSpec, rng: np.random.Generator) -> np.ndarray:
    """n periods (ms) as ``spec`` says."""
    if spec.choices:
        return np.asarray(spec.choices, dtype=float)[rng.integers(len(spec.choices), size=n)]
    ps = np.exp(rng.uniform(math.log(spec.lo), math.log(spec.hi), size=n))
    if spec.granularity:
        ps = np.maximum(spec.granularity, np.round(ps / spec.granularity) * spec.granularity)
    return ps


def random_taskset(
    n: int,
    u: float,
    rng: np.random.Generator,
    periods: PeriodSpec | str = "loguniform:10..1000",
    *,
    name: str = "random",
    deadline_factor: tuple[float, float] = (1.0, 1.0),
) -> TaskSet:
    """A random set of n tasks of total utilization u (UUniFast-Discard when u > 1).

    Deadlines are drawn uniformly in [a·max(e, …), b·p] for ``deadline_factor = (a, b)``,
    i.e. implicit by default; priorities deadline-monotonic.
    """
    spec = parse_periods(periods) if isinstance(periods, str) else periods
    us = uunifast_discard(n, u, rng) if u > 1 else uunifast(n, u, rng)
    ps = draw_periods(n, spec, rng)
    a, b = deadline_factor
    if not (0 < a <= b <= 1):
        raise InputError(f"deadline_factor must satisfy 0 < a <= b <= 1, got {(a, b)}")
    rows = []
    for i in range(n):
        p = float(ps[i])
        e = max(float(us[i]) * p, 1e-9)
        d = p if a == b == 1 else float(rng.uniform(max(a * p, e), max(b * p, e)))
        rows.append((d, p, i, e))
    order = sorted(rows)
    tasks = [
        Task(f"tau{k + 1}", e, p, deadline=d, priority=k + 1)
        for k, (d, p, _, e) in enumerate(order)
    ]
    return TaskSet(tuple(tasks), name=name)
