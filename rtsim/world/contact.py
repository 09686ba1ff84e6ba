"""Contact between robots: the closest approach and the planner's contact bound.

Every robot is a disc of radius r_F (the paper's barrels); two discs keep the formation's
clearance (``[formation] clearance``) when their centres stay at least

    d_c = 2·r_F + clearance   (cm)

apart. The paper's four bounds have no term for it, so the ``plan`` policy checks it beside
them on its rollout (docs/planning.md, "The contact bound"): over a window, follower i's
closest approach d_i is the least centre distance from it to any other robot, the leader
included, at the scans that open and close the window, and its contact bound is

    MSB_contact = w · d_i / d_c   (ms),

so that MSB_contact ≥ w exactly when d_i ≥ d_c — the same reading as the four bounds
L·w / c, which are ≥ w exactly when the change c keeps its threshold L.

The functions are kernel sources (`rtsim.world.jit`): the Python rollout, the truth's
physical log and the compiled rollout call the same code. A distance is
``sqrt(dx·dx + dy·dy)`` (not ``math.hypot``, whose CPython algorithm numba does not carry),
so both backends give the same float. The rollouts sample the robots at the scans only
(the closest approach at a scan is computed once and serves the windows on both sides).
"""

from __future__ import annotations

import math
from typing import Any

from rtsim.world.jit import kernel

__all__ = [
    "closest_each",
    "closest_into",
    "closest_over",
    "closest_to",
    "contact_bound",
    "contact_distance",
    "lowest_contact",
]


def contact_distance(radius: float, clearance: float) -> float:
    """d_c = 2·r_F + clearance (cm): the least centre distance two robots may come to."""
    return 2.0 * radius + clearance


@kernel
def closest_to(xs: Any, ys: Any, i: int, xl: float, yl: float) -> float:
    """The centre distance (cm) from follower ``i`` at (xs[i], ys[i]) to the nearest other
    robot: the leader at (xl, yl), or another follower (xs[j], ys[j]). (The least squared
    distance, then one square root: √ is monotone and correctly rounded, so this is the
    least of the distances, exactly.)"""
    xi, yi = xs[i], ys[i]
    dx, dy = xi - xl, yi - yl
    best = dx * dx + dy * dy
    for j in range(len(xs)):
        if j != i:
            dx, dy = xi - xs[j], yi - ys[j]
            d2 = dx * dx + dy * dy
            if d2 < best:
                best = d2
    return math.sqrt(best)


def closest_each(xs: Any, ys: Any, xl: float, yl: float) -> tuple[float, ...]:
    """`closest_to` of every follower at once (`closest_into`), as a tuple."""
    best = [0.0] * len(xs)
    closest_into(xs, ys, xl, yl, best)
    return tuple(best)


@kernel
def closest_into(xs: Any, ys: Any, xl: float, yl: float, best: Any) -> None:
    """`closest_to` of every follower at once, written into ``best`` (one per follower):
    each pair's squared distance computed once and offered to both ends (the same float
    from either: a − b = −(b − a) exactly), then one square root each; the same numbers as
    one `closest_to` per follower."""
    n = len(xs)
    for i in range(n):
        dx, dy = xs[i] - xl, ys[i] - yl
        best[i] = dx * dx + dy * dy
    for i in range(n - 1):
        xi, yi = xs[i], ys[i]
        for j in range(i + 1, n):
            dx, dy = xi - xs[j], yi - ys[j]
            d2 = dx * dx + dy * dy
            if d2 < best[i]:
                best[i] = d2
            if d2 < best[j]:
                best[j] = d2
    for i in range(n):
        best[i] = math.sqrt(best[i])


@kernel
def closest_over(d_open: float, d_close: float) -> float:
    """A window's closest approach from `closest_to` at its opening and its closing scan:
    the smaller."""
    return d_close if d_close < d_open else d_open


@kernel
def contact_bound(w: float, d: float, d_c: float) -> float:
    """MSB_contact = w·d / d_c (ms) of a window of ``w`` ms whose closest approach is ``d``
    (module docstring); ≥ w exactly when d ≥ d_c."""
    return w * d / d_c


@kernel
def lowest_contact(windows: Any, w: float, d_c: float, m: float) -> float:
    """``m`` lowered to the smallest `contact_bound` of every follower in every window of
    ``windows`` (``windows[j][i][4]``: follower i's closest approach in window j of ``w``
    ms, as the rollout's changes carry it), windows then followers in order; ``d_c`` = 0:
    ``m`` unchanged (the contact bound is off)."""
    if d_c > 0.0:
        for j in range(len(windows)):
            per = windows[j]
            for i in range(len(per)):
                b = contact_bound(w, per[i][4], d_c)
                if b < m:
                    m = b
    return m
