"""The one loader of input files: read (size-limited) → TOML → overrides → one validation.

Every problem the model finds is reported at once, one line each, ``<file>: <key>: <problem>``
(the error's ``lines``); the rules between keys are checked when the runtime objects are
built from the valid model, also all at once where they are independent.
"""

from __future__ import annotations

import os
import tomllib
from collections.abc import Callable, Mapping
from importlib import resources
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from rtsim.config.dotted import apply_overrides
from rtsim.config.errors import Loc, error_lines, raise_errors
from rtsim.errors import InputError, ScenarioError, TaskSetError

__all__ = ["validate", "parse_toml", "load_taskset", "parse_taskset", "taskset_bytes",
           "PACKAGED_TASKSET"]

M = TypeVar("M", bound=BaseModel)

#: The paper's Table 1, shipped inside the package (also ``tasksets/barrel_robots.toml``).
PACKAGED_TASKSET = "barrel_robots.toml"


def validate(model: type[M], data: Any, source: str, error: type[InputError],
             where: Callable[[Loc], str] | None = None,
             special: Callable[[Loc, str], str | None] | None = None) -> M:
    """``data`` validated by ``model``, or ``error`` with every problem, one line each."""
    if not isinstance(data, Mapping):
        raise error(f"{source}: must be a table of keys, got {type(data).__name__}")
    try:
        return model.model_validate(dict(data))
    except ValidationError as exc:
        kw: dict[str, Any] = {} if where is None else {"where": where}
        lines = error_lines(exc, model, source, special=special, **kw)
        raise_errors(lines, error)
        raise AssertionError("unreachable") from None


def parse_toml(raw: bytes, source: str, error: type[InputError]) -> dict[str, Any]:
    """The TOML document in ``raw`` (bytes of a file called ``source``)."""
    if b"\x00" in raw:
        raise error(f"{source}: not a text file (contains NUL bytes)")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{source}: not a text file (not UTF-8 at byte {exc.start})") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{source}: malformed TOML: {exc}") from None
    except RecursionError:
        raise error(f"{source}: nested too deeply to read (tables or arrays within each other "
                    f"hundreds of levels deep)") from None


def with_overrides(data: dict[str, Any], overrides: Mapping[str, Any] | None, source: str,
                   error: type[InputError]) -> dict[str, Any]:
    """``data`` with the dotted ``overrides`` applied (:mod:`rtsim.config.dotted`)."""
    if overrides:
        apply_overrides(data, overrides, source, error,
                        options=("mode", "policy", "seed", "exec", "duration_s"))
    return data


# -------------------------------------------------------------------------- task sets
def taskset_bytes(path: str | os.PathLike[str] | None) -> tuple[bytes, str]:
    """The bytes of a task-set file and the name errors give it (``None``: the packaged
    paper set; a shipped example by name, ``example``)."""
    if path is None:
        res = resources.files("rtsim") / "data" / PACKAGED_TASKSET
        return res.read_bytes(), str(res)
    from rtsim.examples import packaged_text

    shipped = packaged_text(path, "taskset")
    if shipped is not None:
        return shipped.encode("utf-8"), f"{os.fspath(path)}.toml (packaged)"
    source = os.fspath(path)
    from rtsim.io.limits import read_input

    try:
        return read_input(source, "task-set"), source
    except FileNotFoundError:
        raise TaskSetError(f"{source}: no such file") from None
    except IsADirectoryError:
        raise TaskSetError(f"{source}: is a directory, not a task-set file") from None
    except OSError as exc:
        raise TaskSetError(f"{source}: cannot read: {exc.strerror or exc}") from None


def parse_taskset(data: Mapping[str, Any], source: str) -> Any:
    """Validate a task-set table (as :func:`tomllib.loads` returns it) and build the TaskSet;
    ``source`` names the file in error messages and is kept as ``TaskSet.source``."""
    from rtsim.config.taskset import (
        TaskSetFile,
        build_taskset,
        taskset_special,
        taskset_where,
    )

    model = validate(TaskSetFile, data, source, TaskSetError, taskset_where(data),
                     taskset_special)
    ts, errors = build_taskset(model, source)
    raise_errors([f"{source}: {e}" for e in errors], TaskSetError)
    assert ts is not None
    return ts


def load_taskset(path: str | os.PathLike[str] | None = None,
                 overrides: Mapping[str, Any] | None = None) -> Any:
    """Read a TOML task-set file (``None``: the packaged paper set, Table 1); ``overrides``:
    dotted paths and their values (:mod:`rtsim.config.dotted`)."""
    raw, source = taskset_bytes(path)
    data = parse_toml(raw, source, TaskSetError)
    return parse_taskset(with_overrides(data, overrides, source, TaskSetError), source)


# -------------------------------------------------------------------------- scenarios
def scenario_bytes(path: str | os.PathLike[str]) -> tuple[bytes, Path]:
    """The bytes of a scenario file, and its path.

    ``path`` is a file, or the name of a packaged scenario (``test1``, ``test2``: the paper's
    tests, shipped with rtsim as copies of ``experiments/scenarios/``) when no such file
    exists.
    """
    from rtsim.config.scenario import PACKAGED_SCENARIOS
    from rtsim.io.limits import read_input

    p = Path(path)
    if not p.exists() and str(path) in PACKAGED_SCENARIOS:
        res = resources.files("rtsim") / "data" / "scenarios" / f"{path}.toml"
        return res.read_bytes(), Path(f"{path}.toml")
    try:
        return read_input(p, "scenario"), p
    except OSError as exc:
        raise ScenarioError(f"{p}: cannot read scenario: {exc.strerror or exc}") from None


def load_scenario(path: str | os.PathLike[str],
                  overrides: Mapping[str, Any] | None = None) -> Any:
    """Read and validate a scenario TOML file (or a packaged scenario by name, e.g. ``test1``).

    ``overrides``: dotted paths into the file and their new values, resolved as a sweep's
    (``{"leader.speed": 20, "formation.followers": 4}``; :mod:`rtsim.config.dotted`).
    """
    from rtsim.config.scenario import parse_scenario

    raw, p = scenario_bytes(path)
    src = str(p)  # the full path in every message
    data = parse_toml(raw, src, ScenarioError)
    return parse_scenario(with_overrides(data, overrides, src, ScenarioError), src, p.parent)
