"""The base helpers for files: atomic writes, manifests, result directories, chunked tables,
parameter ranges and the input and work limits. The loaders of input files are in
`rtsim.config` (`rtsim.config.taskset.load_taskset`, `rtsim.config.scenario.load_scenario`).

The names below load their module on first use (``rtsim.io.columns`` needs pandas).
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
}

__all__ = sorted(_WHERE)


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        return getattr(importlib.import_module(f"rtsim.io.{_WHERE[name]}"), name)
    raise AttributeError(f"module 'rtsim.io' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
