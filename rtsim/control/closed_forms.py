"""Closed forms for the leader speed that makes one bound hold at w_sch (paper §3.3,
docs/model/adjustment.md).

Two families, each returning the **largest** leader speed V_L at which one bound of one
follower is at least the window w (ms):

- [`paper_speed`][rtsim.control.closed_forms.paper_speed] — the paper's Eqs 23–26 as corrected in
docs/model/slips.md. V_F, θ and ω_L
  are
  held at the leader's estimates while V_L changes (the paper's assumption):
  * bearing (Eq 23): β̇ = (V sin β − V_F sin(β+θ))/ρ − ω_L is affine in V, and |β̇| ≤ T_β/w
    is an interval whose upper end is (ρ(ω_L + T_β/w) + V_F sin(β+θ))/sin β when sin β > 0
    (as printed) and (ρ(ω_L − T_β/w) + V_F sin(β+θ))/sin β when sin β < 0;
  * separation / localization (Eqs 24/25, printed with sin(β+θ); solving Eqs 19/20 gives
    cos(β+θ)): |V_F cos(β+θ) − V cos β| ≤ D/w with D = T_ρ ρ_d or r_H, upper end
    (V_F cos(β+θ) − D/w)/cos β for trailing followers (cos β < 0), (… + D/w)/cos β otherwise;
    with the full localization bound, |(a₀, b₀) + V(−cos β, sin β)| ≤ r_H/w is a quadratic in V;
  * path diversion (Eq 26): T_ε ρ_d / w, which assumes V_F = V_L.
- [`coupled_speed`][rtsim.control.closed_forms.coupled_speed] — the follower coupled to the leader
through the formation,
  V_F = s·V_L, ω_L = κ·V_L, θ fixed, so every bound is c/V_L and has one positive root:
  D/(w|s cos(β+θ) − cos β|), T_β/(w|(sin β − s sin(β+θ))/ρ − κ|), T_ε ρ_d/(w s).

Return value: the upper end of the speeds satisfying the bound (``inf`` when unbounded above;
possibly ≤ 0, which means no forward speed works), or ``None`` when no speed at all satisfies
it. Windows are in ms and converted to s inside.
"""

from __future__ import annotations

import math

from rtsim.analysis.kinematics import BOUND_KINDS, Thresholds
from rtsim.errors import InputError

__all__ = ["coupled_speed", "coupled_speeds", "paper_speed"]


def _check_w(w: float) -> float:
    if not (math.isfinite(w) and w > 0.0):
        raise InputError(f"window w must be positive and finite (ms), got {w!r}")
    return w / 1000.0


def _affine_upper(c0: float, c1: float, limit: float) -> float | None:
    """Largest V with |c0 + c1·V| ≤ limit; ``inf``/``None`` when c1 is negligible.

    c1 counts as zero when it would take a speed above 1e12 times the other terms to matter
    (e.g. cos β at β = π/2 in floating point).
    """
    if abs(c1) * 1e12 <= max(abs(c0), limit):
        return math.inf if abs(c0) <= limit else None
    return max((limit - c0) / c1, (-limit - c0) / c1)


def paper_speed(
    kind: str,
    *,
    rho: float,
    beta: float,
    theta: float,
    v_f: float,
    omega_l: float,
    rho_d: float,
    thr: Thresholds,
    w: float,
) -> float | None:
    """The paper's corrected closed form (Eqs 23–26) for bound ``kind`` at window ``w`` (ms)."""
    ws = _check_w(w)
    sb, cb = math.sin(beta), math.cos(beta)
    if kind == "path_diversion":  # Eq 26 (assumes V_F = V_L)
        return thr.T_eps * rho_d / ws
    if kind == "bearing":  # Eq 23 and its sin β < 0 twin; β̇·ρ = V sin β − V_F sin(β+θ) − ρ ω_L
        c0 = -v_f * math.sin(beta + theta) - rho * omega_l
        return _affine_upper(c0, sb, rho * thr.T_beta / ws)
    a0 = v_f * math.cos(beta + theta)  # ρ̇ = a0 − V cos β
    if kind == "separation":  # Eq 24 with cos(β+θ)
        return _affine_upper(a0, -cb, thr.T_rho * rho_d / ws)
    if kind == "localization":
        limit = thr.r_H / ws
        if thr.localization == "predicted":  # no speed of the leader moves it
            return math.inf if thr.predicted_ms >= 1000.0 * ws else None
        if thr.localization == "radial":  # Eq 25 with cos(β+θ)
            return _affine_upper(a0, -cb, limit)
        # full: (ρ̇, ρβ̇) = (a0, b0) + V(−cos β, sin β), a unit direction in V
        b0 = -v_f * math.sin(beta + theta) - rho * omega_l
        p = b0 * sb - a0 * cb
        q = a0 * a0 + b0 * b0 - limit * limit
        disc = p * p - q
        if disc < 0.0:
            return None
        return -p + math.sqrt(disc)
    raise InputError(f"unknown bound kind {kind!r}")


def coupled_speed(
    kind: str,
    *,
    rho: float,
    beta: float,
    s: float,
    theta_f: float,
    kappa: float,
    rho_d: float,
    thr: Thresholds,
    w: float,
) -> float:
    """Coupled closed form (docs/model/adjustment.md): the V_L at which bound ``kind`` equals ``w``
    (ms).

    ``s`` = V_F/V_L and ``theta_f`` come from the formation (see
    [`rtsim.analysis.kinematics.formation_velocity`][rtsim.analysis.kinematics.formation_velocity]
    at V_L = 1, ω_L = κ); every bound is
    then proportional to 1/V_L, so it holds exactly for V_L ≤ the returned speed (``inf`` when
    the bound does not depend on V_L at all).
    """
    speeds = coupled_speeds(
        rho=rho, beta=beta, s=s, theta_f=theta_f, kappa=kappa, rho_d=rho_d, thr=thr, w=w
    )
    if kind not in BOUND_KINDS:
        raise InputError(f"unknown bound kind {kind!r}")
    return speeds[BOUND_KINDS.index(kind)]


def coupled_speeds(
    *,
    rho: float,
    beta: float,
    s: float,
    theta_f: float,
    kappa: float,
    rho_d: float,
    thr: Thresholds,
    w: float,
) -> tuple[float, float, float, float]:
    """[`coupled_speed`][rtsim.control.closed_forms.coupled_speed] for the four bounds at once, in
    ``BOUND_KINDS`` order
    (localization, separation, path_diversion, bearing): the same values, one evaluation of
    the shared terms."""
    ws = _check_w(w)
    a_rho = s * math.cos(beta + theta_f) - math.cos(beta)  # ρ̇ / V_L
    a_beta = (math.sin(beta) - s * math.sin(beta + theta_f)) / rho - kappa  # β̇ / V_L
    d_rho = abs(a_rho)
    d_loc = d_rho if thr.localization == "radial" else math.hypot(a_rho, rho * a_beta)
    d_beta = abs(a_beta)
    if thr.localization == "predicted":  # independent of V_L
        v_loc = math.inf if thr.predicted_ms >= 1000.0 * ws else 0.0
    else:
        v_loc = math.inf if d_loc == 0.0 else thr.r_H / (ws * d_loc)
    return (
        v_loc,
        math.inf if d_rho == 0.0 else thr.T_rho * rho_d / (ws * d_rho),
        math.inf if s == 0.0 else thr.T_eps * rho_d / (ws * s),
        math.inf if d_beta == 0.0 else thr.T_beta / (ws * d_beta),
    )
