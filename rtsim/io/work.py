"""The work a command would do, estimated before it starts (cheap upper bounds: jobs, windows,
world steps, grid points, backlog, EDF arrivals), and refused above a limit with one line
that names the input (`TooMuchWork`, exit 2) unless forced; the library applies the same
limits. The limits and what each counts: docs/reliability.md. A helper below every layer: it
imports only `rtsim.errors`, `rtsim._numbers` and the range table `rtsim.io.limits`.
"""

from __future__ import annotations

import math
from typing import Any

from rtsim._numbers import is_int
from rtsim.errors import InputError
from rtsim.io import limits

__all__ = [
    "LIMITS",
    "TooMuchWork",
    "check_work",
    "check_simulate",
    "check_coupled",
    "check_seed",
    "simulate_backlog",
]

#: The largest amount of each kind of work a command does without ``--force``.
LIMITS: dict[str, float] = {
    "jobs": 5e7,
    "windows": 2e6,
    "world_steps": 2e8,
    "grid": 1e5,
    "backlog": 1e6,
    "arrivals": 1e6,
    "interference": 1e7,
}

_WHAT = {
    "jobs": "jobs",
    "windows": "processing windows",
    "world_steps": "world steps x followers",
    "grid": "grid points",
    "backlog": "jobs waiting at once (the CPU is overloaded: finish-late jobs pile up in memory)",
    "arrivals": "arrivals for the EDF response-time bound to examine (the busy period is "
    "long against the periods)",
    "interference": "interference terms for the offset-based (transaction) analysis to "
    "evaluate (many tasks, or long busy periods)",
}


class TooMuchWork(InputError):
    """A run would do more work than its limit (see `LIMITS`); ``--force`` overrides."""


def check_work(kind: str, amount: float, where: str, *, force: bool = False) -> float:
    """Refuse ``amount`` of ``kind`` work (a key of `LIMITS`) above its limit.

    ``where`` names the input that sets the amount (``"--horizon 1e15"``,
    ``"test2.toml: duration"``). Returns ``amount``. A NaN or infinite amount is refused
    even with ``force`` (it would never finish).
    """
    limit = LIMITS[kind]
    if not math.isfinite(amount):
        raise TooMuchWork(f"{where}: the run would never finish ({_WHAT[kind]}: {amount})")
    if amount > limit and not force:
        raise TooMuchWork(
            f"{where}: about {amount:.3g} {_WHAT[kind]}, above the limit of "
            f"{limit:.3g}; use --force (force=True in Python) to run it anyway"
        )
    return amount


def simulate_jobs(ts: Any, horizon_ms: float, w: float | None) -> float:
    """Jobs released in [0, horizon): Σ horizon / period, periods in ms at window ``w``
    (a processing-window set's per-window periods and its chain need ``w``)."""
    tasks = ts.at_window(w).tasks if ts.window is not None and w is not None else ts.tasks
    total = 0.0
    for t in tasks:
        if t.per_window:
            continue
        total += math.ceil(horizon_ms / t.period) if horizon_ms / t.period < 1e300 else math.inf
    return total


def check_simulate(
    ts: Any, horizon_ms: float, w: float | None, where: str, *, force: bool = False
) -> None:
    """Refuse a simulation of more than ``LIMITS["jobs"]`` jobs (``where``: the horizon's
    name, e.g. ``--horizon 1e+15``)."""
    check_work("jobs", simulate_jobs(ts, horizon_ms, w), where, force=force)
    check_work("backlog", simulate_backlog(ts, horizon_ms, w), where, force=force)


def simulate_backlog(ts: Any, horizon_ms: float, w: float | None) -> float:
    """Jobs that may wait at once: 0 when the utilization at window ``w`` is at most 1;
    above 1, every job of a ``finish-late`` task released over the horizon (an upper
    bound: such jobs are never dropped, so an overloaded CPU queues them — ``skip`` and
    ``abort`` tasks bound their own backlog by their overload policy)."""
    if ts.window is not None and w is None:
        return 0.0  # the window is chosen by the run (w_sch or above: schedulable)
    tasks = ts.at_window(w).tasks if ts.window is not None else ts.tasks
    plain = [t for t in tasks if not t.per_window]
    if sum(t.wcet / t.period for t in plain) <= 1.0:
        return 0.0
    return float(
        sum(
            math.ceil(horizon_ms / t.period) if horizon_ms / t.period < 1e300 else math.inf
            for t in plain
            if t.overload == "finish-late"
        )
    )


def check_seed(seed: object, where: str) -> None:
    """Refuse an integer seed outside the CLI's ``--seed`` range (non-negative, 63 bits)."""
    if isinstance(seed, bool) or (is_int(seed) and not 0 <= int(seed) < 2**63):  # type: ignore[call-overload]
        raise InputError(
            f"{where}: {seed!r} is outside [0, 2**63 - 1] (a non-negative 63-bit integer)"
        )
    if is_int(seed):
        limits.check("option: --seed", seed, where)


def check_coupled(
    duration_ms: float, g_ms: float, step_ms: float, n: int, where: str, *, force: bool = False
) -> None:
    """Refuse a coupled run of more than ``LIMITS["windows"]`` windows (duration over the
    chain's processing time g, below which no window can be) or ``LIMITS["world_steps"]``
    world steps × followers (duration over the world step, times n)."""
    check_work("windows", duration_ms / g_ms if g_ms > 0 else math.inf, where, force=force)
    check_work("world_steps", duration_ms / step_ms * n, where, force=force)
