"""The typed configuration: the models of task-set, scenario and sweep files, and the one
loader that reads, applies overrides and validates them (every error at once).

Layer: above model, analysis, world, sim and control (it builds their runtime objects once
from a valid file), below coupling. Names load their module on first use.
"""

from __future__ import annotations

import importlib
from typing import Any

_WHERE = {
    "load_taskset": "load",
    "parse_taskset": "load",
    "load_scenario": "load",
    "scenario_bytes": "load",
    "parse_scenario": "scenario",
    "Scenario": "scenario",
    "AdjustConfig": "scenario",
    "ScenarioFile": "scenario",
    "TaskSetFile": "taskset",
    "SweepFile": "sweep",
    "json_schema": "schema",
    "apply_overrides": "dotted",
    "parse_assignment": "dotted",
}

__all__ = sorted(_WHERE)


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        return getattr(importlib.import_module(f"rtsim.config.{_WHERE[name]}"), name)
    raise AttributeError(f"module 'rtsim.config' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
