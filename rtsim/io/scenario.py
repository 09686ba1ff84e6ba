"""Robot scenario files (TOML): the world, the task set it runs on, and every assumption.

Shape (units as in docs/model/index.md: cm, cm/s, s for ``duration``, ms for ``world.step_ms`` and
``adjust.cap``; every angular key is radians, or degrees when written with ``_deg``)::

    name = "test1"
    description = "Paper's Test 1: smooth turns"
    taskset = "barrel_robots"          # the packaged set, or a file path relative to this file
    duration = 200                     # simulated s (default: one lap at V_Ld, rounded up)

    [leader]
    speed = 25                         # V_Ld (cm/s)
    start = {x = 0, y = 0, heading_deg = 0}
    start_s = 0                        # optional: initial arc length along the path (cm)
    accel_max = 30                     # optional: speed ramp up (cm/s^2; default inf = a step)
    decel_max = 30                     # optional: speed ramp down (cm/s^2; default inf)
    path = [ {straight = 600}, {turn = "left", radius = 200, angle_deg = 90}, ... ]
    # or instead of path:
    shape = {kind = "rounded_rectangle", length = 600, width = 400, radius = 200,
             direction = "left"}       # straights of length/width, four 90-degree turns

    [formation]
    model = "follow-the-leader"        # or "l-psi" (the default): how followers are controlled
    followers = 2                      # l-psi: the chevron, pairs at 180 ± offset widening
                                       # outward; follow-the-leader: the line (rank p at
                                       # p*separation, 180 ± offset tucked inward), the
                                       # place each follower holds on straights
    separation = 390                   # rho_d of the first pair (cm)
    bearing_offset_deg = 15
    layout = "line"                    # or "fan" (follow-the-leader): every follower at
                                       # rho_d, bearings fanned out (rtsim.world.formation)
    # or explicit slots instead of followers/separation/bearing_offset:
    # [[formation.slot]]
    # rho_d = 390
    # beta_d_deg = 195

    [follower]     radius, max_speed, max_accel, max_turn_rate(_deg), control_offset,
                   gain_rho, gain_beta, speed_noise, turn_noise(_deg), lookahead
    [sensing]      r_H, r_reacq, position_noise, min_points, max_range
    [ekf]          measurement_noise, speed_noise, turn_noise(_deg), position_drift,
                   heading_drift(_deg), init_position_sd, init_heading_sd(_deg), backend
    [thresholds]   T_rho, T_eps, T_beta(_deg), localization = "radial" | "full" | "predicted"
                   (default: "predicted" with [localization] centre = "predicted", else "radial")
    [adjust]       cap (ms, the largest window), floor (cm/s, the lowest leader speed),
                   predictor = "paper" | "formation" | "hybrid" | "commands"
                   (rtsim.control.predict), lower_bound = "w_sch" | "w_rta" | "w_susp",
                   decide = "end" | "before-send" (when in the window the decision is taken)
    [localization] centre = "previous" | "predicted", search = "always" | "visible"
                   (where the Hough windows are centred; which lost followers are searched for)
    [world]        step_ms (integration step while a speed ramps), backend ("python",
                   "compiled" or "filterpy"; default compiled where numba is installed)
    [assumptions]  key = "reason"      # every value the paper does not give

Every table but ``[leader]`` and ``[formation]`` is optional (defaults: the world's dataclasses).
Unknown keys are errors with a did-you-mean; every problem is one
:class:`~rtsim.errors.ScenarioError` line, ``<file>: <key>: <problem>``. The path must close.
Initial state: see :class:`rtsim.world.World` (followers on their slots in steady formation,
estimates = truth + N(0, init sd²)).
"""

from __future__ import annotations

import difflib
import math
import os
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, TypeVar

from rtsim.analysis.kinematics import (
    LOCALIZATION_KINDS,
    Thresholds,
    msb_localization_predicted,
)
from rtsim.errors import InputError, ScenarioError
from rtsim.model.taskset import TaskSet
from rtsim.world._check import non_negative, number, positive
from rtsim.world.config import LocalizationParams, SensingParams, WorldConfig
from rtsim.world.ekf import EkfParams
from rtsim.world.follower import FollowerParams
from rtsim.world.formation import (
    FORMATION_LAYOUTS,
    Formation,
    fan,
    follower_model,
    outer_side,
)
from rtsim.world.path import LeaderPath, Segment, Straight, Turn, rounded_rectangle

