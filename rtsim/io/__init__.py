"""Files in and out: task sets, scenarios, atomic results, manifests, parameter ranges.

The names below load their module on first use, so that ``rtsim.io.atomic`` (used by every
command) does not pull in the world and filterpy.
"""

from __future__ import annotations

import importlib
from typing import Any

_WHERE = {
    "write_json": "atomic",
    "write_table": "atomic",
    "write_text": "atomic",
    "write_manifest": "manifest",
    "parse_int_values": "ranges",
    "parse_values": "ranges",
    "Scenario": "scenario",
    "load_scenario": "scenario",
    "parse_scenario": "scenario",
    "load_taskset": "taskset",
    "parse_taskset": "taskset",
    "taskset_to_dict": "taskset",
}

__all__ = sorted(_WHERE)


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        return getattr(importlib.import_module(f"rtsim.io.{_WHERE[name]}"), name)
    raise AttributeError(f"module 'rtsim.io' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
