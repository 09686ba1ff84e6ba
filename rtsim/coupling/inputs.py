"""What a coupled run needs, prepared once: the world, the task set, the run options and the
resolved values recorded in the manifest (docs/scenarios.md)."""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from rtsim.config.scenario import load_scenario, scenario_bytes
from rtsim.config.taskset import taskset_to_dict
from rtsim.errors import InputError
from rtsim.io.atomic import inf_as_null
from rtsim.model.taskset import TaskSet
from rtsim.world.config import WorldConfig

__all__ = ["ScenarioInputs", "resolved", "scenario_inputs"]


@dataclass(frozen=True)
class ScenarioInputs:
    """What a coupled run needs: the world, the leader's task set, and run options.

    ``adjust``: options of [`rtsim.control.decide`][rtsim.control.decide] (``cap`` in ms or
    ``cap_factor``
    × w_sch, ``floor_frac``, ``floor_w``, ``predictor``, ``methods``, ``scan_points``,
    ``lower_bound``), ``policy`` and the policy's own keys; validated by
    `rtsim.control.policy.adjust_options`.
    ``duration_s``: default duration (simulated s), None = one lap. ``text``/``resolved``:
    the scenario file's text and resolved values, for the manifest.
    """

    world: WorldConfig
    taskset: TaskSet
    name: str = ""
    duration_s: float | None = None
    adjust: Mapping[str, Any] = field(default_factory=dict)
    source: str | None = None
    text: str | None = None
    resolved: Mapping[str, Any] = field(default_factory=dict)


def scenario_inputs(
    scenario: Any,
    text: str | None = None,
    overrides: Mapping[str, Any] | None = None,
    allow_code: bool | None = None,
) -> ScenarioInputs:
    """What [`run_scenario`][rtsim.coupling.run_scenario] runs, prepared once (the world, the task
    set loaded, the
    resolved values): a caller that runs the same scenario many times (a sweep's worker)
    can keep it and pass it back. Accept [`ScenarioInputs`][rtsim.coupling.inputs.ScenarioInputs], a
    path (loaded with
    [`rtsim.config.scenario.load_scenario`][rtsim.config.scenario.load_scenario]), or a
    [`rtsim.config.scenario.Scenario`][rtsim.config.scenario.Scenario].

    A Scenario's ``[adjust]`` maps to [`rtsim.control.decide`][rtsim.control.decide]: ``cap`` (ms;
    ``inf`` →
    decide's default, 10·w_sch) and ``floor`` (cm/s) → ``floor_frac`` = floor / V_Ld, which
    is also the lowest speed the coupling ever sets; ``predictor`` (when not the default
    ``formation``) → ``predictor``. The leader's current actual speed is passed to every
    decision as ``v_now`` (the ``hybrid`` model needs it).
    """
    if overrides and not isinstance(scenario, str | os.PathLike):
        raise InputError("overrides need a scenario file or a packaged scenario's name")
    if isinstance(scenario, ScenarioInputs):
        return scenario
    if isinstance(scenario, str | os.PathLike):
        path = scenario
        # a file, or a packaged scenario by name ("test2")
        scenario = load_scenario(path, overrides=overrides, allow_code=allow_code)
        if text is None:
            text = scenario_bytes(path)[0].decode("utf-8")
    try:
        world = scenario.world
        ts = scenario.load_taskset() if hasattr(scenario, "load_taskset") else scenario.taskset
    except AttributeError:
        raise InputError(f"not a scenario: {type(scenario).__name__}") from None
    adjust: dict[str, Any] = {}
    cfg = getattr(scenario, "adjust", None)
    if cfg is not None and not isinstance(cfg, Mapping):
        if math.isfinite(cfg.cap):
            adjust["cap"] = float(cfg.cap)
        adjust["floor_frac"] = float(cfg.floor) / world.leader_speed
        if getattr(cfg, "predictor", "formation") != "formation":
            adjust["predictor"] = cfg.predictor
        if getattr(cfg, "lower_bound", "w_sch") != "w_sch":
            adjust["lower_bound"] = cfg.lower_bound
        if getattr(cfg, "policy", "adjust") != "adjust":
            adjust["policy"] = cfg.policy
        if getattr(cfg, "decide", "end") != "end":
            adjust["decide"] = cfg.decide
        if not getattr(cfg, "paper_predictor", True):
            adjust["paper_predictor"] = False
        adjust.update(getattr(cfg, "params", {}))
    elif cfg:
        adjust = dict(cfg)
    duration = getattr(scenario, "duration", None)
    return ScenarioInputs(
        world=world,
        taskset=ts,
        name=str(getattr(scenario, "name", "") or ""),
        duration_s=float(duration) if duration else None,
        adjust=adjust,
        source=getattr(scenario, "source", None),
        text=text,
        resolved=resolved(scenario, ts),
    )


_inputs = scenario_inputs


def resolved(scenario: Any, ts: TaskSet) -> dict[str, Any]:
    """The scenario's resolved values as plain JSON data (for the manifest); a limit that is
    not set (``inf``: follower.max_turn_rate, sensing.max_range, adjust.cap) is null."""
    from dataclasses import asdict, is_dataclass

    cfg: WorldConfig = scenario.world

    def plain(obj: Any) -> Any:
        return asdict(obj) if is_dataclass(obj) and not isinstance(obj, type) else obj

    path = cfg.path
    out: dict[str, Any] = {
        "name": getattr(scenario, "name", ""),
        "description": getattr(scenario, "description", ""),
        "duration_s": getattr(scenario, "duration", None),
        "leader": {
            "speed": cfg.leader_speed,
            "start_s": cfg.start_s,
            "accel_max": cfg.leader_accel_max,
            "decel_max": cfg.leader_decel_max,
            "start": list(path.start),
            "lap_length": path.lap_length,
            "lap_time_s": path.lap_time(cfg.leader_speed),
            "segments": [{"kind": s.kind, **plain(s)} for s in path.segments],
        },
        "formation": {
            "model": cfg.formation.model,
            "rho_d": list(cfg.formation.rho_d),
            "beta_d": list(cfg.formation.beta_d),
        },
        "follower": plain(cfg.follower),
        "sensing": plain(cfg.sensing),
        "ekf": plain(cfg.ekf),
        "thresholds": plain(cfg.thresholds),
        "localization": plain(cfg.localization),
        "radio": plain(cfg.radio),
        "step_ms": cfg.step_ms,
        "adjust": plain(getattr(scenario, "adjust", {})),
        "assumptions": dict(getattr(scenario, "assumptions", {}) or {}),
        "taskset": taskset_to_dict(ts),
    }

    return inf_as_null(out)
