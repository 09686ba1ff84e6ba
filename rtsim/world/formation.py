"""Formation slots (ρ_d,i, β_d,i) of the followers in the leader's frame: the l-ψ chevron,
follow-the-leader's ``line`` and ``fan`` layouts, each spread just enough that the laser
sees every follower (docs/followers.md, "The formation"; docs/model/world.md)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rtsim.errors import InputError, ScenarioError
from rtsim.registry import Registry
from rtsim.world._check import integer, number, positive

__all__ = [
    "CHEVRON_GAP",
    "CLEARANCE_MARGIN",
    "DEFAULT_CLEARANCE",
    "FAN_INNER",
    "FOLLOWER_MODELS",
    "FORMATION_LAYOUTS",
    "FORMATION_MODELS",
    "FollowerModel",
    "Formation",
    "chevron",
    "chevron_offsets",
    "fan",
    "fan_bearings",
    "fan_step",
    "in_line",
    "in_line_offsets",
    "outer_side",
]

#: How ``followers``/``separation``/``bearing_offset`` place them: ``line`` (the chevron for
#: l-ψ, `in_line` for follow-the-leader) or ``fan`` (`fan`).
FORMATION_LAYOUTS: tuple[str, ...] = ("line", "fan")
#: The least gap (cm) between any two robots' discs in the world by default
#: (``[formation] clearance``): summary.json counts the scans that break it.
DEFAULT_CLEARANCE = 10.0
#: What the layouts keep on top of the clearance (cm): the followers' true places depart
#: from their error-free ones by a few cm (at most 4 measured, docs/followers.md), so a
#: layout whose error-free lap keeps clearance + this margin keeps the clearance in the world.
CLEARANCE_MARGIN = 5.0
#: Followers the fan places on the inner side of the path's turns before the outer side is
#: full (the pair's one included).
FAN_INNER = 1


@dataclass(frozen=True)
class Formation:
    """Desired separation ``rho_d`` (cm) and bearing ``beta_d`` (rad) of every follower.

    Validated: ρ_d > 0, β_d ∈ [π/2, 3π/2] (followers trail inside the laser's view).
    `check_spacing` rejects slots closer than 2·r_F to each other or to the leader.
    """

    rho_d: tuple[float, ...]
    beta_d: tuple[float, ...]
    model: str = "l-psi"
    #: the least gap (cm) kept between any two robots' discs (``[formation] clearance``)
    clearance: float = 0.0

    def __post_init__(self) -> None:
        follower_model(self.model, "formation.model")
        c = number("formation.clearance", self.clearance)
        if not 0.0 <= c < math.inf:
            raise ScenarioError(f"formation.clearance: must be >= 0 cm, got {self.clearance!r}")
        object.__setattr__(self, "clearance", c)
        rho = tuple(positive(f"formation.slot[{i + 1}].rho_d", r) for i, r in enumerate(self.rho_d))
        beta = tuple(
            number(f"formation.slot[{i + 1}].beta_d", b) for i, b in enumerate(self.beta_d)
        )
        if not rho:
            raise ScenarioError("formation has no followers")
        if len(rho) != len(beta):
            raise ScenarioError(f"formation: {len(rho)} rho_d but {len(beta)} beta_d")
        for i, b in enumerate(beta):
            if not (math.pi / 2 - 1e-12 <= b <= 1.5 * math.pi + 1e-12):
                raise ScenarioError(
                    f"formation.slot[{i + 1}].beta_d: must be in [90, 270] deg (followers "
                    f"trail the leader), got {math.degrees(b):.6g} deg"
                )
        object.__setattr__(self, "rho_d", rho)
        object.__setattr__(self, "beta_d", beta)

    @property
    def n(self) -> int:
        return len(self.rho_d)

    @property
    def lateral(self) -> tuple[float, ...]:
        """Each follower's lateral offset from the leader's trace on straights, ρ_d·sin β_d
        (cm, positive to the left): its place in follow-the-leader."""
        return tuple(r * math.sin(b) for r, b in zip(self.rho_d, self.beta_d, strict=True))

    def xy(self) -> NDArray[np.float64]:
        """(n, 2) slot positions in the leader frame (cm)."""
        r = np.asarray(self.rho_d)
        b = np.asarray(self.beta_d)
        return np.column_stack((r * np.cos(b), r * np.sin(b)))

    def check_spacing(self, r_F: float) -> None:
        """Raise `ScenarioError` if slots (or a slot and the leader) are closer than
        2 r_F + clearance (the discs would touch or come within the clearance)."""
        p = self.xy()
        need = 2 * r_F + self.clearance
        what = f"2*r_F{' + clearance' if self.clearance else ''} = {need:.6g} cm"
        for i in range(self.n):
            if self.rho_d[i] < need - 1e-9:
                raise ScenarioError(
                    f"formation.slot[{i + 1}] is {self.rho_d[i]:.6g} cm from the leader, "
                    f"closer than {what}"
                )
            for j in range(i):
                d = float(np.hypot(*(p[i] - p[j])))
                if d < need - 1e-9:  # (a layout built for the clearance meets it exactly)
                    raise ScenarioError(
                        f"formation: followers {j + 1} and {i + 1} are {d:.6g} cm apart, "
                        f"closer than {what} "
                        f"(on top of each other)"
                    )


#: Angular gap kept between the discs of consecutive chevron pairs (rad): two beams.
CHEVRON_GAP = math.radians(1.0)


def chevron_offsets(
    pairs: int, separation: float, offset: float, r_F: float, gap: float = CHEVRON_GAP
) -> list[float]:
    """Bearing offset of each pair (rad): ``offset`` for the first, then widened so that no
    follower is hidden behind a nearer one (module docstring)."""
    offs = [offset]
    for p in range(2, pairs + 1):
        near, far = (p - 1) * separation, p * separation
        offs.append(
            offs[-1] + math.asin(min(1.0, r_F / near)) + math.asin(min(1.0, r_F / far)) + gap
        )
    return offs


def _pair_args(
    n: int, separation: float, offset: float, r_F: float
) -> tuple[int, float, float, float]:
    """The checked arguments of [`chevron`][rtsim.world.formation.chevron] and `in_line` (offset in
    [0, 90°])."""
    n = integer("formation.followers", n, minimum=1)
    sep = positive("formation.separation", separation)
    off = number("formation.bearing_offset", offset)
    r_F = positive("follower.radius", r_F)
    if not 0 <= off <= math.pi / 2:
        raise ScenarioError(
            f"formation.bearing_offset: must be in [0, 90] deg, got {math.degrees(off):.6g} deg"
        )
    return n, sep, off, r_F


def _pairs(n: int, sep: float, offs: list[float]) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """(ρ_d, β_d) of ``n`` followers in pairs: pair p at p·``sep`` cm, 180° ± ``offs[p − 1]``
    (odd followers right, even left)."""
    rho = tuple(sep * ((i + 1) // 2) for i in range(1, n + 1))
    beta = tuple(
        math.pi + (offs[(i + 1) // 2 - 1] if i % 2 == 1 else -offs[(i + 1) // 2 - 1])
        for i in range(1, n + 1)
    )
    return rho, beta


def chevron(
    n: int,
    separation: float,
    offset: float = math.radians(15),
    *,
    r_F: float = 25.0,
    gap: float = CHEVRON_GAP,
    clearance: float = 0.0,
) -> Formation:
    """The default V formation: pair p at p·``separation`` cm and 180° ± offset_p.

    offset_1 = ``offset``; further pairs turn outward so the laser sees every follower
    (module docstring). Raises `ScenarioError` if a pair would leave [90°, 270°].
    """
    n, sep, off, r_F = _pair_args(n, separation, offset, r_F)
    offs = chevron_offsets((n + 1) // 2, sep, off, r_F, gap)
    if offs[-1] > math.pi / 2:
        raise ScenarioError(
            f"formation.followers: {n} followers do not fit a chevron at {sep:.6g} cm that "
            f"keeps every follower in the laser's view (the last pair would need "
            f"{math.degrees(offs[-1]):.4g} deg off the track, above 90); use a larger "
            f"separation, a smaller bearing_offset, or [[formation.slot]]"
        )
    return Formation(*_pairs(n, sep, offs), clearance=clearance)


def in_line_offsets(
    pairs: int, separation: float, offset: float, r_F: float, gap: float = CHEVRON_GAP
) -> list[float]:
    """Bearing offset of each rank (rad) in follow-the-leader's line: rank p at p·separation,
    each rank tucked inside the one before it (module docstring)."""
    rho = [p * separation for p in range(1, pairs + 1)]
    half = [math.asin(min(1.0, r_F / r)) for r in rho]
    step = [half[p - 1] + half[p] + gap for p in range(1, pairs)]
    first = max(offset, half[-1] + 0.5 * gap + sum(step))
    offs = [first]
    for d in step:
        offs.append(offs[-1] - d)
    return offs


def in_line(
    n: int,
    separation: float,
    offset: float = math.radians(15),
    *,
    r_F: float = 25.0,
    gap: float = CHEVRON_GAP,
    clearance: float = 0.0,
) -> Formation:
    """Follow-the-leader's default line: rank p at p·``separation`` cm, its two followers at
    180° ± φ_p on straights (odd right, even left), φ_p from `in_line_offsets`.

    Raises `ScenarioError` if the first rank would need more than 90°.
    """
    n, sep, off, r_F = _pair_args(n, separation, offset, r_F)
    offs = in_line_offsets((n + 1) // 2, sep, off, r_F, gap)
    if offs[0] > math.pi / 2:
        raise ScenarioError(
            f"formation.followers: {n} followers do not fit a line at {sep:.6g} cm that keeps "
            f"every follower in the laser's view (the first rank would need "
            f"{math.degrees(offs[0]):.4g} deg off the track, above 90); use a larger "
            f"separation or [[formation.slot]]"
        )
    return Formation(*_pairs(n, sep, offs), "follow-the-leader", clearance)


@dataclass(frozen=True)
class FollowerModel:
    """How followers are controlled: ``on_trace`` (follow-the-leader: each follower tracks the
    leader's trace at its lateral offset, `rtsim.world.ftl`) or rigid slots (l-ψ), and
    ``place(n, separation, offset, *, r_F)``, the default slots of n followers (a
    [`Formation`][rtsim.world.formation.Formation]) for a scenario that gives ``followers`` and
    ``separation``."""

    name: str
    place: Callable[..., Formation]
    on_trace: bool


def _follower_model(obj: Any, spec: str, where: str) -> FollowerModel:
    if isinstance(obj, FollowerModel):
        return obj
    raise InputError(f"{where} is not a FollowerModel")


#: The follower models by name (``[formation] model``; entry-point group ``rtsim.followers``).
FOLLOWER_MODELS: Registry[FollowerModel] = Registry(
    "follower model", "rtsim.followers", _follower_model
)
FOLLOWER_MODELS.register(
    "follow-the-leader", FollowerModel("follow-the-leader", in_line, on_trace=True)
)
FOLLOWER_MODELS.register("l-psi", FollowerModel("l-psi", chevron, on_trace=False))
#: The old name of `FOLLOWER_MODELS` (it iterates over the names).
FORMATION_MODELS = FOLLOWER_MODELS


def follower_model(name: object, where: str = "formation.model") -> FollowerModel:
    """The follower model ``name`` names; an unknown one is a `ScenarioError`."""
    try:
        return FOLLOWER_MODELS.resolve(name, where)  # type: ignore[arg-type]
    except ScenarioError:
        raise
    except InputError as exc:
        raise ScenarioError(str(exc)) from None


def outer_side(curvatures: Sequence[float], lengths: Sequence[float]) -> int:
    """+1 (left) or −1 (right): the outer side of a path's turns, opposite to the way its
    turning adds up (a counter-clockwise path turns left: its outer side is the right)."""
    total = sum(k * ell for k, ell in zip(curvatures, lengths, strict=True))
    return 1 if total < 0 else -1


def fan_step(separation: float, r_F: float, clearance: float, gap: float = CHEVRON_GAP) -> float:
    """The fan's angular step (rad) between neighbours at ρ_d = ``separation``: the larger of
    the laser's (the two discs' angular half-widths plus ``gap``, so neither hides the other)
    and the clearance's (a chord of 2·r_F + ``clearance`` + `CLEARANCE_MARGIN` between
    the centres)."""
    seen = 2.0 * math.asin(min(1.0, r_F / separation)) + gap
    apart = 2.0 * math.asin(min(1.0, (r_F + 0.5 * (clearance + CLEARANCE_MARGIN)) / separation))
    return max(seen, apart)


def fan_bearings(
    n: int,
    separation: float,
    offset: float,
    r_F: float,
    outer: int = -1,
    gap: float = CHEVRON_GAP,
    clearance: float = 0.0,
) -> list[float]:
    """Bearings (rad) of the fan's followers (module docstring): follower 1 at 180° + offset
    on the right, 2 at 180° − offset on the left, then each further follower one step
    (`fan_step`) beyond the last on the outer side (``outer``: −1 right, +1
    left) while the inner side holds `FAN_INNER`, and on the inner side once the outer
    one is full (the next bearing would put the disc outside [90°, 270°]). A follower that
    fits neither side gets the outer side's next bearing (`fan` refuses it)."""
    step = fan_step(separation, r_F, clearance, gap)
    half = math.asin(min(1.0, r_F / separation))
    right, left = math.pi + offset, math.pi - offset
    bearings = [right, left][:n]
    inner_count = 1
    last = {-1: right, 1: left}

    def fits(b: float) -> bool:
        return math.pi / 2 + half <= b <= 1.5 * math.pi - half

    for _ in range(2, n):
        nxt = {side: last[side] + (step if side < 0 else -step) for side in (-1, 1)}
        side = outer
        if inner_count < FAN_INNER or (not fits(nxt[outer]) and fits(nxt[-outer])):
            side = -outer
        if side != outer:
            inner_count += 1
        last[side] = nxt[side]
        bearings.append(last[side])
    return bearings


