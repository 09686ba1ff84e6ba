"""The one loader of input files: read (size-limited) → TOML → overrides → one validation.

Every problem the model finds is reported at once, one line each, ``<file>: <key>: <problem>``
(the error's ``lines``); the rules between keys are checked when the runtime objects are
built from the valid model, also all at once where they are independent.
"""

from __future__ import annotations

import tomllib
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from rtsim.config.dotted import apply_overrides
from rtsim.config.errors import Loc, error_lines, raise_errors
from rtsim.errors import InputError, OverrideError

__all__ = [
    "validate",
    "parse_toml",
]

M = TypeVar("M", bound=BaseModel)


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
