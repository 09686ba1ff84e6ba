"""The oracle lap: the fastest lap that keeps every bound, computed offline from the path, the
follow-the-leader law, the leader's speed limits and w_sch, all known exactly
(docs/planning.md, "The oracle lap").

Along one lap of error-free follow-the-leader (`rtsim.world.ideal.ideal_lap`: the
leader at arc length s, follower k on its reference, moving at g_k(s)·V_L with bearing
β_k(s)), each bound with the window at its least, w = w_sch, caps the leader's speed:

* path diversion (Eq 21): V_L·g_k·w_sch ≤ T_ε·ρ_d,k;
* bearing (T_β): V_L·|dβ_k/ds|·w_sch ≤ T_β;
* separation and localization (Eqs 19, 20): ρ̇ = 0 on the reference (the law holds the
  Euclidean separation exactly), so neither caps it;
* the followers' top speed: V_L·g_k ≤ max_speed; and V_L ≤ V_Ld.

A window spans V_L·w_sch of path, so each cap is the least over the window ahead. The
fastest profile under the cap with the leader's ramp limits is the usual two passes on the
grid (forward: v_{i+1}² ≤ v_i² + 2·a_max·Δs; backward: v_i² ≤ v_{i+1}² + 2·d_max·Δs), from
V_Ld at the run's start (the world starts the leader at V_Ld), and the lap time is
Σ 2Δs/(v_i + v_{i+1}) (exact for a constant acceleration over each step). What the oracle
leaves out — windows longer than w_sch, estimation and tracking error, the decision's
latency — can only make a real lap slower: it is a lower bound on a bound-keeping lap.
"""

from __future__ import annotations

import math

import numpy as np

from rtsim.analysis.kinematics import Thresholds
from rtsim.world.config import WorldConfig
from rtsim.world.formation import follower_model
from rtsim.world.ideal import IdealLap, ideal_lap

__all__ = ["lap_oracle", "oracle_profile", "speed_cap", "start_speed"]


def speed_cap(
    lap: IdealLap,
    rho_d: tuple[float, ...],
    thresholds: Thresholds,
    w_sch: float,
    v_ld: float,
    max_speed: float = math.inf,
) -> np.ndarray:
    """The leader's largest speed (cm/s) at each grid point of ``lap`` that keeps the bounds
    over a window of ``w_sch`` ms from there (module docstring)."""
    w = w_sch / 1000.0
    ds = float(lap.s[1] - lap.s[0])
    cap = np.full(lap.s.shape, float(v_ld))
    rho = np.asarray(rho_d, dtype=float)[:, None]
    g = np.maximum(lap.ratio, 1e-12)
    cap = np.minimum(cap, (thresholds.T_eps * rho / (w * g)).min(axis=0))
    dbeta = np.abs(np.gradient(lap.bearing, ds, axis=1))
    with np.errstate(divide="ignore"):
        cap = np.minimum(cap, (thresholds.T_beta / (w * dbeta)).min(axis=0))
    if math.isfinite(max_speed):
        cap = np.minimum(cap, (max_speed / g).min(axis=0))
    # the least over the window ahead (V_Ld·w_sch of path)
    m = max(1, int(math.ceil(v_ld * w / ds)))
    if m > 1:
        pad = np.concatenate((cap, np.full(m - 1, cap[-1])))
        cap = np.lib.stride_tricks.sliding_window_view(pad, m).min(axis=1)
    return cap


def oracle_profile(
    cap: np.ndarray, ds: float, v0: float, accel_max: float, decel_max: float
) -> np.ndarray:
    """The fastest speed profile under ``cap`` (grid step ``ds`` cm) from ``v0`` within the
    ramp limits (cm/s², inf: a step), by the forward and backward passes."""
    v = np.minimum(cap, math.inf).astype(float)
    v[0] = min(v[0], v0)
    vl = v.tolist()
    up = 2.0 * accel_max * ds
    down = 2.0 * decel_max * ds
    for i in range(len(vl) - 1):
        vl[i + 1] = min(vl[i + 1], math.sqrt(vl[i] * vl[i] + up))
    for i in range(len(vl) - 2, -1, -1):
        vl[i] = min(vl[i], math.sqrt(vl[i + 1] * vl[i + 1] + down))
    return np.asarray(vl)


def _oracle(cfg: WorldConfig, w_sch: float) -> float:
    lap = ideal_lap(cfg.path, cfg.formation, cfg.start_s)
    cap = speed_cap(
        lap,
        cfg.formation.rho_d,
        cfg.thresholds,
        w_sch,
        cfg.leader_speed,
        cfg.follower.max_speed,
    )
    ds = float(lap.s[1] - lap.s[0])
    v = oracle_profile(cap, ds, cfg.leader_speed, cfg.leader_accel_max, cfg.leader_decel_max)
    return float(np.sum(2.0 * ds / (v[:-1] + v[1:])))


def lap_oracle(cfg: WorldConfig, w_sch: float) -> float | None:
    """The oracle lap (s) of ``cfg`` with the window's lower bound ``w_sch`` (ms), from the
    leader's start; None for followers that do not track the trace (l-ψ). Cached per what
    it depends on (path, formation, start, thresholds, speeds and ramps, w_sch)."""
    if not follower_model(cfg.formation.model).on_trace:
        return None
    thr = cfg.thresholds
    key = (
        tuple(cfg.path.segments),
        cfg.path.start,
        cfg.formation.rho_d,
        cfg.formation.beta_d,
        cfg.start_s,
        (thr.T_eps, thr.T_beta),
        cfg.leader_speed,
        cfg.follower.max_speed,
        cfg.leader_accel_max,
        cfg.leader_decel_max,
        float(w_sch),
    )
    got = _CACHE.get(key)  # (the key hashed once on a hit: its segments' fields)
    if got is None:
        if len(_CACHE) >= _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))
        got = _CACHE[key] = _oracle(cfg, float(w_sch))
    return got


_CACHE: dict[tuple[object, ...], float] = {}
_CACHE_SIZE = 64


def start_speed(cfg: WorldConfig, w_sch: float) -> float:
    """The leader's speed for a settled start (cm/s): V_Ld, or less where the bounds at the
    start with windows of ``w_sch`` ms allow less (`speed_cap` at the start; e.g. six
    followers of Test 2: T_ε·ρ_d/w_sch = 29.0 cm/s on the straight, below V_Ld = 30). V_Ld
    for followers that do not track the trace (l-ψ)."""
    if not follower_model(cfg.formation.model).on_trace:
        return cfg.leader_speed
    lap = ideal_lap(cfg.path, cfg.formation, cfg.start_s)
    cap = speed_cap(
        lap, cfg.formation.rho_d, cfg.thresholds, w_sch, cfg.leader_speed, cfg.follower.max_speed
    )
    return float(min(cfg.leader_speed, cap[0]))
