"""The paper's lower bound on the processing window (Eqs 1, 2, 5–7, 10–11).

Pure functions on numbers, times in ms, lengths in cm. See docs/model/lower-bound.md.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from rtsim.model.window import LASER_POINTS, e_hough, g_window

__all__ = [
    "LASER_POINTS",
    "e_hough",
    "g_window",
    "hp_utilization",
    "k_geometric",
    "BEAM_SPACING_DEG",
    "R_F",
    "w_eq7",
    "w_eq11",
    "w_sch",
]

#: Angular spacing of the beams (degrees).
BEAM_SPACING_DEG = 0.5
#: Radius of a follower's barrel (cm), docs/model/index.md.
R_F = 25.0


def k_geometric(rho_min: float, r_F: float = R_F, spacing_deg: float = BEAM_SPACING_DEG) -> int:
    """The geometric k of Eq 1: most beams that can hit a disc of radius ``r_F`` (cm) whose
    centre is at distance ρ ≥ ``rho_min`` (cm), beams ``spacing_deg`` apart
    (docs/model/lower-bound.md).

    A beam hits the disc iff its angle to the centre's bearing is at most arcsin(r_F/ρ)
    (tangent included), so the beams lie in a closed arc of width 2·arcsin(r_F/ρ), which
    holds at most ⌊width/spacing⌋ + 1 of them; the width shrinks with ρ, so ρ = rho_min is
    the worst case. Rounding is taken upward (1e-9 relative) so the count stays sound.
    361 when rho_min ≤ r_F (the disc can cover the sensor).
    """
    if not (math.isfinite(rho_min) and rho_min > 0 and r_F > 0 and spacing_deg > 0):
        raise ValueError(f"k_geometric: need positive rho_min, r_F, spacing, got "
                         f"{rho_min!r}, {r_F!r}, {spacing_deg!r}")
    if rho_min <= r_F:
        return LASER_POINTS
    width = 2.0 * math.asin(r_F / rho_min)
    return min(LASER_POINTS, math.floor(width / math.radians(spacing_deg) * (1 + 1e-9)) + 1)


def hp_utilization(hp: Iterable[tuple[float, float]]) -> float:
    """Σ_{T_hp} e_j/p_j over (e, p) pairs."""
    return sum(e / p for e, p in hp)


def w_eq7(g: float, hp: Iterable[tuple[float, float]]) -> float:
    """Window-chain schedulability, Eq 7: w ≥ (g + Σ_hp e_j) / (1 − Σ_hp e_j/p_j).

    Returns ``inf`` when T_hp alone saturates the CPU.
    """
    hp = list(hp)
    u = hp_utilization(hp)
    if u >= 1.0:
        return math.inf
    return (g + sum(e for e, _ in hp)) / (1.0 - u)


def w_eq11(g: float, hp: Iterable[tuple[float, float]], lp_wcets: Iterable[float]) -> float:
    """Command-task schedulability with p_cmd = 2w, Eq 11.

    (Eq 10 corrected: its last sum is over T_hp, not T_lp.)

    w ≥ (½ Σ_{T_lp ∪ T_hp} e_j + g) / (1 − Σ_hp e_j/p_j). With no T_lp task the bound is
    vacuous and ``-inf`` is returned.
    """
    hp = list(hp)
    lp = list(lp_wcets)
    if not lp:
        return -math.inf
    u = hp_utilization(hp)
    if u >= 1.0:
        return math.inf
    return (0.5 * (sum(lp) + sum(e for e, _ in hp)) + g) / (1.0 - u)


def w_sch(g: float, hp: Iterable[tuple[float, float]], lp_wcets: Iterable[float]) -> float:
    """The analytic lower bound w_sch = max(Eq 7, Eq 11) (docs/model/lower-bound.md)."""
    hp = list(hp)
    return max(w_eq7(g, hp), w_eq11(g, hp, lp_wcets))
