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
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from rtsim.config.dotted import apply_overrides
from rtsim.config.errors import Loc, error_lines, raise_errors
from rtsim.errors import InputError, OverrideError, TaskSetError

__all__ = [
    "validate",
    "parse_toml",
    "load_taskset",
    "parse_taskset",
    "taskset_bytes",
    "PACKAGED_TASKSET",
]

M = TypeVar("M", bound=BaseModel)

#: The paper's Table 1, shipped inside the package (also ``tasksets/barrel_robots.toml``).
PACKAGED_TASKSET = "barrel_robots.toml"


def validate(
    model: type[M],
    data: Any,
    source: str,
    error: type[InputError],
    where: Callable[[Loc], str] | None = None,
    special: Callable[[Loc, str], str | None] | None = None,
) -> M:
    """``data`` validated by ``model``, or ``error`` with every problem, one line each."""
    if not isinstance(data, Mapping):
        raise error(f"{source}: must be a table of keys, got {type(data).__name__}")
    try:
        return model.model_validate(dict(data))
    except ValidationError as exc:
        kw: dict[str, Any] = {} if where is None else {"where": where}
        lines = error_lines(exc, model, source, special=special, **kw)
    # raised outside the handler: the user's error alone, no pydantic traceback chained under it
    raise_errors(lines, error)
    raise AssertionError("unreachable")


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
        raise error(
            f"{source}: nested too deeply to read (tables or arrays within each other "
            f"hundreds of levels deep)"
        ) from None


def with_overrides(
    data: dict[str, Any], overrides: Mapping[str, Any] | None, source: str
) -> dict[str, Any]:
    """``data`` with the dotted ``overrides`` applied (`rtsim.config.dotted`)."""
    if overrides:  # a path that names no key, or a run option: an OverrideError
        apply_overrides(
            data,
            overrides,
            source,
            OverrideError,
            options=("mode", "policy", "seed", "exec", "duration_s"),
        )
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
        from rtsim.examples import shipped_hint

        raise TaskSetError(f"{source}: no such file{shipped_hint(source, 'taskset')}") from None
    except IsADirectoryError:
        raise TaskSetError(f"{source}: is a directory, not a task-set file") from None
    except OSError as exc:
        raise TaskSetError(f"{source}: cannot read: {exc.strerror or exc}") from None


def parse_taskset(data: Mapping[str, Any], source: str, *, allow_code: bool | None = None) -> Any:
    """Validate a task-set table (as `tomllib.loads` returns it) and build the TaskSet;
    ``source`` names the file in error messages and is kept as ``TaskSet.source``. A
    ``[scheduler] policy`` of the form ``module:Name`` is code: it loads only with
    ``allow_code=True`` or the user's opt-in (`rtsim.registry.reading_input`)."""
    from rtsim.config.taskset import (
        TaskSetFile,
        build_taskset,
        taskset_special,
        taskset_where,
    )
    from rtsim.registry import reading_input

    with reading_input(allow_code):
        model = validate(
            TaskSetFile, data, source, TaskSetError, taskset_where(data), taskset_special
        )
        ts, errors = build_taskset(model, source)
    raise_errors([f"{source}: {e}" for e in errors], TaskSetError)
    assert ts is not None
    return ts


def load_taskset(
    path: str | os.PathLike[str] | None = None,
    overrides: Mapping[str, Any] | None = None,
    *,
    allow_code: bool | None = None,
) -> Any:
    """Read a TOML task-set file (``None``: the packaged paper set, Table 1); ``overrides``:
    dotted paths and their values (`rtsim.config.dotted`); ``allow_code``: as
    [`parse_taskset`][rtsim.config.load.parse_taskset]."""
    raw, source = taskset_bytes(path)
    data = parse_toml(raw, source, TaskSetError)
    return parse_taskset(with_overrides(data, overrides, source), source, allow_code=allow_code)