__all__ = ["AdjustConfig", "Scenario", "load_scenario", "parse_scenario", "scenario_bytes",
           "PACKAGED_SCENARIOS", "PACKAGED_TASKSETS"]

#: Task-set names that refer to the package's own files rather than to a path.
PACKAGED_TASKSETS = ("barrel_robots", "example")
#: Scenarios shipped with rtsim (the paper's Test 1 and Test 2), loadable by name.
PACKAGED_SCENARIOS = ("test1", "test2")

T = TypeVar("T")

TOP_KEYS = ("name", "description", "taskset", "duration", "leader", "formation", "follower",
            "sensing", "ekf", "thresholds", "adjust", "world", "assumptions", "scheduler",
            "localization")
_ANGLES: dict[str, tuple[str, ...]] = {
    "leader": (), "start": ("heading",), "segment": ("angle",),
    "formation": ("bearing_offset",), "slot": ("beta_d",),
    "follower": ("max_turn_rate", "turn_noise"), "sensing": (),
    "ekf": ("turn_noise", "heading_drift", "init_heading_sd"), "thresholds": ("T_beta",),
}


@dataclass(frozen=True)
class AdjustConfig:
    """Limits for the adjustment algorithm (semantics in :mod:`rtsim.control`).

    cap: the largest window w (ms; ``inf`` = none); floor: the lowest leader speed (cm/s);
    predictor: the prediction model of :mod:`rtsim.control.predict` (``paper``, ``formation``
    or ``hybrid``; the old key ``model`` and value ``estimate`` are errors naming their new
    names); lower_bound: the window's lower bound, ``w_sch`` (the paper's Eq 7/11),
    ``w_rta`` (exact RTA), ``w_susp`` (suspension-aware, Δt with the CPU idle) or ``w_edf``
    (the EDF demand criterion; needs ``[scheduler] policy = "edf"``); decide: when in its
    window the decision is taken, ``end`` (after the radio round trip) or ``before-send``.
    """

    cap: float = math.inf
    floor: float = 0.0
    predictor: str = "formation"
    lower_bound: str = "w_sch"
    policy: str = "adjust"
    decide: str = "end"
    params: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        from rtsim.analysis.bounds import LOWER_BOUNDS

        if self.lower_bound not in LOWER_BOUNDS:
            raise ScenarioError(f"adjust.lower_bound: must be one of {', '.join(LOWER_BOUNDS)}, "
                                f"got {self.lower_bound!r}")
        if self.decide not in ("end", "before-send"):
            raise ScenarioError(f"adjust.decide: must be one of end, before-send, got "
                                f"{self.decide!r}")
        from rtsim.control.predict import check_predictor

        object.__setattr__(self, "cap", positive("adjust.cap", self.cap, allow_inf=True))
        object.__setattr__(self, "floor", non_negative("adjust.floor", self.floor))
        from rtsim.control.policy import make_policy

        try:
            check_predictor(self.predictor, "adjust.predictor")
            make_policy(self.policy, self.params, "adjust",
                        ("cap", "floor", "predictor", "lower_bound", "policy", "decide"))
        except InputError as exc:
            raise ScenarioError(str(exc)) from None


