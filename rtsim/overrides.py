"""Dotted-path overrides of a scenario or task-set file, for the library (notebooks).

``load_scenario("test2", overrides={"leader.speed": 20, "formation.followers": 4})`` changes
the parsed TOML document before it is validated, with the paths a sweep's ``[sweep.set]`` and
``[grid]`` use and ``--set KEY=VALUE`` on the command line takes: one implementation,
:mod:`rtsim.config.dotted`, kept here under its old name.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from rtsim.config.dotted import apply_overrides
from rtsim.errors import InputError

__all__ = ["apply_dotted_overrides"]


def apply_dotted_overrides(data: dict[str, Any], overrides: Mapping[str, Any], source: str,
                           kind: str = "scenario") -> dict[str, Any]:
    """Apply ``overrides`` (dotted path -> value) to the TOML dict ``data`` in place
    (``kind``: ``scenario`` or ``simulate``, a task-set file: no difference any more)."""
    del kind
    return apply_overrides(data, overrides, source, InputError,
                           options=("mode", "policy", "seed", "exec", "duration_s"))
