"""The ``paper`` predictor's speed search compiled with numba (the world's ``compiled``
backend turns it on; `rtsim.world.compiled` for the world's own kernels,
`rtsim.control.compiled_rollout` for the rollout's).

Under the ``paper`` model the followers' predicted speed, heading and the leader's turn rate
stay at their estimates whatever the leader's speed, so the predicate of the speed search —
"every follower's four bounds (Eq 17, Eqs 19–21 and the bearing bound, radial localization)
are at least w_sch at V_L" — is a few lines of arithmetic per follower. `PaperSearch`
is the predictor name ``"paper"`` (a ``str`` equal to it, so every comparison and every
record sees the same name) carrying `PaperSearch.largest`, which runs
`rtsim.control.adjust.largest` over the grid with that predicate in one compiled call:
the same expressions in the same order as `scalar_msbs`
and `min_bound_rows`, so the same speed, bit for bit (tested
against the Python search on whole runs).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from rtsim.analysis.kinematics import Thresholds
from rtsim.world.jit import build, kernel
from rtsim.world.kernels import announce

__all__ = ["PaperSearch"]


@kernel
def _passes(
    v: float,
    rho: Any,
    beta: Any,
    theta: Any,
    v_f: Any,
    rho_d: Any,
    omega_l: float,
    r_H: float,
    T_rho: float,
    T_eps: float,
    T_beta: float,
    need: float,
) -> bool:
    """min over followers and bounds (scalar_msbs at leader speed v) >= need."""
    inf = math.inf
    best = inf
    for i in range(rho.shape[0]):
        rd = v_f[i] * math.cos(theta[i] + beta[i]) - v * math.cos(beta[i])
        bd = (v * math.sin(beta[i]) - v_f[i] * math.sin(beta[i] + theta[i])) / rho[i] - omega_l
        ard, abd, avf = abs(rd), abs(bd), abs(v_f[i])
        loc = inf if ard == 0.0 else 1000.0 * r_H / ard
        sep = inf if ard == 0.0 else 1000.0 * (T_rho * rho_d[i]) / ard
        path = inf if avf == 0.0 else 1000.0 * (T_eps * rho_d[i]) / avf
        bear = inf if abd == 0.0 else 1000.0 * T_beta / abd
        if loc < best:
            best = loc
        if sep < best:
            best = sep
        if path < best:
            best = path
        if bear < best:
            best = bear
    return best >= need


@kernel
def _largest_paper(
    grid: Any,
    rho: Any,
    beta: Any,
    theta: Any,
    v_f: Any,
    rho_d: Any,
    omega_l: float,
    r_H: float,
    T_rho: float,
    T_eps: float,
    T_beta: float,
    need: float,
) -> tuple[bool, float]:
    """adjust.largest with the paper model's predicate: (found, speed)."""
    have_above = False
    above = 0.0
    for g in range(grid.shape[0]):
        v = grid[g]
        if _passes(v, rho, beta, theta, v_f, rho_d, omega_l, r_H, T_rho, T_eps, T_beta, need):
            if not have_above:
                return True, v
            lo, hi = v, above
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                if _passes(
                    mid, rho, beta, theta, v_f, rho_d, omega_l, r_H, T_rho, T_eps, T_beta, need
                ):
                    lo = mid
                else:
                    hi = mid
                if hi - lo <= 1e-13 * hi:
                    break
            return True, lo
        have_above = True
        above = v
    return False, 0.0


#: about how long compiling `_largest_paper` takes, CPU s (as
#: `rtsim.control.kernels.COMPILE_S`)
PAPER_COMPILE_S = 1.0


class PaperSearch(str):
    """The predictor name ``"paper"`` with its compiled speed search (module docstring)."""

    def __new__(cls) -> PaperSearch:
        return super().__new__(cls, "paper")

    def __init__(self) -> None:
        announce([_largest_paper], PAPER_COMPILE_S)
        self._kernel = build(_largest_paper)
        self.largest(  # compile, or load from the cache, now rather than in a window
            [], 0.0, Thresholds(1.0, 1.0, 1.0, 1.0), 1.0, [1.0]
        )

    def largest(
        self,
        followers: Sequence[Any],
        omega_l: float,
        thr: Thresholds,
        need: float,
        grid: Sequence[float],
    ) -> float | None:
        """`rtsim.control.adjust.largest` over ``grid`` with the paper model's
        predicate (radial localization) for ``followers``; None when no speed passes."""
        rho = np.array([f.rho for f in followers], dtype=float)
        beta = np.array([f.beta for f in followers], dtype=float)
        theta = np.array([f.theta for f in followers], dtype=float)
        v_f = np.array([f.v_f for f in followers], dtype=float)
        rho_d = np.array([f.rho_d for f in followers], dtype=float)
        found, v = self._kernel(
            np.array(grid, dtype=float),
            rho,
            beta,
            theta,
            v_f,
            rho_d,
            float(omega_l),
            thr.r_H,
            thr.T_rho,
            thr.T_eps,
            thr.T_beta,
            float(need),
        )
        return v if found else None

    def __reduce__(self) -> Any:  # pickles as the plain name
        return (str, ("paper",))
