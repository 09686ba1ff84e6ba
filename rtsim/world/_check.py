"""Validators shared by the world's frozen specs: one-line `ScenarioError` naming the key."""

from __future__ import annotations

import math
from typing import TypeVar

from rtsim._numbers import is_int, is_real
from rtsim.errors import InputError, ScenarioError
from rtsim.registry import Registry

__all__ = ["number", "positive", "non_negative", "integer", "plugin"]

T = TypeVar("T")


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


def non_negative(key: str, value: object) -> float:
    """``value`` as a float ≥ 0."""
    v = number(key, value)
    if v < 0:
        raise ScenarioError(f"{key}: must be non-negative, got {value!r}")
    return v


def integer(key: str, value: object, *, minimum: int = 0) -> int:
    """``value`` as an int ≥ ``minimum``."""
    if not is_int(value) or value < minimum:
        raise ScenarioError(f"{key}: must be an integer >= {minimum}, got {value!r}")
    return int(value)
