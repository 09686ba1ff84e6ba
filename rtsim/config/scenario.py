"""Scenario files: the typed model of the file, and the runtime objects built from it once
it is valid ([`WorldConfig`][rtsim.world.config.WorldConfig], the task set,
[`AdjustConfig`][rtsim.config.scenario.AdjustConfig]),
each built once.

Angles are radians, or degrees when the key is written with ``_deg`` (``heading_deg``):
both spellings are fields of the model, with the same range. See
[`rtsim.config.scenario`][rtsim.config.scenario]
for the file format.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields, replace
from functools import lru_cache, partial
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal, NamedTuple, TypeVar

from pydantic import ConfigDict, Field, create_model, model_validator

from rtsim.analysis.bounds import LOWER_BOUNDS
from rtsim.analysis.kinematics import (
    LOCALIZATION_KINDS,
    R_H_DEFAULT,
    Thresholds,
)
from rtsim.config.errors import raise_errors
from rtsim.config.fields import (
    Leaf,
    Table,
    choice,
    integer,
    number,
    plugin,
    problem,
    ranged,
    text,
)
from rtsim.config.load import parse_toml, validate, with_overrides
from rtsim.config.taskset import packaged_data, taskset_bytes, taskset_from_bytes
from rtsim.control.policy import DECIDE, AdjustOptions, make_policy
from rtsim.control.predict import PREDICTORS
from rtsim.errors import InputError, ScenarioError
from rtsim.examples import shipped_hint
from rtsim.io.limits import read_input
from rtsim.model.taskset import TaskSet
from rtsim.registry import file_allows_code, reading_input
from rtsim.sim.policy import SCHEDULERS
from rtsim.world.config import (
    CENTRES,
    DEFAULT_THRESHOLDS,
    SEARCHES,
    WORLD_BACKENDS,
    LocalizationParams,
    RadioParams,
    SensingParams,
    WorldConfig,
)
from rtsim.world.ekf import EKF_BACKENDS, EkfParams
from rtsim.world.follower import FollowerParams
from rtsim.world.formation import (
    DEFAULT_CLEARANCE,
    FOLLOWER_MODELS,
    FORMATION_LAYOUTS,
    Formation,
    fan,
    follower_model,
    outer_side,
)
from rtsim.world.ideal import START_ON, check_clearance, settled_start
from rtsim.world.locmodels import LOCALIZATION_MODELS, predicted_bound_ms
from rtsim.world.motionmodels import MOTION_MODELS
from rtsim.world.path import LeaderPath, Segment, Straight, Turn, rounded_rectangle

__all__ = [
    "AdjustConfig",
    "fit_taskset",
    "Scenario",
    "ScenarioFile",
    "load_scenario",
    "parse_scenario",
    "scenario_bytes",
    "PACKAGED_SCENARIOS",
    "PACKAGED_TASKSETS",
    "PRESETS",
    "UNTIL",
]

#: Task-set names that refer to the package's own files rather than to a path.
PACKAGED_TASKSETS = ("barrel_robots", "example")
#: Scenarios shipped with rtsim (the paper's Test 1 and Test 2), loadable by name.
PACKAGED_SCENARIOS = ("test1", "test2")

#: The model choices a scenario file leaves unsaid, by ``preset`` (docs/configuration.md).
#: ``recommended`` (the default) is what the shipped Test 1/2 chose by evidence
#: (docs/results.md, docs/planning.md, docs/followers.md, docs/localization.md); ``paper`` is
#: the paper's own algorithm as written: its adjustment, its predictor (the followers'
#: estimated speed held), its window centre (Fig 5) and a search for every lost follower.
#: A key the file gives always wins; ``formation.layout`` applies to a pattern, not to slots.
PRESETS: dict[str, dict[str, str]] = {
    "recommended": {
        "formation.model": "follow-the-leader",
        "formation.layout": "fan",
        "adjust.policy": "plan",
        "adjust.predictor": "commands",
        "localization.centre": "predicted",
        "localization.search": "visible",
        "localization.model": "hough",
    },
    "paper": {
        "formation.model": "follow-the-leader",
        "formation.layout": "line",
        "adjust.policy": "adjust",
        "adjust.predictor": "paper",
        "localization.centre": "previous",
        "localization.search": "always",
        "localization.model": "hough",
    },
}
_DEFAULT = PRESETS["recommended"]
#: ``until``: what ends a run without a ``duration`` (docs/scenarios.md): ``lap``, the leader's
#: lap plus the largest ρ_d, so that the followers complete theirs too
#: (`rtsim.coupling.duration`). A ``duration`` given anywhere replaces it.
UNTIL: tuple[str, ...] = ("lap",)

#: Top-level keys an override may set though the file leaves them out (``--set
#: duration=30``), each with the key it replaces.
_TOP_KEYS: dict[str, str | None] = {"duration": "until", "until": "duration", "preset": None}

T = TypeVar("T")
Side = Literal["left", "right"]


# ----------------------------------------------------------------- runtime objects
@dataclass(frozen=True)
class Scenario:
    """A validated scenario: the world, the task set reference, duration and assumptions.

    ``scheduler``: the leader CPU's scheduling policy from ``[scheduler] policy`` (None: the
    task set's, ``fp`` unless its file says otherwise). ``task_set``: the task-set file, read
    once when the scenario is loaded (`load_taskset` gives it the scenario's n, r_H
    and scheduler). ``duration``: simulated s, exact; 0 with ``until = "lap"`` (the run ends
    with the lap, `rtsim.coupling.duration`).
    """

    name: str
    world: WorldConfig
    taskset: str = "barrel_robots"
    duration: float = 0.0
    description: str = ""
    until: str | None = None
    adjust: AdjustConfig = field(default_factory=lambda: AdjustConfig())
    assumptions: Mapping[str, str] = field(default_factory=dict)
    source: str | None = None
    scheduler: str | None = None
    task_set: TaskSet | None = field(default=None, compare=False, repr=False)
    #: the file may name code (``module:Name``), also in its task set (the user opted in)
    allow_code: bool = field(default=False, compare=False)
    #: (the ``adjust`` table, the policy made from it once when the scenario was built)
    made: tuple[Any, Any] | None = field(default=None, compare=False, repr=False)

    @property
    def n(self) -> int:
        return self.world.n

    def load_taskset(self) -> TaskSet:
        """The task set, with its window's n and r_H set to the scenario's (followers, r_H)
        and the scenario's ``[scheduler]``; the file is read once, when the scenario is
        loaded (``task_set``), or here for a scenario made by hand."""
        where = self.source or "<scenario>"
        ts = (
            self.task_set
            if self.task_set is not None
            else _read_taskset(self.taskset, where, self.allow_code)
        )
        return fit_taskset(ts, self.world, self.scheduler)

    def policy(self) -> Any:
        """The ``[adjust]`` policy: the one made when the scenario was built, or (``adjust``
        replaced since, or a scenario made by hand) made now from ``adjust``."""
        if self.made is not None and self.made[0] is self.adjust:
            return self.made[1]
        adj = self.adjust
        return make_policy(adj.policy, adj.params, "adjust", tuple(AdjustConfig.model_fields))


def taskset_file(name: str) -> str | None:
    """What `load_taskset` reads for a scenario's ``taskset`` ``name``: a packaged set by its
    own name (``None``: the paper's; "example" is the generic set), else the path."""
    return None if name == "barrel_robots" else name


#: Task-set files a process keeps built (`_built_taskset`): a sweep's points and a
#: notebook's runs read the same few.
TASKSETS_KEPT = 8


@lru_cache(maxsize=TASKSETS_KEPT)
def _built_taskset(raw: bytes, source: str, allow_code: bool) -> TaskSet:
    """The task set of a file's bytes, built once per process for each (bytes, name, code
    allowed): what it builds depends on nothing else (an edited file has other bytes). The
    TaskSet is immutable and shared."""
    ts: TaskSet = taskset_from_bytes(raw, source, allow_code=allow_code)
    return ts


def _read_taskset(name: str, where: str, allow_code: bool | None = None) -> TaskSet:
    """The task-set file ``name`` (a packaged name or a path), which must have a [window];
    read at every call, built once per content (`_built_taskset`)."""
    ts = _built_taskset(*taskset_bytes(taskset_file(name)), file_allows_code(allow_code))
    if ts.window is None:
        raise ScenarioError(f"{where}: taskset: '{name}' has no [window]")
    return ts


def fit_taskset(ts: TaskSet, world: WorldConfig, scheduler: str | None = None) -> TaskSet:
    """``ts`` with the world's follower count and r_H (``[sensing] r_H``, a coupled run's one
    r_H) and the scenario's scheduler (None: the set's): the one source of each."""
    assert ts.window is not None
    if (ts.window.n, ts.window.r_H) != (world.n, world.thresholds.r_H):
        ts = ts.with_window(n=world.n, r_H=world.thresholds.r_H)
    if scheduler is not None and scheduler != ts.scheduler:
        ts = replace(ts, scheduler=scheduler)
    return ts


# ------------------------------------------------------------------------ the model
_CM_MAX = 1e7  # cm: 100 km
_MS_MAX = 1e9
_ANGLE = 20 * math.pi


def _angle(
    lo: float,
    hi: float,
    why: str,
    deg: bool = False,
    lo_open: bool = False,
    unit: str = "rad",
    inf: bool = False,
) -> Any:
    return number(lo, hi, unit, why, deg=deg, lo_open=lo_open, inf=inf)


class _Angles(Table):
    """A table with angle keys that may be written in degrees (``<key>_deg``)."""

    #: Angle keys that must be given (in one spelling).
    _required_angles: ClassVar[tuple[str, ...]] = ()

    @model_validator(mode="after")
    def _one_spelling(self) -> Any:
        for name in type(self).model_fields:
            if name.endswith("_deg") and name[:-4] in type(self).model_fields:
                key = name[:-4]
                if key in self.model_fields_set and getattr(self, name) is not None:
                    raise problem(f"give {key} or {name}, not both")
        for key in self._required_angles:
            if getattr(self, key) is None and getattr(self, f"{key}_deg") is None:
                raise problem(f"{key}: missing (required)")
        return self

    def radians(self, key: str, default: Any = None) -> Any:
        """The angle ``key`` in radians (its ``_deg`` twin converted), or ``default``; a key
        without a twin as it is."""
        deg = getattr(self, f"{key}_deg", None)
        if deg is not None:
            return math.radians(float(deg))
        value = getattr(self, key)
        return default if value is None else value

    def build(self, spec: Callable[..., T]) -> T:
        """The world's spec ``spec`` (a dataclass) made of this table's values of its fields
        (angles in radians)."""
        keys = spec.__dataclass_fields__  # type: ignore[attr-defined]
        return spec(**{key: self.radians(key) for key in keys})


_HEADING = "ten turns either way"


class StartTable(_Angles):
    x: Annotated[float, number(-_CM_MAX, _CM_MAX, "cm", "within 100 km")] = 0.0
    y: Annotated[float, number(-_CM_MAX, _CM_MAX, "cm", "within 100 km")] = 0.0
    heading: Annotated[float, _angle(-_ANGLE, _ANGLE, _HEADING)] | None = None
    heading_deg: Annotated[float, _angle(-_ANGLE, _ANGLE, _HEADING, deg=True)] | None = None


class SegmentTable(_Angles):
    """One entry of ``leader.path``: ``{straight = <cm>}`` or ``{turn = "left", radius, angle}``."""

    straight: (
        Annotated[float, number(0, _CM_MAX, "cm", "a straight of at most 100 km", lo_open=True)]
        | None
    ) = None
    turn: Annotated[Side, choice(("left", "right"))] | None = None
    radius: (
        Annotated[
            float,
            number(1, _CM_MAX, "cm", "a turn tighter than 1 cm is a spin in place, not an arc"),
        ]
        | None
    ) = None
    angle: Annotated[float, _angle(0, _ANGLE, "up to ten full turns", lo_open=True)] | None = None
    angle_deg: (
        Annotated[float, _angle(0, _ANGLE, "up to ten full turns", deg=True, lo_open=True)] | None
    ) = None

    @model_validator(mode="after")
    def _kind(self) -> Any:
        if self.straight is not None and self.turn is not None:
            raise problem("a segment is either straight or turn, not both")
        if self.straight is None and self.turn is None:
            raise problem("a segment needs 'straight = <cm>' or 'turn = \"left\"|\"right\"'")
        if self.turn is not None:
            for req in ("radius", "angle"):
                if getattr(self, req) is None and (req != "angle" or self.angle_deg is None):
                    raise problem(f"{req}: missing (required for a turn)")
        else:
            for key in ("radius", "angle", "angle_deg"):
                if getattr(self, key) is not None:
                    raise problem(f"{key}: only for a turn")
        return self


class ShapeTable(Table):
    kind: Annotated[str, choice(("rounded_rectangle",))]
    length: Annotated[float, number(0, _CM_MAX, "cm", "at most 100 km")]
    width: Annotated[float, number(0, _CM_MAX, "cm", "at most 100 km")]
    radius: Annotated[float, number(1, _CM_MAX, "cm", "as a path turn's radius")]
    direction: Annotated[Side, choice(("left", "right"))] = "left"


def _spec(cls: type, key: str) -> Leaf:
    """The range of field ``key`` of the world's spec ``cls``, declared there once with its
    default (`rtsim.world._check.spec`)."""
    return ranged(cls.__dataclass_fields__[key].metadata["range"])  # type: ignore[attr-defined]


class LeaderTable(Table):
    """``[leader]``: its numbers are `rtsim.world.config.WorldConfig`'s ``leader_*`` and
    ``start_s`` fields."""

    # (start_on's default differs from WorldConfig's on purpose: a file's group starts
    # settled on a straight, a config built by hand where it is given)

    speed: Annotated[float, _spec(WorldConfig, "leader_speed")]
    start: StartTable = Field(default_factory=StartTable)
    start_s: Annotated[float, _spec(WorldConfig, "start_s")] = WorldConfig.start_s
    start_on: Annotated[str, choice(START_ON)] = "straight"
    accel_max: Annotated[float, _spec(WorldConfig, "leader_accel_max")] = (
        WorldConfig.leader_accel_max
    )
    decel_max: Annotated[float, _spec(WorldConfig, "leader_decel_max")] = (
        WorldConfig.leader_decel_max
    )
    path: list[SegmentTable] | None = Field(default=None, min_length=1)
    shape: ShapeTable | None = None

    @model_validator(mode="after")
    def _path_or_shape(self) -> Any:
        if (self.path is None) == (self.shape is None):
            raise problem("give exactly one of 'path' or 'shape'")
        return self


class SlotTable(_Angles):
    _required_angles: ClassVar[tuple[str, ...]] = ("beta_d",)
    rho_d: Annotated[float, number(0, 1e5, "cm", "as separation", lo_open=True)]
    beta_d: Annotated[float, _angle(-_ANGLE, _ANGLE, "an angle")] | None = None
    beta_d_deg: Annotated[float, _angle(-_ANGLE, _ANGLE, "an angle", deg=True)] | None = None


class FormationTable(_Angles):
    model: Annotated[str, plugin(FOLLOWER_MODELS)] = _DEFAULT["formation.model"]
    layout: Annotated[str, choice(FORMATION_LAYOUTS)] = _DEFAULT["formation.layout"]
    followers: Annotated[int, integer(1, 1000, "followers", "as window.n")] | None = None
    separation: (
        Annotated[float, number(0, 1e5, "cm", "at most 1 km (the laser sees 80 m)", lo_open=True)]
        | None
    ) = None
    bearing_offset: Annotated[float, _angle(-_ANGLE, _ANGLE, "an angle")] | None = None
    bearing_offset_deg: Annotated[float, _angle(-_ANGLE, _ANGLE, "an angle", deg=True)] | None = (
        None
    )
    clearance: Annotated[
        float, number(0, 1000, "cm", "the least gap between two robots' discs, at most 10 m")
    ] = DEFAULT_CLEARANCE
    slot: list[SlotTable] | None = Field(default=None, min_length=1)

    @model_validator(mode="after")
    def _slots_or_pattern(self) -> Any:
        pattern = (self.followers, self.separation, self.bearing_offset, self.bearing_offset_deg)
        if self.slot is not None:
            if any(v is not None for v in pattern) or (
                "layout" in self.model_fields_set and self.layout != "line"
            ):
                raise problem(
                    "give [[formation.slot]] or followers/separation/bearing_offset, not both"
                )
            return self
        for req in ("followers", "separation"):
            if getattr(self, req) is None:
                raise problem(f"{req}: missing (required)")
        return self


def _of(spec: type, **leaves: Leaf) -> Callable[[type[T]], type[T]]:
    """Class decorator: the world's table ``cls`` with a key for each field of the world's
    spec ``spec`` that has a range (`rtsim.world._check.spec`) or a leaf in ``leaves``, with
    the spec's one default and one range; an angle (a unit in rad) with its ``_deg`` twin."""

    def make(cls: type[T]) -> type[T]:
        keys: dict[str, Any] = {}
        for f in fields(spec):
            rng = f.metadata.get("range")
            leaf = leaves.get(f.name) or (ranged(rng) if rng is not None else None)
            if leaf is None:
                continue
            kind = str if rng is None else int if rng.integer else float
            ann: Any = Annotated[kind, leaf]
            keys[f.name] = (ann if f.default is not None else ann | None, f.default)
            if rng is not None and rng.unit.startswith("rad"):
                twin: Any = Annotated[float, ranged(rng, deg=True)]
                keys[f"{f.name}_deg"] = (twin | None, None)
        model: Any = create_model(
            cls.__name__, __base__=cls, __module__=cls.__module__, __doc__=cls.__doc__, **keys
        )
        return model

    return make


@_of(FollowerParams, motion_model=plugin(MOTION_MODELS))
class FollowerTable(_Angles):
    """``[follower]``: `rtsim.world.follower.FollowerParams`'s keys."""


@_of(SensingParams)
class SensingTable(_Angles):
    """``[sensing]``: the run's one r_H and `rtsim.world.config.SensingParams`'s keys."""

    #: the run's one r_H: the window's cost (Eq 1) and the bounds read it; it replaces the
    #: task set's ``[window] r_H`` (the manifest's ``r_H`` records both)
    r_H: Annotated[float, number(0, 1e4, "cm", "as window.r_H", lo_open=True)] = R_H_DEFAULT


@_of(EkfParams, backend=choice(EKF_BACKENDS))
class EkfTable(_Angles):
    """``[ekf]``: `rtsim.world.ekf.EkfParams`'s keys."""


_FRACTION = "a fraction of the desired separation"


class ThresholdsTable(_Angles):
    T_rho: Annotated[float, number(0, 10, "", _FRACTION, lo_open=True)] = DEFAULT_THRESHOLDS.T_rho
    T_eps: Annotated[float, number(0, 10, "", _FRACTION, lo_open=True)] = DEFAULT_THRESHOLDS.T_eps
    T_beta: (
        Annotated[float, _angle(0, math.pi, "a bearing error below 180°", lo_open=True)] | None
    ) = None
    T_beta_deg: (
        Annotated[float, _angle(0, math.pi, "a bearing error below 180°", deg=True, lo_open=True)]
        | None
    ) = None
    localization: Annotated[str, choice(LOCALIZATION_KINDS)] | None = None


class LocalizationTable(Table):
    """``[localization]``: where the Hough windows are centred, which lost followers are
    searched for."""

    centre: Annotated[str, choice(CENTRES)] = _DEFAULT["localization.centre"]
    search: Annotated[str, choice(SEARCHES)] = _DEFAULT["localization.search"]
    model: Annotated[str, plugin(LOCALIZATION_MODELS)] = _DEFAULT["localization.model"]


class AdjustConfig(Table):
    """``[adjust]``, the runtime object too: the keys every policy reads, each with its one
    default and range, and the policy's own keys, the table's other keys (its options model,
    `rtsim.control.policy.PolicyOptions`, checks them when the scenario is built).

    cap: the largest window w (ms; ``inf`` = none); floor: the lowest leader speed (cm/s);
    predictor: the prediction model of `rtsim.control.predict`; lower_bound: the window's
    lower bound, ``w_sch`` (the paper's Eq 7/11), ``w_rta`` (exact RTA), ``w_susp``
    (suspension-aware, Δt with the CPU idle), ``w_txn`` (offset-based: the window chain and
    the command task as one transaction) or ``w_edf`` (the EDF demand criterion; needs
    ``[scheduler] policy = "edf"``); policy: the adjustment policy
    (`rtsim.control.policy`); decide: when in its window the decision is taken, ``end``
    (after the radio round trip) or ``before-send``; paper_predictor: the policy ``adjust``
    runs on the paper's predictor (default) or on ``predictor`` (the other policies always
    use ``predictor``).
    """

    model_config = ConfigDict(strict=True, extra="allow", frozen=True, validate_default=False)

    cap: Annotated[float, number(0, _MS_MAX, "ms", "inf: no cap", lo_open=True, inf=True)] = (
        math.inf
    )
    floor: Annotated[float, number(0, 1000, "cm/s", "as leader.speed")] = 0.0
    predictor: Annotated[str, plugin(PREDICTORS)] = _DEFAULT["adjust.predictor"]
    lower_bound: Annotated[str, choice(LOWER_BOUNDS)] = AdjustOptions.lower_bound
    policy: Annotated[str, text(what="a policy name")] = _DEFAULT["adjust.policy"]
    decide: Annotated[str, choice(DECIDE)] = AdjustOptions.decide
    paper_predictor: bool = AdjustOptions.paper_predictor

    @property
    def params(self) -> dict[str, Any]:
        """The policy's own keys, in the file's order."""
        return dict(self.model_extra or {})


@_of(RadioParams)
class RadioTable(_Angles):
    """``[radio]``: the round trip's spread and the commands' loss probability."""


class WorldTable(Table):
    step_ms: Annotated[float, _spec(WorldConfig, "step_ms")] = WorldConfig.step_ms
    backend: Annotated[str, choice(WORLD_BACKENDS)] | None = None


class SchedulerTable(Table):
    policy: Annotated[str, text(what="a policy name")] = "fp"


class ScenarioFile(Table):
    """A scenario file."""

    name: Annotated[str, text()] | None = None
    description: Annotated[str, text(nonempty=False, what="a string")] = ""
    #: the model choices the file leaves unsaid (`PRESETS`)
    preset: Annotated[str, choice(tuple(PRESETS))] = "recommended"
    taskset: Annotated[str, text(what="a name or a path")] = "barrel_robots"
    duration: (
        Annotated[float, number(0, 1e6, "s", "up to 11.6 simulated days", lo_open=True)] | None
    ) = None
    #: ``"lap"``: run to the end of the lap, followers included (without a duration)
    until: Annotated[str, choice(UNTIL)] | None = None
    leader: LeaderTable
    formation: FormationTable
    follower: FollowerTable = Field(default_factory=FollowerTable)
    sensing: SensingTable = Field(default_factory=SensingTable)
    ekf: EkfTable = Field(default_factory=EkfTable)
    thresholds: ThresholdsTable = Field(default_factory=ThresholdsTable)
    adjust: AdjustConfig = Field(default_factory=AdjustConfig)
    world: WorldTable = Field(default_factory=WorldTable)
    localization: LocalizationTable = Field(default_factory=LocalizationTable)
    radio: RadioTable = Field(default_factory=RadioTable)
    assumptions: dict[str, Annotated[str, text(what="a non-empty string giving the reason")]] = (
        Field(default_factory=dict)
    )
    scheduler: SchedulerTable | None = None


# -------------------------------------------------------------------------- building
def parse_scenario(
    data: Mapping[str, Any],
    source: str = "<scenario>",
    base: Path | None = None,
    *,
    allow_code: bool | None = None,
) -> Scenario:
    """Validate a parsed TOML document and build the scenario; ``base`` resolves a relative
    task-set path. Every problem of the file is reported at once.

    A plug-in named ``module:Name`` (``[adjust] policy``, ``predictor``, ``[formation]
    model``, ``[scheduler] policy``, the task set's) is code: it loads only with
    ``allow_code=True`` or the user's opt-in (`rtsim.registry.reading_input`).
    """
    allow = file_allows_code(allow_code)
    with reading_input(allow):
        scenario = _parse_scenario(data, source, base)
    return replace(scenario, allow_code=True) if allow else scenario


def _parse_scenario(data: Mapping[str, Any], source: str, base: Path | None) -> Scenario:
    if (
        isinstance(data, Mapping)
        and isinstance(data.get("adjust"), Mapping)
        and "model" in data["adjust"]
    ):
        raise ScenarioError(
            f"{source}: adjust: unknown key 'model' (renamed; did you mean 'predictor'?)"
        )
    model = validate(ScenarioFile, _with_preset(data), source, ScenarioError)
    errors: list[str] = []
    scenario = _build_scenario(model, source, base, errors)
    raise_errors(
        [e if e.startswith(f"{source}: ") else f"{source}: {e}" for e in errors], ScenarioError
    )
    assert scenario is not None
    return scenario


def _with_preset(data: Mapping[str, Any]) -> Mapping[str, Any]:
    """``data`` with its ``preset``'s choices (`PRESETS`) where the file gives none;
    the recommended preset's are the model's defaults, so only another preset fills keys."""
    preset = data.get("preset") if isinstance(data, Mapping) else None
    if not isinstance(preset, str) or preset not in PRESETS or preset == "recommended":
        return data
    out = {k: dict(v) if isinstance(v, Mapping) else v for k, v in data.items()}
    for dotted, value in PRESETS[preset].items():
        table, key = dotted.split(".")
        if table == "formation" and key == "layout" and "slot" in out.get(table, {}):
            continue
        section = out.setdefault(table, {})
        if isinstance(section, dict):
            section.setdefault(key, value)
    return out


def _attempt(errors: list[str], where: str, make: Callable[[], T]) -> T | None:
    """``make()``, or None with its error (``<where>: <message>``) added to ``errors``."""
    try:
        return make()
    except (InputError, TypeError) as exc:
        errors.append(f"{where}: {exc}" if where else str(exc))
        return None


def _path(src: str, leader: LeaderTable) -> LeaderPath:
    st = leader.start
    start = (st.x, st.y, st.radians("heading", 0.0))
    if leader.path is not None:
        segs: list[Segment] = []
        for k, s in enumerate(leader.path):
            where = f"{src}: leader.path[{k + 1}]"
            seg: Segment
            if s.straight is not None:
                seg = _attempt_raise(where, partial(Straight, s.straight))
            else:
                assert s.turn is not None and s.radius is not None  # (the model's rule)
                seg = _attempt_raise(where, partial(Turn, s.turn, s.radius, s.radians("angle")))
            segs.append(seg)
        return _attempt_raise(f"{src}: leader.path", lambda: LeaderPath(segs, start))
    shape = leader.shape
    assert shape is not None
    return _attempt_raise(
        f"{src}: leader.shape",
        lambda: rounded_rectangle(
            shape.length, shape.width, shape.radius, direction=shape.direction, start=start
        ),
    )


def _attempt_raise(where: str, make: Callable[[], T]) -> T:
    try:
        return make()
    except (InputError, TypeError) as exc:
        raise ScenarioError(f"{where}: {exc}") from None


def _formation(f: FormationTable, r_F: float, path: LeaderPath) -> Formation:
    if f.slot is not None:
        rho = tuple(s.rho_d for s in f.slot)
        beta = tuple(s.radians("beta_d") for s in f.slot)
        return Formation(rho, beta, f.model, f.clearance)
    offset = f.radians("bearing_offset", math.radians(15))
    assert f.followers is not None and f.separation is not None  # (the model's rule)
    if f.layout == "fan":
        segs = path.segments
        outer = outer_side([g.curvature for g in segs], [g.length for g in segs])
        return fan(
            f.followers,
            f.separation,
            offset,
            r_F=r_F,
            outer=outer,
            model=f.model,
            clearance=f.clearance,
        )
    place = follower_model(f.model, "formation.model").place
    return replace(place(f.followers, f.separation, offset, r_F=r_F), clearance=f.clearance)


class _Parts(NamedTuple):
    """The world's parts a scenario file describes (None: that part has an error)."""

    path: LeaderPath | None
    follower: FollowerParams | None
    formation: Formation | None
    sensing: SensingParams | None
    ekf: EkfParams | None


def _parts(m: ScenarioFile, src: str, errors: list[str]) -> _Parts:
    path = _attempt(errors, "", lambda: _path(src, m.leader))
    follower = _attempt(errors, src, lambda: m.follower.build(FollowerParams))
    formation = None
    if follower is not None and path is not None:
        r_F = follower.radius
        formation = _attempt(errors, src, lambda: _formation(m.formation, r_F, path))
    sensing = _attempt(errors, src, lambda: m.sensing.build(SensingParams))
    ekf = _attempt(errors, src, lambda: m.ekf.build(EkfParams))
    return _Parts(path, follower, formation, sensing, ekf)


def _thresholds(m: ScenarioFile, src: str, parts: _Parts, errors: list[str]) -> Thresholds:
    """The bounds' thresholds, with the run's one r_H (``[sensing] r_H``) and the decision's
    localization bound: by default the one that matches the window's centre (Eq 19 for the
    previous position, the residual bound for the predicted one,
    `rtsim.world.locmodels.predicted_bound_ms`)."""
    th = m.thresholds
    centre = m.localization.centre
    loc = th.localization or ("predicted" if centre == "predicted" else "radial")
    predicted_ms: float | None = math.inf
    r_H = float(m.sensing.r_H)
    follower, formation, sensing, ekf = parts.follower, parts.formation, parts.sensing, parts.ekf
    if loc == "predicted" and None not in (follower, sensing, ekf, formation):
        assert follower and sensing and ekf and formation  # (for the type checker)
        rho_max = max(formation.rho_d, default=0.0)
        predicted_ms = _attempt(
            errors,
            src,
            lambda: predicted_bound_ms(m.localization.model, r_H, sensing, follower, ekf, rho_max),
        )
    if loc == "predicted" and centre != "predicted":
        errors.append(
            f"{src}: thresholds.localization: 'predicted' bounds what a predicted "
            f"window centre leaves; set [localization] centre = 'predicted' (it is "
            f"{centre!r})"
        )
    return Thresholds(
        r_H=r_H,
        T_rho=th.T_rho,
        T_eps=th.T_eps,
        T_beta=th.radians("T_beta", DEFAULT_THRESHOLDS.T_beta),
        localization=loc,  # type: ignore[arg-type]
        predicted_ms=math.inf if predicted_ms is None else predicted_ms,
    )


def _policy(m: ScenarioFile, src: str, errors: list[str]) -> Any:
    """The ``[adjust]`` policy, made once with its own keys, and the checks of ``[adjust]``
    against the scheduler and the leader's speed."""
    adjust = m.adjust
    common = tuple(AdjustConfig.model_fields)
    policy = _attempt(
        errors, src, lambda: make_policy(adjust.policy, adjust.params, "adjust", common)
    )
    scheduler = m.scheduler.policy if m.scheduler is not None else None
    if scheduler is not None:
        sched = None
        try:
            sched = SCHEDULERS.resolve(scheduler, f"{src}: scheduler.policy")
        except InputError as exc:
            errors.append(str(exc))
        # the scheduler's registry entry names the lower bounds that hold under it
        bound = adjust.lower_bound
        if sched is not None and sched.lower_bounds and bound not in sched.lower_bounds:
            need = [n for n, c in SCHEDULERS.items() if bound in c.lower_bounds]
            errors.append(
                f"{src}: adjust.lower_bound: {bound} assumes the {' or '.join(need)} "
                f"scheduler, but [scheduler] policy is {scheduler!r}"
            )
    speed = float(m.leader.speed)
    if adjust.floor > speed:
        errors.append(
            f"{src}: adjust.floor: {adjust.floor:g} cm/s is above the desired speed {speed:g} cm/s"
        )
    return policy


def _taskset_path(name: str, src: str, base: Path | None, errors: list[str]) -> str:
    """A packaged task set's name, or the path of the file ``name`` (relative to ``base``)."""
    if name in PACKAGED_TASKSETS:
        return name
    p = Path(name)
    if not p.is_absolute() and base is not None:
        p = base / p
    if not p.is_file():
        errors.append(f"{src}: taskset: file not found: {p}")
    return str(p)


def _world(
    m: ScenarioFile, src: str, parts: _Parts, thresholds: Thresholds, errors: list[str]
) -> WorldConfig | None:
    """The world, of its parts and thresholds."""
    path, follower, formation, sensing, ekf = parts
    if path is None or formation is None or follower is None or sensing is None or ekf is None:
        return None
    localization = LocalizationParams(
        centre=m.localization.centre, search=m.localization.search, model=m.localization.model
    )
    world = _attempt(
        errors,
        src,
        lambda: WorldConfig(
            path,
            float(m.leader.speed),
            formation,
            follower,
            sensing,
            ekf,
            thresholds,
            m.world.step_ms,
            float(m.leader.start_s),
            leader_accel_max=float(m.leader.accel_max),
            leader_decel_max=float(m.leader.decel_max),
            localization=localization,
            backend=m.world.backend,
            radio=m.radio.build(RadioParams),
        ),
    )
    return world


def _build_scenario(
    m: ScenarioFile, src: str, base: Path | None, errors: list[str]
) -> Scenario | None:
    parts = _parts(m, src, errors)
    thresholds = _thresholds(m, src, parts, errors)
    policy = _policy(m, src, errors)
    taskset = _taskset_path(m.taskset, src, base, errors)
    if policy is None:
        return None
    world = _world(m, src, parts, thresholds, errors)
    if world is None:
        return None
    errors += _sense(world, src)
    if not errors:
        errors += _fits_path(world, m.leader.start_on, src)
        if not errors:
            world = replace(
                world, start_s=_start(world, m.leader.start_on), start_on=m.leader.start_on
            )
    if errors:
        return None
    task_set = _attempt(errors, "", lambda: _read_taskset(taskset, src))
    if task_set is None:
        return None
    # a duration given anywhere replaces ``until``; neither given: to the end of the lap
    return Scenario(
        name=m.name if m.name is not None else Path(src).stem,
        world=world,
        taskset=taskset,
        duration=float(m.duration) if m.duration is not None else 0.0,
        until=None if m.duration is not None else (m.until or "lap"),
        description=m.description,
        adjust=m.adjust,
        assumptions=dict(m.assumptions),
        source=src,
        scheduler=m.scheduler.policy if m.scheduler is not None else None,
        task_set=task_set,
        made=(m.adjust, policy),
    )


def _start(world: WorldConfig, start_on: str) -> float:
    """The leader's initial arc length: ``leader.start_s``, moved forward onto the first
    straight that holds the whole group settled with ``start_on = "straight"``
    (`rtsim.world.ideal.settled_start`)."""
    if start_on == "given":
        return world.start_s
    return settled_start(world.path, world.formation, world.follower.radius, world.start_s)


def _fits_path(world: WorldConfig, start_on: str, src: str) -> list[str]:
    """A formation that cannot fit its path: the settled start has no straight long enough,
    or (follow-the-leader) two robots would come closer than 2·r_F + clearance over a lap
    without error, or an offset trace folds inside a turn
    (`rtsim.world.ideal.check_clearance`): one line each, before the run."""
    try:
        start = _start(world, start_on)
        if follower_model(world.formation.model).on_trace:
            check_clearance(world.path, world.formation, world.follower.radius, start)
    except ScenarioError as exc:
        return [f"{src}: {exc}"]
    return []


def _sense(world: WorldConfig, src: str) -> list[str]:
    """A scenario that would run but give nonsense: a leader starting beyond its path's length
    (its arc length would swamp each step: the leader stands still) and a leader faster than
    the followers can drive (they fall behind from the first window)."""
    out = []
    length = world.path.lap_length
    if world.start_s > length:
        out.append(
            f"{src}: leader.start_s: {world.start_s:g} cm is beyond the path's length "
            f"{length:g} cm (give a position within one lap)"
        )
    vmax = world.follower.max_speed
    if world.leader_speed > vmax:
        out.append(
            f"{src}: leader.speed: {world.leader_speed:g} cm/s is above "
            f"follower.max_speed {vmax:g} cm/s: the followers cannot keep up"
        )
    return out


# -------------------------------------------------------------------------- loading
def scenario_bytes(path: str | os.PathLike[str]) -> tuple[bytes, Path]:
    """The bytes of a scenario file, and its path.

    ``path`` is a file, or the name of a packaged scenario (``test1``, ``test2``: the paper's
    tests, shipped with rtsim as copies of ``experiments/scenarios/``) when no such file
    exists.
    """
    p = Path(path)
    if not p.exists() and str(path) in PACKAGED_SCENARIOS:
        res = packaged_data("scenarios", f"{path}.toml")
        return res.read_bytes(), Path(f"{path}.toml")
    try:
        return read_input(p, "scenario"), p
    except FileNotFoundError:
        raise ScenarioError(f"{p}: no such scenario file{shipped_hint(p, 'scenario')}") from None
    except OSError as exc:
        raise ScenarioError(f"{p}: cannot read scenario: {exc.strerror or exc}") from None


def load_scenario(
    path: str | os.PathLike[str],
    overrides: Mapping[str, Any] | None = None,
    *,
    allow_code: bool | None = None,
) -> Scenario:
    """Read and validate a scenario TOML file (or a packaged scenario by name, e.g. ``test1``).

    ``overrides``: dotted paths into the file and their new values, resolved as a sweep's
    (``{"leader.speed": 20, "formation.followers": 4}``; `rtsim.config.dotted`).
    ``allow_code``: as [`parse_scenario`][rtsim.config.scenario.parse_scenario].
    """
    raw, p = scenario_bytes(path)
    src = str(p)  # the full path in every message
    data = parse_toml(raw, src, ScenarioError)
    if overrides and any(k in overrides for k in _TOP_KEYS):
        # top-level keys a file may leave out; the run's end asked for replaces the file's
        overrides = dict(overrides)
        for key, other in _TOP_KEYS.items():
            if key in overrides:
                if other:
                    data.pop(other, None)
                data[key] = overrides.pop(key)
    return parse_scenario(
        with_overrides(data, overrides, src), src, p.parent, allow_code=allow_code
    )
