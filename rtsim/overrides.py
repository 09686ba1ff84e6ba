"""Dotted-path overrides of a scenario or task-set file, for the library (notebooks).

``load_scenario("test2", overrides={"leader.speed": 20, "formation.followers": 4})`` changes
the parsed TOML document before it goes through the normal loader, exactly as a sweep's
``[sweep.set]`` and ``[grid]`` entries do: the same path resolution (tables by key, lists of
tables by ``name`` or 0-based index, shortcuts for ``[window]`` and top-level keys), the same
typo check, the same :func:`rtsim.sweep.kinds.apply_overrides`, and the loader's own
validation of the changed values — so a notebook and a sweep accept and refuse the same
paths with the same messages (:mod:`rtsim.sweep.spec`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from rtsim.errors import OverrideError

__all__ = ["apply_dotted_overrides"]


def apply_dotted_overrides(data: dict[str, Any], overrides: Mapping[str, Any], source: str,
                           kind: str = "scenario") -> dict[str, Any]:
    """Apply ``overrides`` (dotted path -> value) to the TOML dict ``data`` in place.

    ``kind``: ``scenario`` or ``simulate`` (a task-set file); decides which names are run
    options of a sweep, which are refused here (pass them as arguments instead).
    Raises :class:`~rtsim.errors.OverrideError` (an InputError) naming ``source`` and the
    path; a value the file's loader refuses is the loader's error (a ScenarioError, ...).
    """
    from rtsim.errors import SweepError
    from rtsim.sweep.kinds import KINDS, apply_overrides
    from rtsim.sweep.spec import BaseFile, _resolve

    if not isinstance(overrides, Mapping):
        raise OverrideError(f"{source}: overrides: expected a mapping of dotted paths to values, "
                         f"got {type(overrides).__name__}")
    base = BaseFile(source, "")
    paths = []
    for name, value in overrides.items():
        if not isinstance(name, str) or not name:
            raise OverrideError(f"{source}: overrides: keys must be dotted paths, got {name!r}")
        try:  # the sweep's path resolution, its errors renamed for what the user did
            target = _resolve(source, name, kind, base, data, table="overrides")
        except SweepError as exc:
            raise OverrideError(str(exc)) from None
        if target[0] != "path":
            opts = ", ".join(KINDS[kind].options)
            raise OverrideError(f"{source}: overrides.{name}: a run option ({opts}), not a key of "
                             f"the file: pass it as an argument")
        paths.append((tuple(target[1:]), value))
    return apply_overrides(data, tuple(paths))
