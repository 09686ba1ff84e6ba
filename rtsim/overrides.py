"""Dotted-path overrides of a scenario or task-set file, for the library (notebooks).

``load_scenario("test2", overrides={"leader.speed": 20, "formation.followers": 4})`` changes
the parsed TOML document before it is validated, with the paths a sweep's ``[sweep.set]`` and
``[grid]`` use and ``--set KEY=VALUE`` on the command line takes: one implementation,
`rtsim.config.dotted`, kept here under its old names, and the run options of the sweep
kinds that have a base file (names that are arguments, not keys of the file). A path that
names no key of the file, or a run option, is an `OverrideError`; a value
the file's model refuses is the loader's error (a ScenarioError, ...).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from rtsim.config.dotted import apply_overrides as _apply_mapping
from rtsim.config.dotted import apply_paths
from rtsim.errors import OverrideError

__all__ = ["RUN_OPTIONS", "LIBRARY_OPTIONS", "apply_dotted_overrides", "apply_overrides"]

#: The run options (not keys of the file) of the sweep kinds that have a base file.
RUN_OPTIONS: dict[str, tuple[str, ...]] = {
    "simulate": ("horizon", "exec", "suspension", "window", "scheduler"),
    "scenario": ("mode", "duration", "exec", "scheduler"),
}
#: The names an ``overrides=`` mapping refuses: arguments of the library's functions.
LIBRARY_OPTIONS: tuple[str, ...] = ("mode", "policy", "seed", "exec", "duration_s")

#: Set each resolved path (a tuple of keys) in a TOML dict: a sweep point's overrides.
apply_overrides = apply_paths


def apply_dotted_overrides(
    data: dict[str, Any], overrides: Mapping[str, Any], source: str, kind: str = "scenario"
) -> dict[str, Any]:
    """Apply ``overrides`` (dotted path -> value) to the TOML dict ``data`` in place
    (``kind``: ``scenario`` or ``simulate``, a task-set file: no difference any more)."""
    del kind
    return _apply_mapping(data, overrides, source, OverrideError, options=LIBRARY_OPTIONS)
