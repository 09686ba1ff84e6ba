"""Adjustment policies: what sets each window's w and the leader's speed target. A policy has
one method, ``decide(ctx: PolicyInput) -> Decision``; the built-in ones are registered in
`ADJUSTMENT_POLICIES`, each with its own options model (`PolicyOptions`: every key's default
and range once). The policies, their keys and how to add one: docs/adjustment.md.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar, Protocol, runtime_checkable

from rtsim._numbers import is_real
from rtsim._suggest import did_you_mean
from rtsim.analysis.bounds import LOWER_BOUNDS
from rtsim.analysis.kinematics import Thresholds, TurnError, unicycle_turn_error
from rtsim.control.adjust import (
    CANDIDATES,
    CAP_FACTOR,
    FLOOR_FRAC,
    FLOOR_W,
    TOL,
    Adjustment,
    Decision,
    adjust_core,
    adjustment_of,
    bound_rows_at,
    largest,
    make_predictor,
    search_rollout,
)
from rtsim.control.predict import (
    FollowerEstimate,
    Predictor,
    check_number,
    check_predictor,
    min_bound_rows,
)
from rtsim.errors import InputError
from rtsim.io.limits import Range
from rtsim.registry import Registry

__all__ = [
    "ADJUSTMENT_POLICIES",
    "AdjustOptions",
    "COMMON_KEYS",
    "DECIDE",
    "PolicyOptions",
    "option",
    "Decision",
    "Policy",
    "decide",
    "decide_rows",
    "PolicyInput",
    "adjust_options",
    "input_maker",
    "make_policy",
    "policy_class",
    "register_adjustment_policy",
]

#: When in its window the decision is taken (``[adjust] decide``): at the window job's end,
#: after the radio round trip (the paper's chain: scan, Hough, estimate, send, receive,
#: schedule), or at the start of the first send, so its speed leaves with the commands.
DECIDE: tuple[str, ...] = ("end", "before-send")

#: ``[adjust]`` keys every policy understands (options of the decision, ScenarioInputs.adjust).
COMMON_KEYS: tuple[str, ...] = (
    "policy",
    "cap",
    "cap_factor",
    "floor_frac",
    "floor_w",
    "predictor",
    "methods",
    "scan_points",
    "lower_bound",
    "decide",
    "paper_predictor",
)


@dataclass(frozen=True, slots=True)
class PolicyInput:
    """What the leader knows when a window completes (units: cm/s, ms, rad/s, 1/cm).

    followers: its estimates (left empty by a coupled run for a policy whose class sets
    ``needs_followers = False``, which reads them through ``rollout``); v_ld: the desired
    speed; w_sch: the window's lower bound; omega_l: its turn rate; kappa: the path's
    curvature where it is; v_now: its actual speed; cap: the largest window (None:
    CAP_FACTOR·w_sch); floor_frac: its speed when nothing restores the bounds, as a fraction
    of v_ld; floor_w: the smallest window of ``min-msb``;
    predictor, methods, scan_points: as in `rtsim.control.adjust.adjust`; ahead: the
    leader's known upcoming path commands as (distance from here to the command's start in
    cm, its curvature in 1/cm), nearest first (filled for a policy whose class sets
    ``needs_path = True``, else empty); accel_max, decel_max: the leader's speed ramp limits
    (cm/s², ``inf`` = the speed steps); speed_noise σ_v (cm/s), turn_noise σ_ω (rad/s): the
    followers' actuation noise per command, turn_error the heading error σ_ω makes over a
    window (their motion model's, `rtsim.analysis.kinematics.TurnError`); pose_sd: per
    follower (σ_p cm, σ_θ rad) from the leader's EKF covariance P, σ_p = √((P_xx +
    P_yy)/2), σ_θ = √P_θθ (these four are filled for a policy whose class sets
    ``needs_noise = True``, else 0 / the unicycle's / empty).

    rollout: **the command-aware rollout hook** (`rtsim.control.rollout.Rollout`),
    filled by a coupled run with follow-the-leader followers when the predictor is
    ``commands`` or the policy's class sets ``needs_rollout = True`` (else None):
    ``rollout.rows(v)`` — every follower's four bounds (ms) in the window this decision
    governs if the leader's target speed is ``v``, from the leader's own ramp and the
    commands it will send (`rtsim.control.rollout`); ``rollout.rows(v, w)`` for a window
    of ``w`` ms; ``rollout.changes(v, windows)`` — the predicted changes (displacement,
    |Δρ|, distance, |Δβ|) per follower in each of several consecutive windows;
    ``rollout.bounds(changes, w)`` turns one window's changes into bounds.
    """

    followers: Sequence[FollowerEstimate]
    v_ld: float
    w_sch: float
    thresholds: Thresholds
    omega_l: float = 0.0
    kappa: float = 0.0
    v_now: float | None = None
    cap: float | None = None
    floor_frac: float = FLOOR_FRAC
    floor_w: float = FLOOR_W
    predictor: str | Predictor = "formation"
    methods: Sequence[str] = CANDIDATES
    scan_points: int = 64
    ahead: tuple[tuple[float, float], ...] = ()
    accel_max: float = math.inf
    decel_max: float = math.inf
    speed_noise: float = 0.0
    turn_noise: float = 0.0
    turn_error: TurnError = unicycle_turn_error
    pose_sd: tuple[tuple[float, float], ...] = ()
    rollout: Any = None


def input_maker(template: PolicyInput, names: Sequence[str]) -> Callable[..., PolicyInput]:
    """The `PolicyInput` of each decision of a run: ``make(*values)`` is
    ``dataclasses.replace(template, **dict(zip(names, values)))``, the same object built
    through its slots' descriptors (a frozen dataclass's ``__init__`` sets every field by
    ``object.__setattr__``: twice the time, per decision)."""
    new, cls = object.__new__, PolicyInput
    kept = [
        (getattr(cls, f.name).__set__, getattr(template, f.name))
        for f in fields(cls)
        if f.name not in names
    ]
    sets = [getattr(cls, name).__set__ for name in names]  # (an unknown name: AttributeError)

    def make(*values: Any) -> PolicyInput:
        obj = new(cls)
        for put, value in kept:
            put(obj, value)
        for put, value in zip(sets, values, strict=True):
            put(obj, value)
        return obj  # type: ignore[no-any-return]

    return make


@runtime_checkable
class Policy(Protocol):
    """An adjustment policy: ``decide`` maps a [`PolicyInput`][rtsim.control.policy.PolicyInput] to
    a
    [`Decision`][rtsim.control.adjust.Decision]. ``params``: its own ``[adjust]`` keys and their
    defaults (its constructor takes them as keyword arguments)."""

    name: ClassVar[str]
    params: ClassVar[Mapping[str, Any]]

    def decide(self, ctx: PolicyInput) -> Decision: ...


def option(default: float, rng: Range) -> Any:
    """A field of a policy's options model: its one default and its one range ``rng``
    (`rtsim.io.limits.Range`; a value outside it is an `InputError` naming the key)."""
    return field(default=default, metadata={"range": rng})


def _checked(rng: Range, name: str, value: Any) -> float:
    """``value`` as a float (an int for a count) if ``rng`` admits it."""
    if not is_real(value) or not math.isfinite(float(value)):
        raise InputError(f"{name}: must be a finite number, got {value!r}")
    x = float(value)
    if not rng.admits(x) or (rng.integer and x != int(x)):
        kind = "an integer " if rng.integer else ""
        raise InputError(f"{name}: must be {kind}in {rng.interval()}, got {value!r}")
    return int(x) if rng.integer else x


@dataclass(frozen=True)
class PolicyOptions:
    """Base of a policy's options model: a frozen dataclass of `option` fields, each checked
    against its range when made. A policy class names its model in
    ``options``; its ``params`` (name → default) are derived from it."""

    def __post_init__(self) -> None:
        for f in fields(self):
            rng = f.metadata.get("range")
            if rng is not None:
                object.__setattr__(self, f.name, _checked(rng, f.name, getattr(self, f.name)))


_HORIZON = "the horizon, in windows of w_sch"
_MARGIN = Range(
    "margin", 0, 1, "", "the share μ of each predicted bound kept in reserve", hi_open=True
)
_Z = Range("z", 0, 10, "σ", "the padding of the predicted V_F, |ρ̇|, |β̇| in standard deviations")
_WINDOWS = Range("windows", 1, 100, "windows", _HORIZON)


#: `PolicyInput`'s defaults, the one declaration of those of `AdjustOptions`.
_INPUT: dict[str, Any] = {f.name: f.default for f in fields(PolicyInput)}


@dataclass(frozen=True)
class AdjustOptions(Mapping[str, Any]):
    """A run's ``[adjust]``, validated once (`adjust_options`, or from a scenario's table):
    the policy (an instance, made with its own keys ``own``) and the options every policy
    reads, each with its one default (`PolicyInput`'s fields of the same names; ``cap``
    None: CAP_FACTOR·w_sch, or ``cap_factor``·w_sch when that is given; ``floor_frac`` is
    also the lowest speed the coupling sets), ``lower_bound`` (the window's lower bound,
    `rtsim.analysis.bounds.LOWER_BOUNDS`), ``decide`` (`DECIDE`) and ``paper_predictor``
    (the policy ``adjust`` predicts with the paper's §3.3 whatever ``predictor`` says).

    As a mapping it is the keys that make it again (``policy`` by name, the options that
    differ from their default, the policy's own keys), so ``{**inputs.adjust, "cap": 500}``
    changes one option of a run's inputs."""

    policy: Any
    cap: float | None = _INPUT["cap"]
    cap_factor: float | None = None
    floor_frac: float = _INPUT["floor_frac"]
    floor_w: float = _INPUT["floor_w"]
    predictor: str | Predictor = _INPUT["predictor"]
    methods: tuple[str, ...] = _INPUT["methods"]
    scan_points: int = _INPUT["scan_points"]
    lower_bound: str = "w_sch"
    decide: str = "end"
    paper_predictor: bool = True
    own: Mapping[str, Any] = field(default_factory=dict)

    def _items(self) -> dict[str, Any]:
        out: dict[str, Any] = {"policy": self.policy.name}
        for f in fields(self):
            if f.name not in ("policy", "own") and getattr(self, f.name) != f.default:
                out[f.name] = getattr(self, f.name)
        return {**out, **self.own}

    def __getitem__(self, key: str) -> Any:
        return self._items()[key]

    def __iter__(self) -> Any:
        return iter(self._items())

    def __len__(self) -> int:
        return len(self._items())

    def overridden(self, spec: str | None, where: str = "adjust") -> AdjustOptions:
        """These options with the policy ``spec`` (``--policy``) instead: the own keys the new
        policy does not know are dropped (``--policy adjust`` on a file written for
        ``margin``; they were validated with their own policy)."""
        if spec is None or spec == self.policy.name:
            return self
        known = policy_class(spec, f"{where}.policy").params  # type: ignore[attr-defined]
        own = {k: v for k, v in self.own.items() if k in known}
        return dataclasses.replace(self, policy=make_policy(spec, own, where), own=own)


def _policy_class(cls: Any, spec: str, where: str) -> type:
    """A loaded class as a policy class (``params`` default ``{}``), or an InputError."""
    if not isinstance(cls, type) or not callable(getattr(cls, "decide", None)):
        raise InputError(
            f"{where} is not a policy class (it needs a method decide(ctx) -> Decision)"
        )
    if not hasattr(cls, "params"):
        cls.params = {}  # type: ignore[attr-defined]
    if not hasattr(cls, "name"):
        cls.name = spec  # type: ignore[attr-defined]
    return cls


#: Registered adjustment policies by name (entry-point group ``rtsim.policies``).
ADJUSTMENT_POLICIES: Registry[type] = Registry("adjustment policy", "rtsim.policies", _policy_class)


def register_adjustment_policy(name: str) -> Callable[[type], type]:
    """Class decorator: register a policy class under ``name`` (sets ``cls.name``)."""

    def deco(cls: type) -> type:
        if name in ADJUSTMENT_POLICIES and ADJUSTMENT_POLICIES[name] is not cls:
            raise ValueError(f"policy {name!r} is already registered")
        cls.name = name  # type: ignore[attr-defined]
        model = getattr(cls, "options", None)
        if model is not None:  # its params, from its options model
            cls.params = {f.name: f.default for f in fields(model)}  # type: ignore[attr-defined]
        elif not hasattr(cls, "params"):
            cls.params = {}  # type: ignore[attr-defined]
        ADJUSTMENT_POLICIES.register(name, cls)
        return cls

    return deco


def policy_class(spec: object, where: str = "policy", *, allow_code: bool | None = None) -> type:
    """The policy class named ``spec``: a registered name, an entry point or
    ``"package.module:Name"`` (code: `rtsim.registry.load_code`). An unknown name is an
    `InputError` with a did-you-mean."""
    return ADJUSTMENT_POLICIES.resolve(spec, where, allow_code=allow_code)  # type: ignore[arg-type]


def make_policy(
    spec: object,
    params: Mapping[str, Any] | None = None,
    where: str = "adjust",
    common: tuple[str, ...] = COMMON_KEYS,
) -> Any:
    """An instance of `policy_class` ``(spec)`` with its own keys ``params``; a key it
    does not know is an `InputError` with a did-you-mean (among ``common`` and its
    own keys)."""
    cls = policy_class(spec, f"{where}.policy")
    params = dict(params or {})
    known = tuple(cls.params)  # type: ignore[attr-defined]
    for key in params:
        if key not in known:
            names = tuple(common) + known
            close = did_you_mean(key, names)
            owner = [n for n, c in ADJUSTMENT_POLICIES.items() if key in c.params]  # type: ignore[attr-defined]
            hint = (
                close
                if close
                else f" (a key of policy '{owner[0]}', not of '{cls.name}')"  # type: ignore[attr-defined]
                if owner
                else f" (known keys: {', '.join(names)})"
            )
            raise InputError(f"{where}: unknown key '{key}'{hint}")
    try:
        return cls(**params)
    except InputError as exc:
        raise InputError(f"{where}.{exc}") from None


def adjust_options(
    opts: Mapping[str, Any], where: str = "adjust", override: str | None = None
) -> AdjustOptions:
    """Validate an ``[adjust]`` mapping (a hand-made `ScenarioInputs.adjust`) once: the
    policy (key ``policy``, default ``adjust``) made with its own keys, and the common
    options (`COMMON_KEYS`) as an `AdjustOptions`. The old key ``model`` names its
    replacement. ``override`` (``--policy``): `AdjustOptions.overridden`."""
    if isinstance(opts, AdjustOptions):
        return opts.overridden(override, where)
    if "model" in opts:
        raise InputError(f"{where}: unknown key 'model' (renamed; did you mean 'predictor'?)")
    own = {k: v for k, v in opts.items() if k not in COMMON_KEYS}
    policy = make_policy(opts.get("policy", "adjust"), own, where)
    common = {k: v for k, v in opts.items() if k in COMMON_KEYS and k != "policy"}
    if common.get("decide", "end") not in DECIDE:
        raise InputError(
            f"{where}.decide: must be one of {', '.join(DECIDE)}, got {common['decide']!r}"
        )
    if common.get("lower_bound", "w_sch") not in LOWER_BOUNDS:
        raise InputError(
            f"{where}.lower_bound: must be one of {', '.join(LOWER_BOUNDS)}, "
            f"got {common['lower_bound']!r}"
        )
    if isinstance(common.get("predictor"), str):
        check_predictor(common["predictor"], f"{where}.predictor")
    if "methods" in common:
        common["methods"] = tuple(common["methods"])
    return AdjustOptions(policy, own=own, **common).overridden(override, where)


def _check(ctx: PolicyInput, where: str) -> float:
    """Validate the numbers every baseline needs; returns the cap (ms)."""
    v_ld = check_number(where, "v_ld", ctx.v_ld)
    w_sch = check_number(where, "w_sch", ctx.w_sch)
    if w_sch <= 0.0:
        raise InputError(f"{where}: w_sch must be positive, got {w_sch!r}")
    del v_ld
    return CAP_FACTOR * w_sch if ctx.cap is None else check_number(where, "cap", ctx.cap)


def _rows_at_vld(ctx: PolicyInput) -> list[tuple[float, float, float, float]]:
    model = ctx.predictor
    predict = (
        None
        if model == "formation"
        else make_predictor(model, omega_l=ctx.omega_l, kappa=ctx.kappa, v_now=ctx.v_now)
    )
    return bound_rows_at(
        ctx.followers,
        predict,
        ctx.thresholds,
        model,
        ctx.kappa,
        ctx.omega_l,
        ctx.v_now,
        ctx.rollout,
    )(ctx.v_ld)


@register_adjustment_policy("adjust")
class PaperPolicy:
    """The paper's adjustment algorithm (§3.3, Eqs 22–26; `rtsim.control.adjust.adjust`):
    w = min(min MSB, cap) at V_Ld when min MSB ≥ w_sch, else w = w_sch and the largest speed
    at which every predicted bound is ≥ w_sch."""

    params: ClassVar[Mapping[str, Any]] = {}

    def decide(self, ctx: PolicyInput) -> Decision:
        return adjust_core(
            ctx.followers,
            ctx.v_ld,
            ctx.w_sch,
            ctx.thresholds,
            ctx.omega_l,
            ctx.kappa,
            ctx.cap,
            ctx.floor_frac,
            ctx.predictor,
            ctx.methods,
            ctx.scan_points,
            ctx.v_now,
            ctx.rollout,
        )


@register_adjustment_policy("fixed-wsch")
class FixedWschPolicy:
    """w = w_sch, V_L = V_Ld always; ``feasible``: min MSB ≥ w_sch."""

    params: ClassVar[Mapping[str, Any]] = {}

    def decide(self, ctx: PolicyInput) -> Decision:
        _check(ctx, "decide")
        rows = _rows_at_vld(ctx)
        m, kind, who = min_bound_rows(rows)
        return Decision(
            ctx.w_sch,
            ctx.v_ld,
            m,
            kind,
            who,
            "none",
            m >= ctx.w_sch * (1.0 - TOL),
            rows,
            rows,
            m,
            {},
        )


@register_adjustment_policy("min-msb")
class MinMsbPolicy:
    """w = min(max(min MSB, floor_w), max(cap, floor_w)), V_L = V_Ld always."""

    params: ClassVar[Mapping[str, Any]] = {}

    def decide(self, ctx: PolicyInput) -> Decision:
        cap = _check(ctx, "decide")
        floor_w = check_number("decide", "floor_w", ctx.floor_w)
        if floor_w <= 0.0:
            raise InputError(f"decide: floor_w must be positive, got {floor_w!r}")
        rows = _rows_at_vld(ctx)
        m, kind, who = min_bound_rows(rows)
        w = min(max(m, floor_w), max(cap, floor_w))
        return Decision(
            w, ctx.v_ld, m, kind, who, "none", m >= ctx.w_sch * (1.0 - TOL), rows, rows, m, {}
        )


@dataclass(frozen=True)
class MarginOptions(PolicyOptions):
    """The options of the policy ``margin``."""

    margin: float = option(0.1, _MARGIN)


@register_adjustment_policy("margin")
class MarginPolicy:
    """The paper's algorithm with every predicted bound shrunk by the factor (1 − μ):

    w = max(w_sch, min((1 − μ)·min MSB, cap)) with min MSB predicted at V_Ld; when
    (1 − μ)·min MSB < w_sch (overload) w = w_sch and V_L is the largest speed at which
    (1 − μ)·(every bound) ≥ w_sch, found by `adjust` against the
    raised lower bound w_sch / (1 − μ) (and the cap / (1 − μ)). μ = 0 is the paper's policy.
    ``feasible``: (1 − μ)·min MSB at the chosen speed ≥ w_sch.
    """

    options: ClassVar[type[PolicyOptions]] = MarginOptions

    def __init__(self, *args: Any, **kw: Any) -> None:
        self.margin = MarginOptions(*args, **kw).margin

    def decide(self, ctx: PolicyInput) -> Decision:
        keep = 1.0 - self.margin
        cap = _check(ctx, "margin")
        d = adjust_core(
            ctx.followers,
            ctx.v_ld,
            ctx.w_sch / keep,
            ctx.thresholds,
            ctx.omega_l,
            ctx.kappa,
            cap / keep,
            ctx.floor_frac,
            ctx.predictor,
            ctx.methods,
            ctx.scan_points,
            ctx.v_now,
            ctx.rollout,
        )
        w = ctx.w_sch if d.method != "none" else max(ctx.w_sch, min(keep * d.msb_min, cap))
        return d._replace(w=w)


@dataclass(frozen=True)
class LookaheadOptions(PolicyOptions):
    """The options of the policy ``lookahead``."""

    margin: float = option(0.0, _MARGIN)
    windows: float = option(2.0, _WINDOWS)


@register_adjustment_policy("lookahead")
class LookaheadPolicy:
    """The margin policy, made safe ahead of time along the leader's known path commands.

    1. d = `MarginPolicy` (``margin`` μ, default 0) on the current command (κ here).
    2. For every upcoming command j at distance D_j within the horizon
       H = V·(windows·w_sch / 1000) + V² / (2·decel_max) (V = the leader's actual speed), the
       safe speed there, v_j = the margin policy's speed with κ = κ_j, ω_L = κ_j·V and the
       ``formation`` predictor (docs/model/world.md: each follower moving with its slot on command
       j,
       from its estimated ρ, β — the followers' motion there is not yet observed); and the
       highest speed from which the leader can still brake to v_j
       before D_j once the next decision comes (one window later, after V·w/1000 cm):
       v_j* = √(v_j² + 2·decel_max·max(0, D_j − V·w/1000)) (uniform deceleration), which is
       v_j itself when the command starts within the window; with ``decel_max`` = inf (the
       speed steps) v_j* = v_j within the window and ∞ beyond it.
    3. Speed target V_L = min(d's speed, min_j v_j*): it slows before a turn so that the
       speed is safe when the turn begins, and since the commands within reach of the window
       count as well as the current one, it speeds up after a turn only when the bounds over
       the window ahead allow.
    4. w = max(w_sch, min(d's w, (1 − μ)·min bound at V_L, formation predictor, on every
       command that starts within the window, V_L·w/1000 cm)): a window that reaches into a
       turn is no longer than the bound in the turn.

    ``method`` is ``lookahead`` when step 3 lowered the speed, else d's. Own keys: ``margin``
    (μ in [0, 1), default 0) and ``windows`` (the horizon in windows of w_sch, ≥ 1, default 2).
    """

    options: ClassVar[type[PolicyOptions]] = LookaheadOptions
    #: the coupling fills PolicyInput.ahead, accel_max and decel_max for this policy
    needs_path: ClassVar[bool] = True

    def __init__(self, *args: Any, **kw: Any) -> None:
        o = LookaheadOptions(*args, **kw)
        self.base: Any = MarginPolicy(o.margin)
        self.windows = o.windows

    def decide(self, ctx: PolicyInput) -> Decision:
        d = self.base.decide(ctx)
        keep = 1.0 - self.base.margin
        v_now = ctx.v_ld if ctx.v_now is None else ctx.v_now
        a_d = float(ctx.decel_max)
        if not a_d > 0.0:
            raise InputError(f"lookahead: decel_max must be positive or inf, got {a_d!r}")
        brake = 0.0 if math.isinf(a_d) else v_now * v_now / (2.0 * a_d)
        horizon = v_now * self.windows * ctx.w_sch / 1000.0 + brake
        reach = v_now * d.w / 1000.0  # covered before the next decision
        v_l = d.v_leader
        for dist, kappa in ctx.ahead:
            if dist > horizon:
                break
            there = self.base.decide(
                dataclasses.replace(ctx, kappa=kappa, omega_l=kappa * v_now, predictor="formation")
            )
            v_safe = max(there.v_leader, ctx.floor_frac * ctx.v_ld)
            gap = max(0.0, dist - reach)
            if math.isinf(a_d):  # the speed steps: the next decision can still lower it
                v_ok = v_safe if gap == 0.0 else math.inf
            else:
                v_ok = math.sqrt(v_safe * v_safe + 2.0 * a_d * gap)
            v_l = min(v_l, v_ok)
        if v_l >= d.v_leader:
            d_out = d
        else:
            rows_after = bound_rows_at(
                ctx.followers,
                None
                if ctx.predictor == "formation"
                else make_predictor(
                    ctx.predictor, omega_l=ctx.omega_l, kappa=ctx.kappa, v_now=ctx.v_now
                ),
                ctx.thresholds,
                ctx.predictor,
                ctx.kappa,
                ctx.omega_l,
                ctx.v_now,
                ctx.rollout,
            )(v_l)
            m_after = min_bound_rows(rows_after)[0]
            d_out = d._replace(
                v_leader=v_l,
                method="lookahead",
                rows_after=rows_after,
                msb_min_after=m_after,
                feasible=keep * m_after >= ctx.w_sch * (1.0 - TOL),
            )
        w = d_out.w
        window_reach = v_l * w / 1000.0
        for dist, kappa in ctx.ahead:
            if dist > window_reach:
                break
            rows = bound_rows_at(
                ctx.followers, None, ctx.thresholds, "formation", kappa, kappa * v_now, ctx.v_now
            )(v_l)
            w = max(ctx.w_sch, min(w, keep * min_bound_rows(rows)[0]))
        return d_out if w == d_out.w else d_out._replace(w=w)


def pad_rows(
    rows: Sequence[tuple[float, float, float, float]],
    followers: Sequence[FollowerEstimate],
    ctx: PolicyInput,
    v: float,
    z: float,
) -> list[tuple[float, float, float, float]]:
    """Every follower's bounds at leader speed ``v`` with the predicted rates padded by z·σ.

    From the unpadded ``rows`` (any predictor) the predicted rates are recovered as
    |V_F| = 1000·T_ε·ρ_d / MSB_path, |ρ̇| = 1000·T_ρ·ρ_d / MSB_sep, |β̇| = 1000·T_β / MSB_bear
    (docs/model/adjustment.md's bounds, an infinite bound = a zero rate). With T = w_sch / 1000 s,
    follower i's
    σ_β = σ_p / ρ and σ_θ² = σ_θ,EKF² + σ_θ,turn(σ_ω, T)² (its heading drifts by the turn
    noise over one window: σ_ω·T for the unicycle, ``ctx.turn_error``), first-order
    propagation of ρ̇ = V_F cos(θ_F + β) − V_L cos β and
    β̇ = (V_L sin β − V_F sin(β + θ_F)) / ρ − ω_L with independent errors, bounded by
    |cos|, |sin| ≤ 1:

        S = √(σ_v² + (V_F·σ_θ)² + ((V_L + V_F)·σ_β)²),
        σ_VF = σ_v,  σ_ρ̇ = S,  σ_β̇ = S / ρ,

    and the padded bounds are 1000·r_H / (|ρ̇| + z·S) (radial localization), 1000·T_ρ·ρ_d /
    (|ρ̇| + z·S), 1000·T_ε·ρ_d / (|V_F| + z·σ_v), 1000·T_β / (|β̇| + z·S/ρ). z = 0 gives
    ``rows`` back unchanged (the same floats)."""
    if z == 0.0:
        return list(rows)
    thr = ctx.thresholds
    t_s = ctx.w_sch / 1000.0
    sv = float(ctx.speed_noise)
    out = []
    for i, (f, row) in enumerate(zip(followers, rows, strict=True)):
        sp, sth = ctx.pose_sd[i] if i < len(ctx.pose_sd) else (0.0, 0.0)
        n_loc, n_sep = 1000.0 * thr.r_H, 1000.0 * thr.T_rho * f.rho_d
        n_path, n_bear = 1000.0 * thr.T_eps * f.rho_d, 1000.0 * thr.T_beta
        rd = 0.0 if math.isinf(row[1]) else n_sep / row[1]
        vf = 0.0 if math.isinf(row[2]) else n_path / row[2]
        bd = 0.0 if math.isinf(row[3]) else n_bear / row[3]
        s_th2 = sth * sth + ctx.turn_error(ctx.turn_noise, t_s)[0] ** 2
        s_beta = sp / f.rho
        big_s = math.sqrt(sv * sv + vf * vf * s_th2 + ((v + vf) * s_beta) ** 2)

        def div(n: float, d: float) -> float:
            return math.inf if d == 0.0 else n / d

        if thr.localization == "radial":
            loc = div(n_loc, rd + z * big_s)
        elif thr.localization == "predicted":  # the noise is already in the bound
            loc = row[0]
        else:  # the full model's bound shrinks by the separation bound's factor
            loc = (
                row[0]
                if rd + z * big_s == 0.0
                else (row[0] * rd / (rd + z * big_s) if rd > 0.0 else row[0])
            )
        out.append(
            (
                loc,
                div(n_sep, rd + z * big_s),
                div(n_path, vf + z * sv),
                div(n_bear, bd + z * big_s / f.rho),
            )
        )
    return out


@dataclass(frozen=True)
class NoiseAwareOptions(PolicyOptions):
    """The options of the policy ``noise-aware``."""

    z: float = option(2.0, _Z)
    margin: float = option(0.0, _MARGIN)


@register_adjustment_policy("noise-aware")
class NoiseAwarePolicy:
    """The paper's algorithm against bounds whose predicted V_F, |ρ̇| and |β̇| are padded by
    z·σ (`pad_rows`; σ from the followers' actuation noise and the leader's EKF
    covariance), optionally with a margin μ:

    with m(v) = min over followers and bounds of the padded bounds at leader speed v,
    w = max(w_sch, min((1 − μ)·m(V_Ld), cap)) when (1 − μ)·m(V_Ld) ≥ w_sch; else w = w_sch and
    V_L = the largest speed with (1 − μ)·m(V_L) ≥ w_sch (scan of ``scan_points`` speeds below
    V_Ld, bisected; method ``numeric``), or floor_frac·V_Ld when none has (method ``floor``).
    Own keys: ``z`` (the padding in standard deviations, in [0, 10], default 2) and
    ``margin`` (μ in [0, 1), default 0). z = 0 with μ = 0 is the paper's decision at V_Ld.
    """

    options: ClassVar[type[PolicyOptions]] = NoiseAwareOptions
    #: the coupling fills PolicyInput.speed_noise, turn_noise, turn_error and pose_sd for
    #: this policy
    needs_noise: ClassVar[bool] = True

    def __init__(self, *args: Any, **kw: Any) -> None:
        o = NoiseAwareOptions(*args, **kw)
        self.z = o.z
        self.margin = o.margin

    def decide(self, ctx: PolicyInput) -> Decision:
        cap = _check(ctx, "noise-aware")
        keep = 1.0 - self.margin
        model = ctx.predictor
        predict = (
            None
            if model == "formation"
            else make_predictor(model, omega_l=ctx.omega_l, kappa=ctx.kappa, v_now=ctx.v_now)
        )
        raw = bound_rows_at(
            ctx.followers,
            predict,
            ctx.thresholds,
            model,
            ctx.kappa,
            ctx.omega_l,
            ctx.v_now,
            ctx.rollout,
        )
        memo: dict[float, list[tuple[float, float, float, float]]] = {}

        def rows_at(v: float) -> list[tuple[float, float, float, float]]:
            if v not in memo:
                memo[v] = pad_rows(raw(v), ctx.followers, ctx, v, self.z)
            return memo[v]

        rows = rows_at(ctx.v_ld)
        m, kind, who = min_bound_rows(rows)
        if keep * m >= ctx.w_sch:
            return Decision(
                max(ctx.w_sch, min(keep * m, cap)),
                ctx.v_ld,
                m,
                kind,
                who,
                "none",
                True,
                rows,
                rows,
                m,
                {},
            )
        need = ctx.w_sch * (1.0 - TOL)

        def ok(v: float) -> bool:
            return keep * min_bound_rows(rows_at(v))[0] >= need

        found = None
        if ctx.v_ld > 0.0:
            step = ctx.v_ld / ctx.scan_points
            grid = [ctx.v_ld - step * i for i in range(ctx.scan_points)]
            grid += [step * 0.5**j for j in range(1, 21)]
            found = largest(ok, grid)
        v_l = ctx.floor_frac * ctx.v_ld if found is None else found
        after = rows_at(v_l)
        m_after = min_bound_rows(after)[0]
        return Decision(
            ctx.w_sch,
            v_l,
            m,
            kind,
            who,
            "floor" if found is None else "numeric",
            keep * m_after >= need,
            rows,
            after,
            m_after,
            {"numeric": math.nan if found is None else found},
        )


@dataclass(frozen=True)
class SafeOptions(PolicyOptions):
    """The options of the policy ``safe``."""

    margin: float = option(0.1, _MARGIN)
    z: float = option(1.0, _Z)
    windows: float = option(2.0, _WINDOWS)


@register_adjustment_policy("safe")
class SafePolicy(LookaheadPolicy):
    """`LookaheadPolicy` on top of `NoiseAwarePolicy`: the current command's and
    every upcoming command's decision are the noise-aware one (padding z·σ, margin μ), the
    leader slows ahead of turns as in ``lookahead``. Own keys: ``margin`` (default 0.1),
    ``z`` (default 1) and ``windows`` (default 2)."""

    options: ClassVar[type[PolicyOptions]] = SafeOptions
    needs_path: ClassVar[bool] = True
    needs_noise: ClassVar[bool] = True

    def __init__(self, *args: Any, **kw: Any) -> None:
        o = SafeOptions(*args, **kw)
        super().__init__(o.margin, o.windows)
        self.base = NoiseAwarePolicy(o.z, o.margin)


@dataclass(frozen=True)
class PlanOptions(PolicyOptions):
    """The options of the policy ``plan``; ``contact``: keep the contact bound (a bool, no
    range: `PlanPolicy`)."""

    windows: int = option(2, Range("windows", 1, 20, "windows", _HORIZON, integer=True))
    margin: float = option(0.0, _MARGIN)
    contact: bool = True

    def __post_init__(self) -> None:
        super().__post_init__()
        if not isinstance(self.contact, bool):
            raise InputError(f"contact: must be true or false, got {self.contact!r}")


@register_adjustment_policy("plan")
class PlanPolicy:
    """Several windows ahead on the command-aware rollout (`PolicyInput.rollout`).

    For a candidate target speed V the rollout plays the leader (its path commands ahead and
    its ramp limits, so a slow-down costs the braking it needs) and every follower under the
    commands it will be sent, over ``windows`` windows of w_sch from the scan of the window
    this decision governs. m(V) = the smallest bound of every follower in every one of those
    windows (rollout bounds L·w / predicted change). The run's predictor is ``commands`` (the
    bounds recorded as the decision's belief are the rollout's).

    * m(V_Ld) ≥ w_sch / (1 − μ): V_L = V_Ld and w = max(w_sch, min((1 − μ)·m₁, cap)), with m₁
      the first window's smallest bound at V_Ld, checked once more by a rollout of a first
      window of that length (shrunk by its own worst change ratio if a change would exceed
      its threshold, never below w_sch);
    * else w = w_sch and V_L = the largest V with (1 − μ)·m(V) ≥ w_sch
      (`search_rollout`: bracket on 8 speeds, bisect to 0.5 % of
      V_Ld, method ``numeric``), or, when none has, the scanned speed with the largest m
      (method ``best``).

    The window's bound, ``msb_min`` and the rows are those of the first window (the window
    the decision governs). A constant target over the horizon is a conservative plan: the
    leader slows for the worst window ahead now, and speeds up only when the whole horizon
    allows.

    **The contact bound** (own key ``contact``, default true; `rtsim.world.contact`): a fifth
    bound beside the four, MSB_contact = w·d_i / d_c per follower and window, d_i the
    follower's predicted closest approach to any other robot (leader included) at the
    window's two scans and d_c = 2·r_F + clearance (`RolloutState.contact_cm`). It joins the
    four wherever the plan compares a rollout's bounds with a window: m(V) over the horizon,
    the check of the longer first window and the feasibility at the chosen speed; it does not
    set the first window's length (m₁, the rows, the binding bound and ``msb_min`` are the
    four's). Off: the plan of before it.

    Own keys: ``windows`` (horizon, integer 1–20, default 2), ``margin`` (μ in [0, 1), default
    0) and ``contact`` (bool, default true).
    """

    options: ClassVar[type[PolicyOptions]] = PlanOptions
    #: the coupling fills PolicyInput.rollout for this policy
    needs_rollout: ClassVar[bool] = True
    #: ... and leaves PolicyInput.followers empty: the plan reads the estimates only
    #: through the rollout
    needs_followers: ClassVar[bool] = False

    def __init__(self, *args: Any, **kw: Any) -> None:
        o = PlanOptions(*args, **kw)
        self.windows = int(o.windows)
        self.margin = o.margin
        self.contact = o.contact

    def decide(self, ctx: PolicyInput) -> Decision:
        return self._planned(ctx.rollout, ctx, *self._fixed(ctx))

    def on_rollout(self, ctx: PolicyInput) -> Callable[[Any], Decision] | None:
        """``decide`` for every decision of a run whose `PolicyInput` other than its
        ``rollout`` is ``ctx`` (`decide`'s inputs checked once): ``decider(rollout)`` is
        ``decide(dataclasses.replace(ctx, rollout=rollout))``, without the `PolicyInput` per
        decision (plan reads of a `PolicyInput` only v_ld, w_sch, cap, floor_frac and the
        rollout); None when ``decide`` is not this class's own (a subclass's, or replaced). A
        coupled run asks for it (`rtsim.coupling.scenario_run`)."""
        if type(self).decide is not _PLAN_DECIDE:  # (overridden, or replaced since)
            return None
        planned = self._planned
        keep, need, cap, v_floor = self._fixed(ctx)
        contact = self.contact
        seen: list[Any] = [None, 0.0]  # (the last rollout's base and its d_c: a run's one)

        def decider(ro: Any) -> Decision:
            base = getattr(ro, "base", None)  # (d_c read once per base)
            if base is None:
                return planned(ro, ctx, keep, need, cap, v_floor)
            if base is not seen[0]:
                seen[0], seen[1] = base, _contact_cm(ro) if contact else 0.0
            return planned(ro, ctx, keep, need, cap, v_floor, seen[1])

        def plan_args(base: Any) -> tuple[float, float, float, float, int, float]:
            """(keep, need, cap, v_floor, windows, d_c) of the decisions on rollouts whose
            base is ``base`` (`rtsim.control.rollout.Rollout.planned`'s)."""
            d_c = float(getattr(base, "contact_cm", 0.0)) if contact else 0.0
            return keep, need, cap, v_floor, self.windows, d_c

        # the decision of a compiled plan's ``hit`` (`Rollout.plan`'s answer): ``decision(hit)``
        # (a partial: no Python frame of its own per decision)
        decision = functools.partial(_planned_decision, ctx.v_ld)

        # (a coupled run whose rollout plans in one step reads these: `Rollout.planned`)
        if type(self)._planned is _PLANNED:  # (not a subclass's own `_planned`)
            decider.plan_args = plan_args  # type: ignore[attr-defined]
            decider.decision = decision  # type: ignore[attr-defined]
        return decider

    def _fixed(self, ctx: PolicyInput) -> tuple[float, float, float, float]:
        """(keep = 1 − μ, need, cap, v_floor) of ``ctx`` (checked: `_check`)."""
        cap = _check(ctx, "plan")
        return 1.0 - self.margin, ctx.w_sch * (1.0 - TOL), cap, ctx.floor_frac * ctx.v_ld

    def _planned(
        self,
        ro: Any,
        ctx: PolicyInput,
        keep: float,
        need: float,
        cap: float,
        v_floor: float,
        d_c: float | None = None,
    ) -> Decision:
        """`decide` on rollout ``ro`` (``ctx``'s other fields, `_fixed`'s numbers; ``d_c``,
        the contact bound's, when the caller has read it)."""
        if ro is None:
            raise InputError(
                "plan: needs the leader's rollout (PolicyInput.rollout), which a "
                "coupled run with follow-the-leader followers fills"
            )
        if d_c is None:  # the contact bound's d_c (cm; 0: off)
            d_c = _contact_cm(ro) if self.contact else 0.0
        plan = getattr(ro, "plan", None)  # the rollout's compiled decision, if it has one
        hit = (
            None
            if plan is None
            else plan(ctx.v_ld, keep, need, cap, v_floor, self.windows, ctx.w_sch, d_c)
        )
        if hit is None:  # the same decision in Python
            return self._decide(ctx, ro, keep, need, cap, v_floor, d_c)
        return _planned_decision(ctx.v_ld, hit)

    def _decide(
        self,
        ctx: PolicyInput,
        ro: Any,
        keep: float,
        need: float,
        cap: float,
        v_floor: float,
        d_c: float,
    ) -> Decision:
        """`decide` on a rollout without a compiled decision (``plan``), in Python."""
        lengths = (ctx.w_sch,) * self.windows

        def worst(v: float) -> float:
            per = ro.changes(v, lengths)
            m = min(min_bound_rows(ro.bounds(c, ctx.w_sch))[0] for c in per)
            return ro.contact(per, ctx.w_sch, d_c, m) if d_c > 0.0 else m  # type: ignore[no-any-return]

        rows = ro.rows(ctx.v_ld)
        m1, kind, who = min_bound_rows(rows)
        if keep * worst(ctx.v_ld) >= need:
            w = max(ctx.w_sch, min(keep * m1, cap))
            if w > ctx.w_sch:  # the longer first window, checked by its own rollout
                r_w = ro.rows(ctx.v_ld, w)
                m_w = min_bound_rows(r_w)[0]
                if d_c > 0.0:
                    m_w = ro.contact(ro.changes(ctx.v_ld, (w,)), w, d_c, m_w)
                if keep * m_w < w:
                    w = max(ctx.w_sch, keep * m_w)
            return Decision(w, ctx.v_ld, m1, kind, who, "none", True, rows, rows, m1, {})
        v_l, method, found = search_rollout(lambda v: keep * worst(v), ctx.v_ld, need, v_floor)
        after = ro.rows(v_l)
        m_after = min_bound_rows(after)[0]
        return Decision(
            ctx.w_sch,
            v_l,
            m1,
            kind,
            who,
            method,
            keep * worst(v_l) >= need,
            rows,
            after,
            m_after,
            {"numeric": found},
        )


def _contact_cm(ro: Any) -> float:
    """The contact bound's d_c (cm; 0: none known) of rollout ``ro``: its state's (a
    `Rollout`'s base: its state's fields that stay for a run)."""
    st = getattr(ro, "base", None)
    st = getattr(ro, "state", None) if st is None else st
    return float(getattr(st, "contact_cm", 0.0))


def _planned_decision(v_ld: float, hit: Any) -> Decision:
    """The `Decision` at desired speed ``v_ld`` of a compiled plan's ``hit``
    (`rtsim.control.rollout.Rollout.plan`'s numbers)."""
    w, v_l, method, found, feasible, rows, after = hit
    m1, kind, who = min_bound_rows(rows)
    # (Decision's fields in order, through namedtuple's _make: no Python __new__)
    if method == "none":
        return _DECISION((w, v_ld, m1, kind, who, "none", True, rows, rows, m1, {}))
    m_after = min_bound_rows(after)[0]
    return _DECISION(
        (w, v_l, m1, kind, who, method, feasible, rows, after, m_after, {"numeric": found})
    )


#: `PlanPolicy.decide` as defined (`PlanPolicy.on_rollout` stands for it only)
_PLAN_DECIDE = PlanPolicy.decide
#: `PlanPolicy._planned` as defined (`PlanPolicy.on_rollout`)
_PLANNED = PlanPolicy._planned

#: `Decision` from its eleven fields in order (namedtuple's ``_make``)
_DECISION = Decision._make


def decide_rows(mode: str, followers: Sequence[FollowerEstimate], **options: Any) -> Decision:
    """[`decide`][rtsim.control.policy.decide] as the lightweight
    [`Decision`][rtsim.control.policy.Decision] (bounds as rows in
    `BOUND_KINDS` order, no dicts): the registered policy ``mode``
    (`rtsim.control.policy`) on a [`PolicyInput`][rtsim.control.policy.PolicyInput] made of
    ``followers`` and ``options`` (its fields: v_ld, w_sch, thresholds, omega_l, kappa, cap,
    floor_frac, floor_w, predictor, methods, scan_points, v_now)."""
    return policy_class(mode, "mode")().decide(PolicyInput(followers, **options))


def decide(mode: str, followers: Sequence[FollowerEstimate], **options: Any) -> Adjustment:
    """One window's decision by the registered policy ``mode`` (`rtsim.control.policy`;
    ``options`` as in `decide_rows`), e.g. the reproduction's three modes:

    - ``adjust``: `adjust`;
    - ``fixed-wsch``: w = w_sch, V_L = V_Ld always (the bounds may break in the world);
    - ``min-msb``: w = min(max(min MSB, floor_w), cap), V_L = V_Ld always (the schedule may
      break); floor_w (ms, default 1) keeps a zero-or-tiny bound from making a zero window.

    In the two baselines ``method`` is ``none``, ``feasible`` says whether min MSB ≥ w_sch, and
    slack = max(0, w − w_sch).
    """
    d = decide_rows(mode, followers, **options)
    return adjustment_of(mode, d, float(options["w_sch"]), float(options["v_ld"]))
