"""The work a command would do, estimated before it starts, and refused above a limit.

Each estimate is cheap (no simulation, nothing materialised) and an upper bound of what
the run would do; above its limit the command stops with one line that names the input and
says that ``--force`` runs it anyway (:class:`TooMuchWork`, exit 2). The limits admit the
long benchmarks: a 24-hour ``simulate --jobs`` of the paper's set (~2.6e6 jobs) and a
6-hour coupled Test 2 (~9e4 windows, ~4.3e6 follower steps).

==================  =========  =====================================================
estimate            limit      what is counted
==================  =========  =====================================================
``jobs``            5e7        jobs released over the horizon, Σ horizon / period
``windows``         2e6        processing windows: duration / the smallest window
``world_steps``     2e8        world integration steps × followers: duration /
                               step_ms × n
``grid``            1e5        points of a sweep grid (product or zip of its lists)
==================  =========  =====================================================
"""

from __future__ import annotations

import math

from rtsim.errors import InputError

__all__ = ["LIMITS", "TooMuchWork", "check_work"]

#: The largest amount of each kind of work a command does without ``--force``.
LIMITS: dict[str, float] = {
    "jobs": 5e7,
    "windows": 2e6,
    "world_steps": 2e8,
    "grid": 1e5,
}

_WHAT = {
    "jobs": "jobs",
    "windows": "processing windows",
    "world_steps": "world steps x followers",
    "grid": "grid points",
}


class TooMuchWork(InputError):
    """A run would do more work than its limit (see :data:`LIMITS`); ``--force`` overrides."""


def check_work(kind: str, amount: float, where: str, *, force: bool = False) -> float:
    """Refuse ``amount`` of ``kind`` work (a key of :data:`LIMITS`) above its limit.

    ``where`` names the input that sets the amount (``"--horizon 1e15"``,
    ``"test2.toml: duration"``). Returns ``amount``. A NaN or infinite amount is refused
    even with ``force`` (it would never finish).
    """
    limit = LIMITS[kind]
    if not math.isfinite(amount):
        raise TooMuchWork(f"{where}: the run would never finish ({_WHAT[kind]}: {amount})")
    if amount > limit and not force:
        raise TooMuchWork(f"{where}: about {amount:.3g} {_WHAT[kind]}, above the limit of "
                          f"{limit:.3g}; use --force to run it anyway")
    return amount


def simulate_jobs(ts: object, horizon_ms: float, w: float | None) -> float:
    """Jobs released in [0, horizon): Σ horizon / period, periods in ms at window ``w``
    (a processing-window set's per-window periods and its chain need ``w``)."""
    from rtsim.model.taskset import TaskSet

    assert isinstance(ts, TaskSet)
    tasks = ts.at_window(w).tasks if ts.window is not None and w is not None else ts.tasks
    total = 0.0
    for t in tasks:
        if t.per_window:
            continue
        total += math.ceil(horizon_ms / t.period) if horizon_ms / t.period < 1e300 else math.inf
    return total


def check_simulate(ts: object, horizon_ms: float, w: float | None, where: str, *,
                   force: bool = False) -> None:
    """Refuse a simulation of more than ``LIMITS["jobs"]`` jobs (``where``: the horizon's
    name, e.g. ``--horizon 1e+15``)."""
    check_work("jobs", simulate_jobs(ts, horizon_ms, w), where, force=force)


def check_scenario(scenario: object, duration_s: float | None, where: str, *,
                   force: bool = False) -> None:
    """Refuse a coupled run of more than ``LIMITS["windows"]`` windows (duration over the
    chain's processing time g, below which no window can be) or ``LIMITS["world_steps"]``
    world steps × followers (duration over ``world.step_ms``, times n)."""
    from rtsim.coupling.scenario_run import LAP_CAP_FACTOR
    from rtsim.io.scenario import Scenario

    assert isinstance(scenario, Scenario)
    cfg = scenario.world
    if duration_s is None:
        lap_s = (cfg.path.lap_length + max(cfg.formation.rho_d)) / cfg.leader_speed
        duration_s = max(scenario.duration, LAP_CAP_FACTOR * lap_s)
    ms = 1000.0 * duration_s
    win = scenario.load_taskset().window
    assert win is not None
    g = win.g()
    check_work("windows", ms / g if g > 0 else math.inf, where, force=force)
    check_work("world_steps", ms / cfg.step_ms * cfg.n, where, force=force)
