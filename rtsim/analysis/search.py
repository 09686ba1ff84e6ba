"""The w_sim search: the least window above which a simulated predicate held everywhere it
was tried (docs/model/lower-bound.md).

Feasibility in simulation need not be monotone in w (with idle suspensions and varying
execution times the phasing against T_hp changes with w), so the search is bisection *plus
a scan*:

1. bracket: ``passes(lo)`` must be false and ``passes(hi)`` true (``hi`` is doubled, at most
   ``max_doublings`` times, until it passes);
2. bisect to ``tol`` (0.01 ms): ``w = hi`` is a passing window with a failing one within tol
   below it;
3. scan ``scan`` windows evenly spaced in (w, hi₀]; if one fails (a non-monotone spot), the
   bracket restarts from it and step 2–3 repeat.

The result is the least w, to ``tol``, above which none of the windows tried failed: the
"threshold" definition of w_sim. ``nonmonotone`` counts the scan failures seen. With WCET
execution, suspensions as CPU time and synchronous releases the simulation is the critical
instant and feasibility is monotone (the argument of `rtsim.analysis.bounds`), so the
scan never fires and w_sim lands within tol above w_rta.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

__all__ = ["SEARCH_TOL", "SearchResult", "smallest_passing"]

#: Resolution of the w_sim search (ms).
SEARCH_TOL = 0.01


@dataclass(frozen=True)
class SearchResult:
    """Outcome of `smallest_passing`: the window found and how it was found."""

    w: float
    lo: float
    hi: float
    evaluations: int
    nonmonotone: int
    hi_doublings: int

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def smallest_passing(
    passes: Callable[[float], bool],
    lo: float,
    hi: float,
    *,
    tol: float = SEARCH_TOL,
    scan: int = 10,
    max_doublings: int = 8,
) -> SearchResult:
    """Least w (to ``tol``) above which ``passes`` held everywhere it was tried (module doc).

    Raises ``ValueError`` when ``passes(lo)`` holds (no failing lower end) or no passing
    upper end is found within ``max_doublings`` doublings of ``hi``.
    """
    if not (0 < lo < hi) or not math.isfinite(hi):
        raise ValueError(f"smallest_passing: need 0 < lo < hi < inf, got lo={lo!r}, hi={hi!r}")
    if tol <= 0:
        raise ValueError(f"smallest_passing: tol must be positive, got {tol!r}")
    evals = 0

    def test(w: float) -> bool:
        nonlocal evals
        evals += 1
        return bool(passes(w))

    if test(lo):
        raise ValueError(f"smallest_passing: the lower end w={lo:g} already passes")
    doublings = 0
    while not test(hi):
        if doublings >= max_doublings:
            raise ValueError(f"smallest_passing: no passing window up to w={hi:g}")
        lo, hi = hi, 2.0 * hi
        doublings += 1
    top = hi
    nonmono = 0
    for _ in range(1000):  # each round ends above the last failure seen: it terminates
        while hi - lo > tol:
            mid = 0.5 * (lo + hi)
            if test(mid):
                hi = mid
            else:
                lo = mid
        found = hi
        bad = None
        for x in np.linspace(found, top, scan + 1)[1:-1] if scan > 1 else ():
            if not test(float(x)):
                bad = float(x)
        if bad is None:
            return SearchResult(found, lo, top, evals, nonmono, doublings)
        nonmono += 1
        lo = bad
        hi = top
        for x in np.linspace(found, top, scan + 1)[1:]:  # the next passing grid point
            if x > bad:
                hi = float(x)
                break
    raise ValueError("smallest_passing: no stable threshold after 1000 rounds")