@dataclass(frozen=True)
class Scenario:
    """A validated scenario: the world, the task set reference, duration and assumptions.

    ``scheduler``: the leader CPU's scheduling policy from ``[scheduler] policy`` (None: the
    task set's, ``fp`` unless its file says otherwise)."""

    name: str
    world: WorldConfig
    taskset: str = "barrel_robots"
    duration: float = 0.0
    description: str = ""
    adjust: AdjustConfig = field(default_factory=AdjustConfig)
    assumptions: Mapping[str, str] = field(default_factory=dict)
    source: str | None = None
    scheduler: str | None = None
    #: the file may name code (``module:Name``), also in its task set (the user opted in)
    allow_code: bool = field(default=False, compare=False)

    @property
    def n(self) -> int:
        return self.world.n

    def load_taskset(self) -> TaskSet:
        """The task set, with its window's n and r_H set to the scenario's (followers, r_H)."""
        from rtsim.io.taskset import load_taskset

        where = self.source or "<scenario>"
        # a packaged set by its own name ("example" is the generic set, not the paper's)
        ts = load_taskset(None if self.taskset == "barrel_robots" else self.taskset,
                          allow_code=self.allow_code)
        if ts.window is None:
            raise ScenarioError(f"{where}: taskset: '{self.taskset}' has no [window]")
        ts = ts.with_window(n=self.n, r_H=self.world.thresholds.r_H)
        if self.scheduler is not None and self.scheduler != ts.scheduler:
            from dataclasses import replace as _replace

            ts = _replace(ts, scheduler=self.scheduler)
        return ts


# --------------------------------------------------------------------------- parsing


class _Table:
    """A TOML table being consumed: values by key (angles: ``key`` rad or ``key_deg``)."""

    def __init__(self, where: str, data: object, angles: tuple[str, ...] = ()) -> None:
        if not isinstance(data, dict):
            raise ScenarioError(f"{where}: must be a table, got {data!r}")
        self.where = where
        self.data = data
        self.angles = angles
        self.used: set[str] = set()

    def has(self, key: str) -> bool:
        return key in self.data or f"{key}_deg" in self.data

    def get(self, key: str, default: Any = None) -> Any:
        """Raw value of ``key`` (degrees converted for angular keys), or ``default``."""
        deg = f"{key}_deg"
        if key in self.angles and deg in self.data:
            if key in self.data:
                raise ScenarioError(f"{self.where}: give {key} or {deg}, not both")
            self.used.add(deg)
            value = self.data[deg]
            number(f"{self.where}.{deg}", value)
            return math.radians(float(value))
        if key in self.data:
            self.used.add(key)
            return self.data[key]
        return default

    def kwargs(self, keys: tuple[str, ...]) -> dict[str, Any]:
        return {k: self.get(k) for k in keys if self.has(k)}

    def finish(self, allowed: tuple[str, ...]) -> None:
        """Raise for the first key not consumed, with the closest allowed key."""
        names = tuple(allowed) + tuple(f"{a}_deg" for a in allowed if a in self.angles)
        for key in self.data:
            if key not in self.used:
                close = difflib.get_close_matches(key, names, n=1, cutoff=0.6)
                hint = (f" (did you mean '{close[0]}'?)" if close
                        else f" (known keys: {', '.join(names)})")
                raise ScenarioError(f"{self.where}: unknown key '{key}'{hint}")


def _build(where: str, make: Callable[[], T]) -> T:
    """Run a constructor; turn its validation error into ``<where>: <message>``."""
    try:
        return make()
    except InputError as exc:
        raise ScenarioError(f"{where}: {exc}") from None
    except TypeError as exc:
        raise ScenarioError(f"{where}: {exc}") from None


def _segment(where: str, raw: object) -> Segment:
    tab = _Table(where, raw, _ANGLES["segment"])
    if tab.has("straight") and tab.has("turn"):
        raise ScenarioError(f"{where}: a segment is either straight or turn, not both")
    if tab.has("straight"):
        length = tab.get("straight")
        tab.finish(("straight",))
        return _build(where, lambda: Straight(length))
    if tab.has("turn"):
        direction = tab.get("turn")
        for req in ("radius", "angle"):
            if not tab.has(req):
                raise ScenarioError(f"{where}: {req}: missing (required for a turn)")
        radius, angle = tab.get("radius"), tab.get("angle")
        tab.finish(("turn", "radius", "angle"))
        return _build(where, lambda: Turn(direction, radius, angle))
    raise ScenarioError(
        f"{where}: a segment needs 'straight = <cm>' or 'turn = \"left\"|\"right\"'")


