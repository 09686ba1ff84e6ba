"""What counts as a number in rtsim's inputs: Python's and numpy's alike.

``numpy.int64(3)`` and ``numpy.float32(2.5)`` are accepted wherever ``3`` and ``2.5`` are;
``True`` and ``numpy.True_`` are not numbers (a bool where a number belongs is a mistake).
"""

from __future__ import annotations

import numbers
from typing import TypeGuard

__all__ = ["is_real", "is_int"]


def _is_bool(v: object) -> bool:
    return isinstance(v, bool) or type(v).__name__ == "bool_"


def is_real(v: object) -> TypeGuard[float]:
    """A real number (int, float, numpy integer or floating scalar), not a bool."""
    return isinstance(v, numbers.Real) and not _is_bool(v)


def is_int(v: object) -> TypeGuard[int]:
    """An integer (int or numpy integer scalar), not a bool."""
    return isinstance(v, numbers.Integral) and not _is_bool(v)
