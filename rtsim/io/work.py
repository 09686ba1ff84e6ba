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