def _path(src: str, leader: _Table) -> LeaderPath:
    start_tab = _Table(f"{src}: leader.start", leader.get("start", {}), _ANGLES["start"])
    start = (start_tab.get("x", 0.0), start_tab.get("y", 0.0), start_tab.get("heading", 0.0))
    start_tab.finish(("x", "y", "heading"))
    if leader.has("path") == leader.has("shape"):
        raise ScenarioError(f"{src}: leader: give exactly one of 'path' or 'shape'")
    if leader.has("path"):
        raw = leader.get("path")
        if not isinstance(raw, list) or not raw:
            raise ScenarioError(f"{src}: leader.path: must be a non-empty list of segments")
        segs = [_segment(f"{src}: leader.path[{k + 1}]", r) for k, r in enumerate(raw)]
        return _build(f"{src}: leader.path", lambda: LeaderPath(segs, start))
    shape = _Table(f"{src}: leader.shape", leader.get("shape"))
    kind = shape.get("kind")
    if kind != "rounded_rectangle":
        raise ScenarioError(f"{src}: leader.shape.kind: must be 'rounded_rectangle', got {kind!r}")
    for req in ("length", "width", "radius"):
        if not shape.has(req):
            raise ScenarioError(f"{src}: leader.shape.{req}: missing (required)")
    args = shape.kwargs(("length", "width", "radius"))
    direction = shape.get("direction", "left")
    shape.finish(("kind", "length", "width", "radius", "direction"))
    return _build(f"{src}: leader.shape",
                  lambda: rounded_rectangle(**args, direction=direction, start=start))


def _formation(src: str, data: object, r_F: float, path: LeaderPath) -> Formation:
    tab = _Table(f"{src}: formation", data, _ANGLES["formation"])
    model = tab.get("model", "l-psi")
    follower = follower_model(model, f"{src}: formation.model")
    if tab.has("slot"):
        if tab.has("followers") or tab.has("separation") or tab.has("bearing_offset"):
            raise ScenarioError(f"{src}: formation: give [[formation.slot]] or "
                                "followers/separation/bearing_offset, not both")
        slots = tab.get("slot")
        if not isinstance(slots, list) or not slots:
            raise ScenarioError(f"{src}: formation.slot: must be a list of tables")
        rho, beta = [], []
        for k, raw in enumerate(slots):
            st = _Table(f"{src}: formation.slot[{k + 1}]", raw, _ANGLES["slot"])
            for req in ("rho_d", "beta_d"):
                if not st.has(req):
                    raise ScenarioError(f"{st.where}: {req}: missing (required)")
            rho.append(st.get("rho_d"))
            beta.append(st.get("beta_d"))
            st.finish(("rho_d", "beta_d"))
        tab.finish(("slot", "model"))
        return _build(src, lambda: Formation(tuple(rho), tuple(beta), model))
    for req in ("followers", "separation"):
        if not tab.has(req):
            raise ScenarioError(f"{src}: formation.{req}: missing (required)")
    args = tab.kwargs(("followers", "separation", "bearing_offset"))
    layout = tab.get("layout", "line")
    tab.finish(("followers", "separation", "bearing_offset", "model", "layout"))
    if layout not in FORMATION_LAYOUTS:
        raise ScenarioError(f"{src}: formation.layout: must be one of "
                            f"{', '.join(FORMATION_LAYOUTS)}, got {layout!r}")
    offset = args.get("bearing_offset", math.radians(15))
    if layout == "fan":
        segs = path.segments
        outer = outer_side([g.curvature for g in segs], [g.length for g in segs])
        return _build(src, lambda: fan(args["followers"], args["separation"], offset, r_F=r_F,
                                       outer=outer, model=model))
    place = follower.place
    return _build(src, lambda: place(args["followers"], args["separation"], offset, r_F=r_F))


def _section(src: str, data: Mapping[str, Any], name: str, keys: tuple[str, ...],
             make: Callable[..., T]) -> T:
    tab = _Table(f"{src}: {name}", data.get(name, {}), _ANGLES.get(name, ()))
    args = tab.kwargs(keys)
    tab.finish(keys)
    return _build(src, lambda: make(**args))


_ADJUST_KEYS = ("cap", "floor", "predictor", "lower_bound", "policy", "decide")


