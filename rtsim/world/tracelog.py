"""The truth log's samples of one scan as a kernel source (`trace_samples`): read by the
coupling's `rtsim.coupling.physical.PhysicalLog` (its own compiled call, or the Python twin)
and compiled into the world's scan (`rtsim.world.scanstep.scan_step`), where the log's
samples are made in the scan's call from the followers' truth the scan has at hand."""

from __future__ import annotations

from typing import Any

from rtsim.world.contact import closest_into
from rtsim.world.exactmath import cpython_hypot
from rtsim.world.ftl import ftl_project, trace_point
from rtsim.world.jit import kernel

__all__ = ["trace_samples"]


@kernel
def trace_samples(
    G: Any,
    sf: Any,
    xs: Any,
    ys: Any,
    xl: float,
    yl: float,
    rho_d: Any,
    guess: Any,
    out: Any,
    near: Any,
) -> None:
    """One scan's samples of every follower with a trace law (`PhysicalLog.add`): into
    ``out``, follower k's separation error |ρ − ρ_d| at 2k and its cross-track distance at
    2k + 1 (from its projection on the trace, `ftl_project`, started at its last, ``sf[k]``,
    or at ``guess[k]`` before the first; ``sf[k]`` kept), and into ``near`` each one's
    closest approach (`rtsim.world.contact.closest_into`). The law's geometry ``G``."""
    for k in range(len(xs)):
        x, y = xs[k], ys[k]
        out[2 * k] = abs(cpython_hypot(x - xl, y - yl) - rho_d[k])
        s = sf[k]
        if s != s:
            s = guess[k]
        s = ftl_project(G, k, s, x, y)
        sf[k] = s
        px, py, _ = trace_point(G, k, s)
        out[2 * k + 1] = cpython_hypot(x - px, y - py)
    closest_into(xs, ys, xl, yl, near)