def fan(
    n: int,
    separation: float,
    offset: float = math.radians(15),
    *,
    r_F: float = 25.0,
    outer: int = -1,
    gap: float = CHEVRON_GAP,
    model: str = "follow-the-leader",
    clearance: float = 0.0,
) -> Formation:
    """The fan: every follower at ρ_d = ``separation`` cm, bearings from `fan_bearings`
    (``model``: follow-the-leader holds them on straights, l-ψ as rigid slots). Raises
    `ScenarioError` when a follower would leave the laser's view (a bearing outside
    [90°, 270°] by its disc's half-width)."""
    n, sep, off, r_F = _pair_args(n, separation, offset, r_F)
    if outer not in (-1, 1):
        raise ValueError(f"outer must be -1 (right) or 1 (left), got {outer!r}")
    bearings = fan_bearings(n, sep, off, r_F, outer, gap, clearance)
    half = math.asin(min(1.0, r_F / sep))
    for i, b in enumerate(bearings):
        if not math.pi / 2 + half <= b <= 1.5 * math.pi - half:
            raise ScenarioError(
                f"formation.followers: {n} followers do not fit a fan at {sep:.6g} cm: "
                f"follower {i + 1} would need {math.degrees(b):.4g} deg, outside the laser's "
                f"view; use a larger separation, a smaller bearing_offset, or "
                f"[[formation.slot]]"
            )
    return Formation(tuple([sep] * n), tuple(bearings), model, clearance)