def _adjust_section(src: str, data: Mapping[str, Any]) -> AdjustConfig:
    """``[adjust]``: the common keys, and the selected policy's own keys
    (:mod:`rtsim.control.policy`; validated there, with a did-you-mean)."""
    raw = data.get("adjust", {})
    tab = _Table(f"{src}: adjust", raw, ())
    args = tab.kwargs(_ADJUST_KEYS)
    if isinstance(raw, Mapping):
        args["params"] = {k: v for k, v in raw.items() if k not in _ADJUST_KEYS}
    return _build(src, lambda: AdjustConfig(**args))


def parse_scenario(data: Mapping[str, Any], source: str = "<scenario>",
                   base: Path | None = None, *, allow_code: bool | None = None) -> Scenario:
    """Validate a parsed TOML document; ``base`` resolves a relative task-set path.

    Every number is then checked against its range (:mod:`rtsim.io.limits`), and the
    combinations that would run but mean nothing are refused (:func:`_sense`). A policy named
    ``module:Name`` (``[adjust] policy``, ``[scheduler] policy``, the task set's) is code: it
    loads only with ``allow_code=True`` (:func:`rtsim.registry.reading_input`).
    """
    from rtsim.io import limits
    from rtsim.registry import file_allows_code, reading_input

    allow = file_allows_code(allow_code)
    with reading_input(allow):
        scenario = limits.parse_checked("scenario",
                                        lambda: _parse_scenario(data, source, base), data,
                                        source)
        if allow:
            scenario = replace(scenario, allow_code=True)
        _sense(scenario, source)
    return scenario


def _sense(sc: Scenario, src: str) -> None:
    """Refuse a scenario that would run but give nonsense: a leader starting beyond its
    path's length (its arc length would swamp each step: the leader stands still) and a
    leader faster than the followers can drive (they fall behind from the first window)."""
    world = sc.world
    length = world.path.lap_length
    if world.start_s > length:
        raise ScenarioError(f"{src}: leader.start_s: {world.start_s:g} cm is beyond the path's "
                            f"length {length:g} cm (give a position within one lap)")
    vmax = world.follower.max_speed
    if world.leader_speed > vmax:
        raise ScenarioError(f"{src}: leader.speed: {world.leader_speed:g} cm/s is above "
                            f"follower.max_speed {vmax:g} cm/s: the followers cannot keep up")


def _predicted_bound(src: str, r_H: float, follower: FollowerParams, sensing: SensingParams,
                     ekf: EkfParams) -> float:
    """The decision's localization bound for a window centred at the predicted position
    (:func:`rtsim.analysis.kinematics.msb_localization_predicted`, docs/localization.md):
    the fix noise, the EKF's initial heading error, the actuation noise, at the followers'
    top speed, 3 standard deviations; the leader knows its own motion (no error)."""
    if not math.isfinite(follower.max_speed):
        raise ScenarioError(f"{src}: thresholds.localization: 'predicted' needs a finite "
                            f"follower.max_speed (the bound carries the heading error at it)")
    return msb_localization_predicted(
        r_H, fix_sd=sensing.position_noise, heading_sd=ekf.init_heading_sd,
        speed_sd=follower.speed_noise, turn_sd=follower.turn_noise, v_max=follower.max_speed)


