"""Validation errors as rtsim prints them: ``<file>: <key.path>: <problem>``, one line each,
every error of a file at once."""

from __future__ import annotations

import types
import typing
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from pydantic import BaseModel, ValidationError

from rtsim._suggest import close_match, did_you_mean
from rtsim.errors import InputError

__all__ = ["error_lines", "raise_errors", "model_at", "keys_of", "Loc"]

Loc = tuple[int | str, ...]


def _model_of(annotation: Any) -> type[BaseModel] | None:
    """The model class inside ``annotation`` (``X``, ``X | None``, ``list[X]``, ...)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in typing.get_args(annotation):
        found = _model_of(arg)
        if found is not None:
            return found
    return None


def _item_of(annotation: Any) -> Any:
    """What a list or dict annotation holds (itself for anything else)."""
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        for arg in typing.get_args(annotation):
            if typing.get_origin(arg) in (list, tuple, dict):
                return _item_of(arg)
    if origin in (list, tuple):
        return typing.get_args(annotation)[0]
    if origin is dict:
        return typing.get_args(annotation)[1]
    return annotation


def model_at(root: type[BaseModel], loc: Loc) -> type[BaseModel] | None:
    """The model of the table at ``loc`` (None if ``loc`` is not a table)."""
    node: Any = root
    for part in loc:
        model = _model_of(node) if not isinstance(part, int) else None
        if isinstance(part, int) or model is None:
            node = _item_of(node)
            continue
        field = model.model_fields.get(str(part))
        if field is None:
            field = next((f for f in model.model_fields.values() if f.alias == part), None)
        if field is None:
            return None
        node = field.annotation
    origin = typing.get_origin(node)
    if origin in (list, tuple, dict):
        return None
    return _model_of(node)


def keys_of(model: type[BaseModel]) -> list[str]:
    """The keys a table of ``model`` accepts."""
    return [f.alias or name for name, f in model.model_fields.items()]


def _problem(root: type[BaseModel], err: Mapping[str, Any]) -> tuple[Loc, str]:
    """(where, what) of one pydantic error."""
    loc: Loc = tuple(err["loc"])
    kind = err["type"]
    value = err.get("input")
    if kind == "rtsim":
        return loc, err["ctx"]["problem"] if "ctx" in err else err["msg"]
    if kind == "extra_forbidden":
        parent = model_at(root, loc[:-1])
        key = loc[-1]
        hint = did_you_mean(key, keys_of(parent)) if parent is not None else ""
        if not hint and parent is not None:
            hint = f" (known keys: {', '.join(keys_of(parent))})"
        return loc[:-1], f"unknown key '{key}'{hint}"
    if kind == "missing":
        return loc, "missing (required)"
    if kind in ("model_type", "model_attributes_type", "dict_type"):
        return loc, f"must be a table, got {value!r}"
    if kind in ("list_type", "tuple_type"):
        return loc, f"must be an array, got {value!r}"
    if kind == "too_short":
        return loc, "must not be empty"
    if kind == "string_type":
        return loc, f"must be a string, got {value!r}"
    if kind == "bool_type":
        return loc, f"must be true or false, got {value!r}"
    return loc, err["msg"]


def _plain_where(loc: Loc) -> str:
    """``leader.speed``; after an array index a colon: ``leader.path[2]: radius``."""
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part + 1}]"
        elif out.endswith("]"):
            out += f": {part}"
        else:
            out += f".{part}" if out else str(part)
    return out


def error_lines(exc: ValidationError, root: type[BaseModel], source: str,
                where: Callable[[Loc], str] = _plain_where,
                special: Callable[[Loc, str], str | None] | None = None) -> list[str]:
    """One line per error of ``exc``: ``<source>: <where>: <problem>`` (no ``<where>`` for
    the file itself). ``where`` renders a location; ``special`` may rewrite a problem."""
    lines: list[str] = []
    errors = exc.errors(include_url=False)
    meant = set()  # a missing key that an unknown key misspells is not reported twice
    for err in errors:
        if err["type"] == "extra_forbidden":
            parent = model_at(root, tuple(err["loc"][:-1]))
            if parent is not None:
                close = close_match(err["loc"][-1], keys_of(parent))
                meant.add((*err["loc"][:-1], close))
    for err in errors:
        if err["type"] == "missing" and tuple(err["loc"]) in meant:
            continue
        loc, what = _problem(root, err)
        if special is not None:
            what = special(loc, what) or what
        at = where(loc) if loc else ""
        line = f"{source}: {at}: {what}" if at else f"{source}: {what}"
        if line not in lines:
            lines.append(line)
    return lines


def raise_errors(lines: Sequence[str], error: type[InputError]) -> None:
    """Raise ``error`` with all ``lines`` (nothing when there are none)."""
    if not lines:
        return
    exc = error("\n".join(lines))
    exc.lines = tuple(lines)  # type: ignore[attr-defined]
    raise exc
