"""What a coupled run needs, prepared once: the world, the task set, the run options and the
resolved values recorded in the manifest (docs/scenarios.md)."""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, is_dataclass
from typing import Any

from rtsim.config.scenario import AdjustConfig, fit_taskset
from rtsim.config.taskset import taskset_to_dict
from rtsim.control.policy import AdjustOptions
from rtsim.errors import InputError
from rtsim.io.atomic import inf_as_null
from rtsim.model.taskset import TaskSet
from rtsim.world.config import WorldConfig

__all__ = ["ScenarioInputs", "fitted_taskset", "resolved", "scenario_inputs"]


@dataclass(frozen=True)
class ScenarioInputs:
    """What a coupled run needs: the world, the leader's task set, and run options.

    ``adjust``: the run's ``[adjust]``, an `rtsim.control.policy.AdjustOptions` (a
    scenario's, validated when it was read), or a mapping of its keys for inputs made by
    hand (``cap`` in ms or ``cap_factor`` × w_sch, ``floor_frac``, ``floor_w``,
    ``predictor``, ``methods``, ``scan_points``, ``lower_bound``, ``decide``,
    ``paper_predictor``, ``policy`` and the policy's own keys), validated once by
    `rtsim.control.policy.adjust_options` when the run starts.
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

    A Scenario's ``[adjust]`` becomes the run's `AdjustOptions` (`adjust_of`): ``cap`` (ms;
    ``inf`` → the decision's default, 10·w_sch) and ``floor`` (cm/s) → ``floor_frac`` =
    floor / V_Ld, which is also the lowest speed the coupling ever sets. The leader's
    current actual speed is passed to every decision as ``v_now`` (the ``hybrid`` model
    needs it).
    """
    if overrides and not isinstance(scenario, str | os.PathLike):
        raise InputError("overrides need a scenario file or a packaged scenario's name")
    if isinstance(scenario, ScenarioInputs):
        return scenario
    if isinstance(scenario, str | os.PathLike):
        # a file, or a packaged scenario by name ("test2"): prepared once per content
        from rtsim.coupling.prepared import prepared

        return prepared(scenario, text, overrides, allow_code, scenario_inputs)  # type: ignore[no-any-return]
    try:
        world = scenario.world
        ts = scenario.load_taskset() if hasattr(scenario, "load_taskset") else scenario.taskset
    except AttributeError:
        raise InputError(f"not a scenario: {type(scenario).__name__}") from None
    cfg = getattr(scenario, "adjust", None)
    adjust: Mapping[str, Any] = (
        adjust_of(cfg, world.leader_speed, scenario.policy())
        if isinstance(cfg, AdjustConfig)
        else dict(cfg or {})
    )
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


def adjust_of(cfg: AdjustConfig, v_ld: float, policy: Any) -> AdjustOptions:
    """A scenario's ``[adjust]`` as the run's options, with ``policy`` the instance made from
    it (`rtsim.config.scenario.Scenario.policy`)."""
    return AdjustOptions(
        policy,
        cap=float(cfg.cap) if math.isfinite(cfg.cap) else None,
        floor_frac=float(cfg.floor) / v_ld,
        predictor=cfg.predictor,
        lower_bound=cfg.lower_bound,
        decide=cfg.decide,
        paper_predictor=cfg.paper_predictor,
        own=cfg.params,
    )


def fitted_taskset(ts: TaskSet, world: WorldConfig, where: str) -> TaskSet:
    """A run's task set: ``ts``, which must have a ``[window]``, sized by the world
    (`rtsim.config.scenario.fit_taskset`: its n and r_H, the one home of each)."""
    if ts.window is None:
        raise InputError(f"{where}: the task set has no [window]")
    return fit_taskset(ts, world)


def r_h_record(scenario: Any, ts: TaskSet) -> dict[str, Any]:
    """The manifest's record of the run's one r_H (cm): ``value``, the scenario's
    ``[sensing] r_H`` that the window's cost and the bounds read; ``taskset``, the task
    set's own ``[window] r_H`` (what it serves analysed alone); ``replaced``: whether the
    two differ (the scenario's replaced the set's)."""
    value = float(scenario.world.thresholds.r_H)
    own = getattr(scenario, "task_set", None)
    win = own.window if own is not None and own.window is not None else ts.window
    mine = None if win is None else float(win.r_H)
    return {"value": value, "from": "sensing.r_H", "taskset": mine, "replaced": mine != value}


def resolved(scenario: Any, ts: TaskSet) -> dict[str, Any]:
    """The scenario's resolved values as plain JSON data (for the manifest); a limit that is
    not set (``inf``: follower.max_turn_rate, sensing.max_range, adjust.cap) is null."""

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
        "r_H": r_h_record(scenario, ts),
        "step_ms": cfg.step_ms,
        "adjust": _adjust_record(getattr(scenario, "adjust", None)),
        "assumptions": dict(getattr(scenario, "assumptions", {}) or {}),
        "taskset": taskset_to_dict(ts),
    }
    return inf_as_null(out)


def _adjust_record(cfg: Any) -> dict[str, Any]:
    """The manifest's ``adjust``: the common keys, then the policy's own under ``params``."""
    if not isinstance(cfg, AdjustConfig):
        return dict(cfg or {})
    return {**{k: getattr(cfg, k) for k in AdjustConfig.model_fields}, "params": cfg.params}
