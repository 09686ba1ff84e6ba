"""What the leader predicts a follower does as the leader's speed changes
(docs/model/adjustment.md, docs/model/world.md).

A *prediction model* maps (follower estimate, leader speed V_L) to (V_F, θ, ω_L):

* ``"formation"`` (docs/model/world.md): the follower moves with its formation slot — velocity =
  leader
  velocity + ω_L × (slot position in the leader frame), ω_L = κ·V_L, via
  [`formation_velocity`][rtsim.analysis.kinematics.formation_velocity]; so V_F = s·V_L with s fixed
  by the
  slot and κ, and θ is fixed. The bounds are evaluated at the *estimated* (ρ, β).
* ``"paper"`` (the paper's §3.3): Eq 17 and Eqs 19–21 evaluated on the EKF estimates —
  V̂_F, θ̂ and ω_L stay at the estimates (and the bounds at the estimated ρ̂, β̂) whatever V_L
  is, so the corrected closed forms of Eqs 23–26
  ([`paper_speed`][rtsim.control.closed_forms.paper_speed]) are exact for it.
* ``"hybrid"``: the follower's estimated velocity vector, with its formation feed-forward
  part following V_L: u(V_L) = û + f(V_L) − f(V_now), where û = V̂_F·(cos θ̂, −sin θ̂) is the
  estimated velocity in the leader frame, f(V) = s·V·(cos θ_F, −sin θ_F) the slot's
  feed-forward velocity (the ``formation`` model) and V_now the leader's current actual speed;
  V_F = |u|, θ = −atan2(u_y, u_x), ω_L = κ·V_L. Equivalently: the formation velocity at V_L
  plus the follower's current correction velocity û − f(V_now), held constant. It equals
  ``"paper"`` at V_L = V_now and ``"formation"`` when û = f(V_now).
* ``"commands"``: the leader plays its own motion and the followers' commands forward
  (`rtsim.control.rollout`): the bounds come from the predicted changes over the window,
  not from a (V_F, θ, ω_L) per follower, so it needs the rollout of a coupled run
  (`rtsim.control.policy.PolicyInput.rollout`);
* any callable with the `Predictor` signature.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from rtsim._numbers import is_real
from rtsim.analysis.kinematics import (
    BOUND_KINDS,
    Thresholds,
    follower_msbs,
    formation_velocity,
    scalar_msbs,
)
from rtsim.errors import InputError
from rtsim.registry import Registry

__all__ = [
    "FollowerEstimate",
    "PREDICTORS",
    "Predictor",
    "RENAMED",
    "check_predictor",
    "hybrid_velocity",
    "min_bound",
    "min_bound_rows",
    "predict_msb_rows",
    "predict_msbs",
    "predictor",
    "trusted_estimate",
    "unit_formation",
]


def check_number(where: str, name: str, value: float) -> float:
    if value.__class__ is float and value - value == 0.0:  # a finite float: the common case
        return value
    if not is_real(value) or not math.isfinite(value):
        raise InputError(f"{where}: {name} must be a finite number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class FollowerEstimate:
    """The leader's estimate of one follower (leader frame, docs/model/upper-bounds.md).

    rho (cm, > 0), beta (rad), theta = θ_L − θ_F (rad), v_f (cm/s, ≥ 0), rho_d: desired
    separation (cm, > 0), beta_d: desired bearing (rad) or ``None``; the formation slot used by
    the ``formation`` model is (rho_d, beta_d), or (rho, beta) when beta_d is ``None``.
    """

    rho: float
    beta: float
    theta: float
    v_f: float
    rho_d: float
    beta_d: float | None = None

    def __post_init__(self) -> None:
        where = "FollowerEstimate"
        for name in ("rho", "beta", "theta", "v_f", "rho_d"):
            object.__setattr__(self, name, check_number(where, name, getattr(self, name)))
        if self.beta_d is not None:
            object.__setattr__(self, "beta_d", check_number(where, "beta_d", self.beta_d))
        for name in ("rho", "rho_d"):
            if getattr(self, name) <= 0.0:
                raise InputError(f"{where}: {name} must be positive, got {getattr(self, name)!r}")
        if self.v_f < 0.0:
            raise InputError(f"{where}: v_f must be non-negative, got {self.v_f!r}")

    @classmethod
    def _trusted(
        cls,
        rho: float,
        beta: float,
        theta: float,
        v_f: float,
        rho_d: float,
        beta_d: float | None = None,
    ) -> FollowerEstimate:
        """Construct without validation: only for values the caller has already checked
        (finite floats, rho and rho_d > 0, v_f ≥ 0) — see `trusted_estimate`."""
        self = object.__new__(cls)
        object.__setattr__(self, "rho", rho)
        object.__setattr__(self, "beta", beta)
        object.__setattr__(self, "theta", theta)
        object.__setattr__(self, "v_f", v_f)
        object.__setattr__(self, "rho_d", rho_d)
        object.__setattr__(self, "beta_d", beta_d)
        return self

    @property
    def slot(self) -> tuple[float, float]:
        """Formation slot (ρ, β) in the leader frame."""
        if self.beta_d is None:
            return self.rho, self.beta
        return self.rho_d, self.beta_d


def trusted_estimate(
    rho: float, beta: float, theta: float, v_f: float, rho_d: float, beta_d: float | None = None
) -> FollowerEstimate:
    """``FollowerEstimate(...)``, skipping the validation when every value is a finite float
    in range (the per-window path of a coupled run); otherwise the checked constructor, with
    its errors."""
    if (
        rho.__class__ is float
        and beta.__class__ is float
        and theta.__class__ is float
        and v_f.__class__ is float
        and rho_d.__class__ is float
        and (beta_d is None or (beta_d.__class__ is float and beta_d - beta_d == 0.0))
        and rho > 0.0
        and rho_d > 0.0
        and v_f >= 0.0
        and rho - rho == 0.0
        and beta - beta == 0.0
        and theta - theta == 0.0
        and v_f - v_f == 0.0
        and rho_d - rho_d == 0.0
    ):
        return FollowerEstimate._trusted(rho, beta, theta, v_f, rho_d, beta_d)
    return FollowerEstimate(rho, beta, theta, v_f, rho_d, beta_d)


#: (follower, leader speed) -> (V_F, θ, ω_L) predicted at that leader speed.
Predictor = Callable[[FollowerEstimate, float], tuple[float, float, float]]


#: A prediction model's factory: ``factory(omega_l=, kappa=, v_now=)`` gives the predictor of
#: one decision (the leader's turn rate, the path's curvature, its current speed).
PredictorFactory = Callable[..., Predictor]


def _formation(*, omega_l: float, kappa: float, v_now: float | None = None) -> Predictor:
    def formation(f: FollowerEstimate, v_l: float) -> tuple[float, float, float]:
        s, theta_f = unit_formation(kappa, *f.slot)
        return s * v_l, theta_f, kappa * v_l

    return formation


def _paper(*, omega_l: float, kappa: float, v_now: float | None = None) -> Predictor:
    return lambda f, v_l: (f.v_f, f.theta, omega_l)


def _hybrid(*, omega_l: float, kappa: float, v_now: float | None = None) -> Predictor:
    if v_now is None:
        raise InputError("model 'hybrid' needs the leader's current speed v_now")
    v0 = check_number("predictor", "v_now", v_now)
    if v0 < 0.0:
        raise InputError(f"predictor: v_now must be non-negative, got {v_now!r}")

    def hybrid(f: FollowerEstimate, v_l: float) -> tuple[float, float, float]:
        return hybrid_velocity(f, v_l, v0, kappa) + (kappa * v_l,)

    return hybrid


def _factory(obj: Any, spec: str, where: str) -> PredictorFactory:
    if not callable(obj):
        raise InputError(
            f"{where} is not a predictor factory (a callable "
            f"factory(omega_l=, kappa=, v_now=) -> predictor)"
        )
    return obj  # type: ignore[no-any-return]


#: The prediction models (``[adjust] predictor`` of a scenario) by name, each a factory
#: (entry-point group ``rtsim.predictors``).
PREDICTORS: Registry[PredictorFactory] = Registry(
    "prediction model", "rtsim.predictors", _factory, renamed={"estimate": "paper"}
)
PREDICTORS.register("paper", _paper)
PREDICTORS.register("formation", _formation)
PREDICTORS.register("hybrid", _hybrid)
PREDICTORS.register("commands", lambda **_: _needs_rollout)
#: Old names, an input error naming their replacement.
RENAMED: dict[str, str] = PREDICTORS.renamed


def check_predictor(name: object, where: str = "predictor") -> str:
    """``name`` if it names a prediction model (`PREDICTORS`); else an
    `InputError` with a did-you-mean (old names such as ``estimate`` name their
    replacement)."""
    PREDICTORS.resolve(name, where)  # type: ignore[arg-type]
    return name  # type: ignore[return-value]


def predictor(
    model: str | Predictor, *, omega_l: float, kappa: float, v_now: float | None = None
) -> Predictor:
    """The prediction model named ``model`` (`PREDICTORS`), or ``model``.

    ``v_now``: the leader's current actual speed (cm/s), required by ``"hybrid"``.
    """
    if callable(model):
        return model
    factory = PREDICTORS.get(model)
    if factory is None:  # an entry point, code, or an error naming the model
        check_predictor(model)
        factory = PREDICTORS.resolve(model, "predictor")
    return factory(omega_l=omega_l, kappa=kappa, v_now=v_now)


def _needs_rollout(f: FollowerEstimate, v_l: float) -> tuple[float, float, float]:
    """The ``commands`` model has no per-follower form: its bounds come from the leader's
    rollout (`rtsim.control.rollout`), which the decision receives separately."""
    raise InputError(
        "predictor 'commands' needs the leader's rollout (PolicyInput.rollout; "
        "a coupled run with follow-the-leader followers fills it)"
    )


def hybrid_velocity(
    f: FollowerEstimate, v_l: float, v_now: float, kappa: float
) -> tuple[float, float]:
    """(V_F, θ) of the ``hybrid`` model (module docstring) at leader speed ``v_l``."""
    s, theta_f = unit_formation(kappa, *f.slot)
    dv = s * (v_l - v_now)
    ux = dv * math.cos(theta_f) + f.v_f * math.cos(f.theta)
    uy = -dv * math.sin(theta_f) - f.v_f * math.sin(f.theta)
    v_f = math.hypot(ux, uy)
    return v_f, (-math.atan2(uy, ux) if v_f > 0.0 else f.theta)


_UNIT_FORMATION: dict[tuple[float, float, float, float], tuple[float, float]] = {}


def unit_formation(kappa: float, rho: float, beta: float) -> tuple[float, float]:
    """``formation_velocity(1.0, kappa, rho, beta)`` (V_F per unit V_L, θ), memoised: a pure
    function of its arguments, evaluated once per (κ, slot)."""
    key = (kappa, rho, beta, math.copysign(1.0, kappa))
    out = _UNIT_FORMATION.get(key)
    if out is None:
        if len(_UNIT_FORMATION) >= 4096:
            _UNIT_FORMATION.clear()
        out = _UNIT_FORMATION[key] = formation_velocity(1.0, kappa, rho, beta)
    return out


def predict_msbs(
    followers: Sequence[FollowerEstimate], v_l: float, predict: Predictor, thr: Thresholds
) -> list[dict[str, float]]:
    """Every follower's four bounds (ms) at leader speed ``v_l`` under ``predict``."""
    out = []
    for f in followers:
        v_f, theta, omega_l = predict(f, v_l)
        out.append(follower_msbs(v_l, omega_l, v_f, f.rho, f.beta, theta, f.rho_d, thr))
    return out


