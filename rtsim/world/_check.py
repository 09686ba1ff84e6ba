"""Validators shared by the world's frozen specs: one-line `ScenarioError` naming the key."""

from __future__ import annotations

import math
from dataclasses import field, fields
from typing import Any, TypeVar

from rtsim._numbers import is_int, is_real
from rtsim.errors import InputError, ScenarioError
from rtsim.io.limits import Range
from rtsim.registry import Registry

__all__ = ["number", "positive", "integer", "plugin", "spec", "in_ranges", "NOISE"]

T = TypeVar("T")

#: The reason of a noise's range (a standard deviation).
NOISE = "a noise standard deviation"


def plugin(registry: Registry[T], name: str, where: str) -> T:
    """The plug-in ``name`` names in ``registry``; an unknown one is a `ScenarioError`."""
    try:
        return registry.resolve(name, where)
    except ScenarioError:
        raise
    except InputError as exc:
        raise ScenarioError(str(exc)) from None


def number(key: str, value: object) -> float:
    """``value`` as a finite float, else ``ScenarioError("<key> must be a finite number, ...")``."""
    if not is_real(value):
        raise ScenarioError(f"{key}: must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ScenarioError(f"{key}: must be finite, got {value!r}")
    return v


def positive(key: str, value: object, *, allow_inf: bool = False) -> float:
    """``value`` as a float > 0 (``inf`` only when ``allow_inf``)."""
    if allow_inf and isinstance(value, float) and value == math.inf:
        return value
    v = number(key, value)
    if v <= 0:
        raise ScenarioError(f"{key}: must be positive, got {value!r}")
    return v


def integer(key: str, value: object, *, minimum: int = 0) -> int:
    """``value`` as an int ≥ ``minimum``."""
    if not is_int(value) or value < minimum:
        raise ScenarioError(f"{key}: must be an integer >= {minimum}, got {value!r}")
    return int(value)


def spec(default: Any, rng: Range) -> Any:
    """A field of a world's frozen spec: its one default and its one range ``rng`` (the
    scenario file's table reads both, `rtsim.config.scenario`; `in_ranges` checks it)."""
    return field(default=default, metadata={"range": rng})


def in_range(key: str, value: object, rng: Range) -> float:
    """``value`` (a float; an int for a count) if ``rng`` admits it, else a `ScenarioError`
    naming ``key`` and the range."""
    if rng.inf and isinstance(value, float) and value == math.inf:
        return value
    v = integer(key, value, minimum=int(rng.lo)) if rng.integer else number(key, value)
    if not rng.admits(v):
        raise ScenarioError(f"{key}: must be in {rng.text()} ({rng.why}), got {value!r}")
    return v


def in_ranges(spec_: object, table: str) -> None:
    """Check (and normalise) every `spec` field of the frozen dataclass ``spec_`` against its
    range; a value outside it is a `ScenarioError` naming ``<table>.<key>`` (the range's own
    key when it has one: a file key whose field is named otherwise)."""
    for f in fields(spec_):  # type: ignore[arg-type]
        rng = f.metadata.get("range")
        value = getattr(spec_, f.name)
        if rng is not None and value is not None:
            key = rng.key or f"{table}.{f.name}"
            object.__setattr__(spec_, f.name, in_range(key, value, rng))
