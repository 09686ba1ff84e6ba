"""The adjustment algorithm (paper §3.3) and the three window modes, as pure functions:
`adjust` predicts every follower's bounds at the desired speed, keeps w = min(m, cap) when
m ≥ w_sch, and otherwise finds the largest leader speed at which every bound is ≥ w_sch
(closed-form, coupled or numeric candidates, each checked). The steps, the numeric search,
the cap and the predictors: docs/model/adjustment.md.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, NamedTuple

from rtsim.analysis.kinematics import BOUND_KINDS, Thresholds
from rtsim.control.closed_forms import coupled_speeds, paper_speed
from rtsim.control.predict import (
    FollowerEstimate,
    Predictor,
    check_number,
    min_bound_rows,
    predict_msb_rows,
    predict_msbs,
    predictor,
    unit_formation,
)
from rtsim.errors import InputError

make_predictor = predictor  # the functions below take a ``predictor`` argument

__all__ = [
    "CAP_FACTOR",
    "FLOOR_FRAC",
    "FLOOR_W",
    "METHODS",
    "MODES",
    "Adjustment",
    "Decision",
    "FollowerEstimate",
    "Predictor",
    "adjust",
    "adjust_core",
    "adjustment_of",
    "largest",
    "predict_msbs",
    "predicted_rows",
    "predictor",
    "bound_rows_at",
    "CANDIDATES",
    "TOL",
]

#: Default window cap as a multiple of w_sch.
CAP_FACTOR = 10.0
#: Default speed floor (fraction of V_Ld) when no speed restores the bounds.
FLOOR_FRAC = 0.05
#: Default smallest window (ms) of the ``min-msb`` mode.
FLOOR_W = 1.0
#: Methods that `adjust` can report.
METHODS: tuple[str, ...] = ("none", "closed-form", "coupled", "numeric", "floor", "best")
#: Window modes of [`decide`][rtsim.control.decide].
MODES: tuple[str, ...] = ("adjust", "fixed-wsch", "min-msb")

Mode = Literal["adjust", "fixed-wsch", "min-msb"]
CANDIDATES = ("closed-form", "coupled", "numeric")
TOL = 1e-9  # relative tolerance of "bound ≥ w_sch" and of ties


@dataclass(frozen=True)
class Adjustment:
    """One window's decision.

    w, slack (= max(0, w − w_sch), the slack granted), msb_min and margin (= msb_min − w_sch,
    signed) are ms. msb_min, binding_* and msbs are predicted at the desired speed (what the
    decision reacts to); msbs_after / msb_min_after at the chosen speed ``v_leader``.
    binding_follower is 1-based (0 when no bound is finite). ``feasible``: msb_min_after ≥
    w_sch (within 1e-9 relative). ``candidates``: the speed each method proposed (NaN if none).
    """

    mode: str
    w: float
    w_sch: float
    slack: float
    v_leader: float
    v_leader_desired: float
    msb_min: float
    margin: float
    binding_kind: str
    binding_follower: int
    method: str
    feasible: bool
    msbs: tuple[dict[str, float], ...]
    msb_min_after: float
    msbs_after: tuple[dict[str, float], ...]
    candidates: dict[str, float] = field(default_factory=dict)

    @property
    def binding(self) -> str:
        """``kind:follower`` as in windows.csv, e.g. ``path_diversion:2``, or ``none``."""
        return (
            "none" if self.binding_follower == 0 else f"{self.binding_kind}:{self.binding_follower}"
        )

    @property
    def critical(self) -> bool:
        """Overload at the desired speed: min MSB < w_sch."""
        return self.msb_min < self.w_sch


class Decision(NamedTuple):
    """A window's decision without the dicts of [`Adjustment`][rtsim.control.adjust.Adjustment]
    (`decide_rows`).

    ``rows``/``rows_after``: every follower's bounds (ms) in `BOUND_KINDS` order at the
    desired / the chosen speed; the other fields as in
    [`Adjustment`][rtsim.control.adjust.Adjustment].
    """

    w: float
    v_leader: float
    msb_min: float
    binding_kind: str
    binding_follower: int
    method: str
    feasible: bool
    rows: list[tuple[float, float, float, float]]
    rows_after: list[tuple[float, float, float, float]]
    msb_min_after: float
    candidates: dict[str, float]

    @property
    def binding(self) -> str:
        """``kind:follower`` as in windows.csv, or ``none``."""
        return (
            "none" if self.binding_follower == 0 else f"{self.binding_kind}:{self.binding_follower}"
        )


def _as_dict(row: Sequence[float]) -> dict[str, float]:
    return {
        "localization": row[0],
        "separation": row[1],
        "path_diversion": row[2],
        "bearing": row[3],
    }


def _formation_consts(
    followers: Sequence[FollowerEstimate], thresholds: Thresholds, kappa: float
) -> list[tuple[float, ...]] | None:
    """Per-follower constants of the ``formation`` model's bounds, or None when the scalar
    fast path does not apply (non-float values, ``full`` localization).

    Each row: ρ, κ, s, cos(θ_F + β), cos β, sin β, sin(β + θ_F), and the numerators
    1000·r_H, 1000·(T_ρ ρ_d), 1000·(T_ε ρ_d), 1000·T_β of `scalar_msbs` (which computes
    ``1000.0 * x / d`` as ``(1000.0 * x) / d``: the same floats).
    """
    if kappa.__class__ is not float or thresholds.localization != "radial":
        return None
    out: list[tuple[float, ...]] = []
    loc = 1000.0 * thresholds.r_H
    bear = 1000.0 * thresholds.T_beta
    for f in followers:
        rho, beta, rho_d = f.rho, f.beta, f.rho_d
        if not (rho.__class__ is float and beta.__class__ is float and rho_d.__class__ is float):
            return None
        s, th = unit_formation(kappa, *f.slot)
        if s.__class__ is not float or th.__class__ is not float:
            return None
        out.append(
            (
                rho,
                kappa,
                s,
                math.cos(th + beta),
                math.cos(beta),
                math.sin(beta),
                math.sin(beta + th),
                loc,
                1000.0 * float(thresholds.T_rho * rho_d),
                1000.0 * float(thresholds.T_eps * rho_d),
                bear,
            )
        )
    return out


def _formation_rows(
    pre: list[tuple[float, ...]], v: float
) -> list[tuple[float, float, float, float]]:
    """`scalar_msbs` of every follower under the ``formation`` model at leader speed
    ``v`` (V_F = s·v, ω_L = κ·v), from `_formation_consts`; the same operations."""
    out = []
    for rho, kappa, s, c_tb, c_b, s_b, s_bt, n_loc, n_sep, n_path, n_bear in pre:
        v_f = s * v
        rd = v_f * c_tb - v * c_b
        bd = (v * s_b - v_f * s_bt) / rho - kappa * v
        ard, abd, avf = abs(rd), abs(bd), abs(v_f)
        out.append(
            (
                math.inf if ard == 0.0 else n_loc / ard,
                math.inf if ard == 0.0 else n_sep / ard,
                math.inf if avf == 0.0 else n_path / avf,
                math.inf if abd == 0.0 else n_bear / abd,
            )
        )
    return out


def _hybrid_consts(
    followers: Sequence[FollowerEstimate], thresholds: Thresholds, kappa: float, v_now: float | None
) -> list[tuple[float, ...]] | None:
    """Per-follower constants of the ``hybrid`` model's bounds, or None when the scalar fast
    path does not apply (non-float values, ``full`` localization).

    Each row: ρ, β, θ̂, cos β, sin β, s, cos θ_F, sin θ_F, V̂_F cos θ̂, V̂_F sin θ̂ (the
    terms of `hybrid_velocity`) and the numerators of
    `_formation_consts`.
    """
    if (
        kappa.__class__ is not float
        or v_now.__class__ is not float
        or thresholds.localization != "radial"
    ):
        return None
    out: list[tuple[float, ...]] = []
    loc = 1000.0 * thresholds.r_H
    bear = 1000.0 * thresholds.T_beta
    for f in followers:
        rho, beta, theta, v_f, rho_d = f.rho, f.beta, f.theta, f.v_f, f.rho_d
        if not (
            rho.__class__ is float
            and beta.__class__ is float
            and theta.__class__ is float
            and v_f.__class__ is float
            and rho_d.__class__ is float
        ):
            return None
        s, th = unit_formation(kappa, *f.slot)
        if s.__class__ is not float or th.__class__ is not float:
            return None
        out.append(
            (
                rho,
                beta,
                theta,
                math.cos(beta),
                math.sin(beta),
                s,
                math.cos(th),
                math.sin(th),
                v_f * math.cos(theta),
                v_f * math.sin(theta),
                loc,
                1000.0 * float(thresholds.T_rho * rho_d),
                1000.0 * float(thresholds.T_eps * rho_d),
                bear,
            )
        )
    return out


def _hybrid_rows(
    pre: list[tuple[float, ...]], v: float, v_now: float, kappa: float
) -> list[tuple[float, float, float, float]]:
    """`scalar_msbs` of every follower under the ``hybrid`` model at leader speed
    ``v`` (`hybrid_velocity`, ω_L = κ·v), from
    `_hybrid_consts`; the same operations, so the same floats."""
    out = []
    omega = kappa * v
    for rho, beta, theta0, c_b, s_b, s, c_tf, s_tf, ux0, uy0, n_loc, n_sep, n_path, n_bear in pre:
        dv = s * (v - v_now)
        ux = dv * c_tf + ux0
        uy = -dv * s_tf - uy0
        v_f = math.hypot(ux, uy)
        theta = -math.atan2(uy, ux) if v_f > 0.0 else theta0
        rd = v_f * math.cos(theta + beta) - v * c_b
        bd = (v * s_b - v_f * math.sin(beta + theta)) / rho - omega
        ard, abd, avf = abs(rd), abs(bd), abs(v_f)
        out.append(
            (
                math.inf if ard == 0.0 else n_loc / ard,
                math.inf if ard == 0.0 else n_sep / ard,
                math.inf if avf == 0.0 else n_path / avf,
                math.inf if abd == 0.0 else n_bear / abd,
            )
        )
    return out


def bound_rows_at(
    followers: Sequence[FollowerEstimate],
    predict: Predictor | None,
    thresholds: Thresholds,
    model: str | Predictor,
    kappa: float,
    omega_l: float = 0.0,
    v_now: float | None = None,
    rollout: Any = None,
) -> Callable[[float], list[tuple[float, float, float, float]]]:
    """v_l -> every follower's bounds at v_l (rows in BOUND_KINDS order), memoised per v_l.

    For the built-in ``formation`` and ``hybrid`` models the per-follower constants are
    computed once (`_formation_consts`, `_hybrid_consts`); the values are those
    of `predict_msb_rows` with the same predictor (bit for bit, tested). The
    ``commands`` model's rows are ``rollout.rows(v_l)`` (`rtsim.control.rollout`).
    """
    if model == "commands":
        if rollout is None:
            predict(None, 0.0)  # type: ignore[arg-type,misc]  # raises: no rollout
        return rollout.rows  # type: ignore[no-any-return]
    memo: dict[float, list[tuple[float, float, float, float]]] = {}
    pre = _formation_consts(followers, thresholds, kappa) if model == "formation" else None
    hyb = _hybrid_consts(followers, thresholds, kappa, v_now) if model == "hybrid" else None

    def rows_at(v: float) -> list[tuple[float, float, float, float]]:
        out = memo.get(v)
        if out is not None:
            return out
        if pre is not None and v.__class__ is float:
            out = _formation_rows(pre, v)
        elif hyb is not None and v.__class__ is float:
            out = _hybrid_rows(hyb, v, v_now, kappa)  # type: ignore[arg-type]
        else:
            nonlocal predict
            if predict is None:  # the formation model's predictor, made when first needed
                predict = make_predictor(model, omega_l=omega_l, kappa=kappa)
            out = predict_msb_rows(followers, v, predict, thresholds)
        memo[v] = out
        return out

    return rows_at


def predicted_rows(
    followers: Sequence[FollowerEstimate],
    v_l: float,
    *,
    thresholds: Thresholds,
    predictor: str | Predictor = "formation",
    omega_l: float = 0.0,
    kappa: float = 0.0,
    v_now: float | None = None,
    rollout: Any = None,
) -> list[tuple[float, float, float, float]]:
    """Every follower's four bounds (ms, `BOUND_KINDS` order) at leader speed ``v_l``
    under ``predictor``, from the same estimates and with the same arithmetic as the decision
    (`decide_rows`'s ``rows`` at ``v_l``): what the decision's belief says about a
    window in which the leader drives at ``v_l`` (windows.csv ``f{i}_msb_{bound}_pred``)."""
    predict = (
        None
        if predictor == "formation"
        else make_predictor(predictor, omega_l=omega_l, kappa=kappa, v_now=v_now)
    )
    return bound_rows_at(followers, predict, thresholds, predictor, kappa, omega_l, v_now, rollout)(
        v_l
    )


def largest(ok: Callable[[float], bool], grid: Sequence[float]) -> float | None:
    """Largest passing speed: scan ``grid`` (descending), bisect below the first failure."""
    above: float | None = None
    for v in grid:
        if ok(v):
            if above is None:
                return v
            lo, hi = v, above
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                if ok(mid):
                    lo = mid
                else:
                    hi = mid
                if hi - lo <= 1e-13 * hi:
                    break
            return lo
        above = v
    return None


def _checked(
    v_ld: float,
    w_sch: float,
    omega_l: float,
    kappa: float,
    cap: float | None,
    floor_frac: float,
    methods: Sequence[str],
    scan_points: int,
) -> tuple[float, float, float, float, float]:
    """`adjust_core`'s arguments checked: (v_ld, w_sch, omega_l, kappa, cap)."""
    where = "adjust"
    v_ld = check_number(where, "v_ld", v_ld)
    w_sch = check_number(where, "w_sch", w_sch)
    omega_l = check_number(where, "omega_l", omega_l)
    kappa = check_number(where, "kappa", kappa)
    if v_ld < 0.0:
        raise InputError(f"{where}: v_ld must be non-negative, got {v_ld!r}")
    if w_sch <= 0.0:
        raise InputError(f"{where}: w_sch must be positive, got {w_sch!r}")
    cap = CAP_FACTOR * w_sch if cap is None else check_number(where, "cap", cap)
    if cap < w_sch:
        raise InputError(f"{where}: cap must be at least w_sch={w_sch!r}, got {cap!r}")
    if not 0.0 <= floor_frac <= 1.0:
        raise InputError(f"{where}: floor_frac must be in [0, 1], got {floor_frac!r}")
    bad = [m for m in methods if m not in CANDIDATES]
    if bad or not methods:
        raise InputError(
            f"{where}: methods must be a non-empty subset of {CANDIDATES}, got {methods!r}"
        )
    if scan_points < 1:
        raise InputError(f"{where}: scan_points must be at least 1, got {scan_points!r}")
    return v_ld, w_sch, omega_l, kappa, cap


def _closed_form(
    followers: Sequence[FollowerEstimate],
    rows: Sequence[Sequence[float]],
    v_ld: float,
    w_sch: float,
    thresholds: Thresholds,
    omega_l: float,
) -> float:
    """The ``closed-form`` candidate: the least of the paper's speed for each bound a follower
    misses (NaN when one has none)."""
    v = math.inf
    for f, fm in zip(followers, rows, strict=True):
        for j, k in enumerate(BOUND_KINDS):
            if fm[j] < w_sch:
                hi = paper_speed(
                    k,
                    rho=f.rho,
                    beta=f.beta,
                    theta=f.theta,
                    v_f=f.v_f,
                    omega_l=omega_l,
                    rho_d=f.rho_d,
                    thr=thresholds,
                    w=w_sch,
                )
                v = -math.inf if hi is None else min(v, hi)
    return math.nan if v == -math.inf else min(v, v_ld)


def _coupled(
    followers: Sequence[FollowerEstimate],
    v_ld: float,
    w_sch: float,
    thresholds: Thresholds,
    kappa: float,
) -> float:
    """The ``coupled`` candidate: the least coupled speed of every follower."""
    v = math.inf
    for f in followers:
        s, theta_f = unit_formation(kappa, *f.slot)
        for c in coupled_speeds(
            rho=f.rho,
            beta=f.beta,
            s=s,
            theta_f=theta_f,
            kappa=kappa,
            rho_d=f.rho_d,
            thr=thresholds,
            w=w_sch,
        ):
            v = min(v, c)
    return min(v, v_ld)


def adjust_core(
    followers: Sequence[FollowerEstimate],
    v_ld: float,
    w_sch: float,
    thresholds: Thresholds,
    omega_l: float,
    kappa: float,
    cap: float | None,
    floor_frac: float,
    model: str | Predictor,
    methods: Sequence[str],
    scan_points: int,
    v_now: float | None,
    rollout: Any = None,
) -> Decision:
    """`adjust` as a [`Decision`][rtsim.control.adjust.Decision] (validation included)."""
    v_ld, w_sch, omega_l, kappa, cap = _checked(
        v_ld, w_sch, omega_l, kappa, cap, floor_frac, methods, scan_points
    )

    # the formation model's predictor (which cannot fail) is only made when needed
    predict = (
        None
        if model == "formation"
        else make_predictor(model, omega_l=omega_l, kappa=kappa, v_now=v_now)
    )
    rows_at = bound_rows_at(followers, predict, thresholds, model, kappa, omega_l, v_now, rollout)
    rows = rows_at(v_ld)
    m, kind, who = min_bound_rows(rows)
    if m >= w_sch:
        return Decision(min(m, cap), v_ld, m, kind, who, "none", True, rows, rows, m, {})

    need = w_sch * (1.0 - TOL)
    if model == "commands":
        # the rollout's compiled search, if it has one (one window of w_sch: its rows)
        compiled = getattr(rollout, "search", None)
        hit = (
            None
            if compiled is None
            else compiled(v_ld, 1.0, need, floor_frac * v_ld, 1, rollout.state.w_sch)
        )
        v_l, method, found = (
            search_rollout(lambda v: min_bound_rows(rows_at(v))[0], v_ld, need, floor_frac * v_ld)
            if hit is None
            else hit
        )
        after_rows = rows_at(v_l)
        m_after = min_bound_rows(after_rows)[0]
        return Decision(
            w_sch,
            v_l,
            m,
            kind,
            who,
            method,
            m_after >= need,
            rows,
            after_rows,
            m_after,
            {"numeric": found},
        )

    def ok(v: float) -> bool:
        return min_bound_rows(rows_at(v))[0] >= need

    # the paper model's search compiled (rtsim.control.compiled.PaperSearch: the same speed)
    fast = getattr(model, "largest", None) if thresholds.localization == "radial" else None

    def search(ok: Callable[[float], bool], grid: Sequence[float]) -> float | None:
        if fast is None:
            return largest(ok, grid)
        return fast(followers, omega_l, thresholds, need, grid)  # type: ignore[no-any-return]

    candidates: dict[str, float] = {k: math.nan for k in methods}
    if "closed-form" in methods:
        candidates["closed-form"] = _closed_form(followers, rows, v_ld, w_sch, thresholds, omega_l)
    if "coupled" in methods:
        candidates["coupled"] = _coupled(followers, v_ld, w_sch, thresholds, kappa)

    passing = [
        (candidates[k], k)
        for k in methods
        if k != "numeric" and 0.0 < candidates[k] <= v_ld and ok(candidates[k])  # NaN fails
    ]
    best: float | None = None
    method = "floor"
    if passing:
        top = max(v for v, _ in passing)
        best, method = next((v, k) for v, k in passing if v >= top * (1.0 - TOL))
        probe = min(best * (1.0 + 1e-6), v_ld)
        if "numeric" in methods and probe > best and ok(probe):  # not maximal: refine upward
            step = (v_ld - best) / scan_points
            grid = [v_ld - step * i for i in range(scan_points)] + [probe]
            hit = search(ok, grid)
            if hit is not None and hit > best:
                best, method = hit, "numeric"
                candidates["numeric"] = hit
    elif (
        "numeric" in methods
        and v_ld > 0.0
        and not (
            model == "paper"
            and thresholds.localization == "radial"
            and paper_infeasible(followers, v_ld, w_sch, thresholds, omega_l)
        )
    ):
        # (an exactly empty intersection of the paper model's intervals skips the grid,
        # which would find nothing: the same decision without ~86 evaluations)
        step = v_ld / scan_points
        grid = [v_ld - step * i for i in range(scan_points)]
        grid += [step * 0.5**j for j in range(1, 21)]
        hit = search(ok, grid)
        if hit is not None:
            best, method = hit, "numeric"
            candidates["numeric"] = hit
    v_l = floor_frac * v_ld if best is None else best
    after_rows = rows_at(v_l)
    m_after = min_bound_rows(after_rows)[0]
    return Decision(
        w_sch, v_l, m, kind, who, method, m_after >= need, rows, after_rows, m_after, candidates
    )


#: Bracket of the ``commands`` search: a descending scan of this many equal steps of (0, V_Ld]
ROLLOUT_GRID = 8
#: ... then bisection until the bracket is this fraction of V_Ld wide.
ROLLOUT_TOL = 0.005


def search_rollout(
    m: Callable[[float], float], v_ld: float, need: float, v_floor: float
) -> tuple[float, str, float]:
    """The largest leader speed in (0, V_Ld) whose predicted min bound ``m(v)`` is ≥ ``need``,
    for a predictor without a closed form (the ``commands`` rollout).

    Bracket: the speeds V_Ld·(1 − j/`ROLLOUT_GRID`), j = 1 … GRID − 1, descending
    (V_Ld itself has failed); the first that passes is refined by bisection against the
    failing one above it until the bracket is `ROLLOUT_TOL`·V_Ld wide (≤ 7 + 5 = 12
    evaluations of ``m``, ``m(v_floor)`` only when nothing passes; the passing end is
    returned, so the result is feasible and at most 0.5 % of V_Ld below the boundary if
    feasibility is monotone within that step). Method
    ``numeric``. When no speed of the scan passes: the scanned speed (or ``v_floor``) with the
    largest min bound — the least-bad window, the larger speed on a tie — method ``best``
    (not ``floor``: the leader does not drop to its floor when braking harder does not help,
    which the rollout can tell because it plays the leader's ramp). Returns (speed, method,
    the found speed or NaN).
    """
    above = v_ld
    scanned = []
    for j in range(1, ROLLOUT_GRID):
        v = v_ld * (1.0 - j / ROLLOUT_GRID)
        mv = m(v)
        if mv >= need:
            lo, hi = v, above
            while hi - lo > ROLLOUT_TOL * v_ld:
                mid = 0.5 * (lo + hi)
                if m(mid) >= need:
                    lo = mid
                else:
                    hi = mid
            return lo, "numeric", lo
        scanned.append((v, mv))
        above = v
    # m(v_floor) matters only here, so it is evaluated last (a search that brackets never
    # pays for it) and compared as if first: the floor wins ties
    best_v, best_m = v_floor, m(v_floor) if v_floor > 0.0 else -math.inf
    for v, mv in scanned:
        if mv > best_m:
            best_v, best_m = v, mv
    return best_v, "best", math.nan


def paper_infeasible(
    followers: Sequence[FollowerEstimate],
    v_ld: float,
    w_sch: float,
    thr: Thresholds,
    omega_l: float,
) -> bool:
    """True when, under the ``paper`` model, no leader speed in (0, V_Ld] keeps every bound
    ≥ w_sch, decided exactly without a grid.

    With V̂_F, θ̂ and ω_L held, each bound is n / |c0 + c1·V| (Eqs 17, 19–21;
    docs/model/adjustment.md):
    localization and separation with ρ̇ = V̂_F cos(θ̂ + β) − V cos β, bearing with
    β̇ = (V sin β − V̂_F sin(β + θ̂))/ρ − ω_L, and path diversion n / V̂_F (no V). The bound
    is ≥ w_sch exactly when |c0 + c1·V| ≤ K = n / w_sch: an interval of V (all V or none when
    c1 = 0). The intersection of every follower's intervals with (0, V_Ld] is empty → True.

    Conservative so that the grid search it replaces would also find nothing: it answers
    True only when the intersection is empty by more than 1e-6·(1 + V_Ld) (far above the
    rounding of the grid's own evaluations, whose check allows 1e-9 relative), and only for
    the ``radial`` localization bound.
    """
    lo, hi = 0.0, v_ld
    k_scale = 1000.0 / (w_sch * (1.0 - TOL))
    slack = 1e-6 * (1.0 + v_ld)
    for f in followers:
        cb, sb = math.cos(f.beta), math.sin(f.beta)
        rho_dot0 = f.v_f * math.cos(f.theta + f.beta)
        beta_dot0 = -f.v_f * math.sin(f.beta + f.theta) / f.rho - omega_l
        k_sep = min(thr.r_H, thr.T_rho * f.rho_d) * k_scale
        k_path = thr.T_eps * f.rho_d * k_scale
        k_bear = thr.T_beta * k_scale
        if f.v_f > k_path + slack:
            return True  # path diversion: no V helps
        for c0, c1, k in ((rho_dot0, -cb, k_sep), (beta_dot0, sb / f.rho, k_bear)):
            if c1 == 0.0:
                if abs(c0) > k + slack:
                    return True
                continue
            a, b = (-k - c0) / c1, (k - c0) / c1
            lo, hi = max(lo, min(a, b)), min(hi, max(a, b))
    return hi < lo - slack


def adjust(
    followers: Sequence[FollowerEstimate],
    *,
    v_ld: float,
    w_sch: float,
    thresholds: Thresholds,
    omega_l: float = 0.0,
    kappa: float = 0.0,
    cap: float | None = None,
    floor_frac: float = FLOOR_FRAC,
    predictor: str | Predictor = "formation",
    methods: Sequence[str] = CANDIDATES,
    scan_points: int = 64,
    v_now: float | None = None,
) -> Adjustment:
    """The adjustment algorithm (paper §3.3, docs/model/adjustment.md); see the module docstring.

    v_ld: desired leader speed (cm/s); w_sch (ms); omega_l: the leader's current turn rate
    (rad/s, used by the paper's forms and the ``paper`` predictor); kappa: path curvature (1/cm,
    positive = left); cap: largest window (ms, default 10·w_sch); floor_frac: leader speed when
    nothing works, as a fraction of v_ld; methods: allowed candidates in tie-break order.
    """
    d = adjust_core(
        followers,
        v_ld,
        w_sch,
        thresholds,
        omega_l,
        kappa,
        cap,
        floor_frac,
        predictor,
        methods,
        scan_points,
        v_now,
    )
    return adjustment_of("adjust", d, float(w_sch), float(v_ld))


def adjustment_of(mode: str, d: Decision, w_sch: float, v_ld: float) -> Adjustment:
    """The [`Adjustment`][rtsim.control.adjust.Adjustment] of a
    [`Decision`][rtsim.control.adjust.Decision]."""
    msbs = tuple(_as_dict(r) for r in d.rows)
    after = msbs if d.rows_after is d.rows else tuple(_as_dict(r) for r in d.rows_after)
    if mode == "adjust":
        slack = d.w - w_sch if d.method == "none" else 0.0
    else:
        slack = max(0.0, d.w - w_sch)
    return Adjustment(
        mode=mode,
        w=d.w,
        w_sch=w_sch,
        slack=slack,
        v_leader=d.v_leader,
        v_leader_desired=v_ld,
        msb_min=d.msb_min,
        margin=d.msb_min - w_sch,
        binding_kind=d.binding_kind,
        binding_follower=d.binding_follower,
        method=d.method,
        feasible=d.feasible,
        msbs=msbs,
        msb_min_after=d.msb_min_after,
        msbs_after=after,
        candidates=d.candidates,
    )