def predict_msb_rows(
    followers: Sequence[FollowerEstimate], v_l: float, predict: Predictor, thr: Thresholds
) -> list[tuple[float, float, float, float]]:
    """[`predict_msbs`][rtsim.control.predict.predict_msbs] as tuples in `BOUND_KINDS` order (same
    values, no dicts)."""
    out = []
    for f in followers:
        v_f, theta, omega_l = predict(f, v_l)
        if (
            v_l.__class__ is float
            and v_f.__class__ is float
            and theta.__class__ is float
            and omega_l.__class__ is float
        ):
            out.append(scalar_msbs(v_l, omega_l, v_f, f.rho, f.beta, theta, f.rho_d, thr))
        else:
            m = follower_msbs(v_l, omega_l, v_f, f.rho, f.beta, theta, f.rho_d, thr)
            out.append(tuple(m[k] for k in BOUND_KINDS))  # type: ignore[arg-type]
    return out


def min_bound_rows(rows: Sequence[Sequence[float]]) -> tuple[float, str, int]:
    """[`min_bound`][rtsim.control.predict.min_bound] over rows of the four bounds in
    `BOUND_KINDS` order (the first smallest, in row then kind order; NaN never is)."""
    best, kind, who = math.inf, "none", 0
    k0, k1, k2, k3 = BOUND_KINDS
    i = 0
    for a, b, c, d in rows:  # (unrolled: a loop over the four was 2-3x the time)
        i += 1
        if a < best:
            best, kind, who = a, k0, i
        if b < best:
            best, kind, who = b, k1, i
        if c < best:
            best, kind, who = c, k2, i
        if d < best:
            best, kind, who = d, k3, i
    return best, kind, who


def min_bound(msbs: Sequence[Mapping[str, float]]) -> tuple[float, str, int]:
    """(min bound, its kind, its 1-based follower); ("none", 0) when there is no finite one."""
    best, kind, who = math.inf, "none", 0
    for i, m in enumerate(msbs, start=1):
        for k in BOUND_KINDS:
            if m[k] < best:
                best, kind, who = m[k], k, i
    return best, kind, who