def _parse_scenario(data: Mapping[str, Any], source: str,
                    base: Path | None) -> Scenario:
    src = source
    top = _Table(src, dict(data))
    for key in ("leader", "formation"):
        if not top.has(key):
            raise ScenarioError(f"{src}: [{key}]: missing (required)")
    name = top.get("name", Path(source).stem)
    if not isinstance(name, str) or not name:
        raise ScenarioError(f"{src}: name: must be a non-empty string, got {name!r}")
    description = top.get("description", "")
    if not isinstance(description, str):
        raise ScenarioError(f"{src}: description: must be a string, got {description!r}")

    leader = _Table(f"{src}: leader", top.get("leader"))
    if not leader.has("speed"):
        raise ScenarioError(f"{src}: leader.speed: missing (required)")
    speed = _build(src, lambda: positive("leader.speed", leader.get("speed")))
    path = _path(src, leader)
    start_s = _build(src, lambda: non_negative("leader.start_s", leader.get("start_s", 0.0)))
    ramps = {f"leader_{key}": _build(src, lambda key=key: positive(
        f"leader.{key}", leader.get(key, math.inf), allow_inf=True))
        for key in ("accel_max", "decel_max")}
    leader.finish(("speed", "start", "start_s", "accel_max", "decel_max", "path", "shape"))

    follower = _section(src, data, "follower", tuple(FollowerParams.__dataclass_fields__),
                        FollowerParams)
    formation = _formation(src, top.get("formation"), follower.radius, path)
    top.get("follower")
    sens = _Table(f"{src}: sensing", top.get("sensing", {}))
    r_H = _build(src, lambda: positive("sensing.r_H", sens.get("r_H", 25.0)))
    sens_args = sens.kwargs(tuple(SensingParams.__dataclass_fields__))
    sens.finish(("r_H",) + tuple(SensingParams.__dataclass_fields__))
    sensing = _build(src, lambda: SensingParams(**sens_args))
    ekf = _section(src, data, "ekf", tuple(EkfParams.__dataclass_fields__), EkfParams)
    top.get("ekf")

    thr = _Table(f"{src}: thresholds", top.get("thresholds", {}), _ANGLES["thresholds"])
    t_rho = thr.get("T_rho", 0.01)
    t_eps = thr.get("T_eps", 0.025)
    t_beta = thr.get("T_beta", math.radians(5.0))
    # the decision's localization bound: by default the one that matches the window's
    # centre (Eq 19 for the previous position, the residual bound for the predicted one)
    centre = data.get("localization", {}).get("centre", "previous") \
        if isinstance(data.get("localization"), Mapping) else "previous"
    loc = thr.get("localization", "predicted" if centre == "predicted" else "radial")
    thr.finish(("T_rho", "T_eps", "T_beta", "localization"))
    for key, val in (("T_rho", t_rho), ("T_eps", t_eps), ("T_beta", t_beta)):
        _build(src, lambda k=key, v=val: positive(f"thresholds.{k}", v))
    if loc not in LOCALIZATION_KINDS:
        raise ScenarioError(f"{src}: thresholds.localization: must be one of "
                            f"{', '.join(repr(k) for k in LOCALIZATION_KINDS)}, got {loc!r}")
    predicted_ms = math.inf
    if loc == "predicted":
        predicted_ms = _predicted_bound(src, r_H, follower, sensing, ekf)
    thresholds = Thresholds(r_H=r_H, T_rho=t_rho, T_eps=t_eps, T_beta=t_beta, localization=loc,
                            predicted_ms=predicted_ms)

    if isinstance(data.get("adjust"), Mapping) and "model" in data["adjust"]:
        raise ScenarioError(f"{src}: adjust: unknown key 'model' (renamed; did you mean "
                            f"'predictor'?)")
    adjust = _adjust_section(src, data)
    top.get("adjust")
    scheduler = _scheduler(src, top.get("scheduler"))
    if scheduler is not None:
        from rtsim.sim.policy import SCHEDULERS

        policy = SCHEDULERS.get(scheduler)  # its registry entry names the bounds that hold
        if policy is not None and policy.lower_bounds \
                and adjust.lower_bound not in policy.lower_bounds:
            need = [n for n, c in SCHEDULERS.items() if adjust.lower_bound in c.lower_bounds]
            raise ScenarioError(f"{src}: adjust.lower_bound: {adjust.lower_bound} assumes the "
                                f"{' or '.join(need)} scheduler, but [scheduler] policy is "
                                f"{scheduler!r}")
    wtab = _Table(f"{src}: world", top.get("world", {}))
    step_ms = wtab.get("step_ms", 10.0)
    backend = wtab.get("backend", None)
    wtab.finish(("step_ms", "backend"))

    localization = _section(src, data, "localization",
                            tuple(LocalizationParams.__dataclass_fields__), LocalizationParams)
    top.get("localization")
    if loc == "predicted" and localization.centre != "predicted":
        raise ScenarioError(f"{src}: thresholds.localization: 'predicted' bounds what a "
                            f"predicted window centre leaves; set [localization] centre = "
                            f"'predicted' (it is {localization.centre!r})")
    world = _build(src, lambda: WorldConfig(path, speed, formation, follower, sensing, ekf,
                                            thresholds, step_ms, start_s, **ramps,
                                            localization=localization, backend=backend))
    if adjust.floor > speed:
        raise ScenarioError(f"{src}: adjust.floor: {adjust.floor:g} cm/s is above the "
                            f"desired speed {speed:g} cm/s")

    lap = path.lap_time(speed)
    duration = top.get("duration", float(math.ceil(lap)))
    duration = _build(src, lambda: positive("duration", duration))

    taskset = top.get("taskset", "barrel_robots")
    if not isinstance(taskset, str) or not taskset:
        raise ScenarioError(f"{src}: taskset: must be a name or a path, got {taskset!r}")
    if taskset not in PACKAGED_TASKSETS:
        p = Path(taskset)
        if not p.is_absolute() and base is not None:
            p = base / p
        if not p.is_file():
            raise ScenarioError(f"{src}: taskset: file not found: {p}")
        taskset = str(p)

    assumptions_raw = top.get("assumptions", {})
    if not isinstance(assumptions_raw, dict):
        raise ScenarioError(f"{src}: [assumptions]: must be a table of key = \"reason\"")
    assumptions: dict[str, str] = {}
    for key, reason in assumptions_raw.items():
        if not isinstance(reason, str) or not reason.strip():
            raise ScenarioError(f"{src}: assumptions.{key}: must be a non-empty string "
                                f"giving the reason, got {reason!r}")
        assumptions[key] = reason
    top.finish(TOP_KEYS)
    return Scenario(name=name, world=world, taskset=taskset, duration=duration,
                    description=description, adjust=adjust, assumptions=assumptions,
                    source=source, scheduler=scheduler)


def _scheduler(src: str, table: object) -> str | None:
    """``[scheduler] policy`` (None when the scenario has no [scheduler] table)."""
    if table is None:
        return None
    from rtsim.errors import InputError
    from rtsim.sim.policy import resolve_policy

    tab = _Table(f"{src}: scheduler", table)
    policy = tab.get("policy", "fp")
    tab.finish(("policy",))
    if not isinstance(policy, str) or not policy:
        raise ScenarioError(f"{src}: scheduler.policy: must be a policy name, got {policy!r}")
    try:
        resolve_policy(policy, where=f"{src}: scheduler.policy")
    except InputError as exc:
        raise ScenarioError(str(exc)) from None
    return policy


def scenario_bytes(path: str | os.PathLike[str]) -> tuple[bytes, Path]:
    """The bytes of a scenario file, and its path.

    ``path`` is a file, or the name of a packaged scenario (``test1``, ``test2``: the paper's
    tests, shipped with rtsim as copies of ``experiments/scenarios/``) when no such file
    exists.
    """
    p = Path(path)
    if not p.exists() and str(path) in PACKAGED_SCENARIOS:
        from importlib import resources

        res = resources.files("rtsim") / "data" / "scenarios" / f"{path}.toml"
        return res.read_bytes(), Path(f"{path}.toml")
    from rtsim.io.limits import read_input

    try:
        return read_input(p, "scenario"), p
    except OSError as exc:
        raise ScenarioError(f"{p}: cannot read scenario: {exc.strerror or exc}") from None


def load_scenario(path: str | os.PathLike[str],
                  overrides: Mapping[str, Any] | None = None, *,
                  allow_code: bool | None = None) -> Scenario:
    """Read and validate a scenario TOML file (or a packaged scenario by name, e.g. ``test1``).

    ``overrides``: dotted paths into the file and their new values, resolved and checked as a
    sweep's (``{"leader.speed": 20, "formation.followers": 4}``; :mod:`rtsim.overrides`).
    ``allow_code``: as :func:`parse_scenario`.
    """
    raw, p = scenario_bytes(path)
    src = str(p)  # the full path in every message
    try:
        data = tomllib.loads(raw.decode("utf-8"))
        if overrides:
            from rtsim.overrides import apply_dotted_overrides

            apply_dotted_overrides(data, overrides, src)
        return parse_scenario(data, src, p.parent, allow_code=allow_code)
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{src}: not a text file (not UTF-8 at byte {exc.start})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{src}: malformed TOML: {exc}") from None
    except RecursionError:
        raise ScenarioError(f"{src}: nested too deeply to read (tables or arrays within each "
                            f"other hundreds of levels deep)") from None
