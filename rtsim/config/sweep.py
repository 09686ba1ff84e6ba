"""Sweep files: the typed model of the file's shape.

What a sweep's names mean (a kind's options and metrics, dotted paths into the base file)
depends on the registered kinds and on the base file, so :mod:`rtsim.sweep.spec` checks
those after this model has checked the shape: the tables and keys, their types, the seed's
range, ``combine``, and what a grid entry may be.
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import Field

from rtsim.config.fields import Leaf, Table, choice, integer, problem, text

__all__ = ["SweepFile", "SweepTable", "GRID_VALUE"]


def _grid_value(value: Any) -> Any:
    scalar = (bool, int, float, str)
    if isinstance(value, scalar):
        return value
    if isinstance(value, list) and value and all(isinstance(v, scalar) for v in value):
        return value
    if isinstance(value, list) and not value:
        raise problem("empty list")
    raise problem(f"expected a list or a range string, got {type(value).__name__}")


_SCALAR = [{"type": "number"}, {"type": "string"}, {"type": "boolean"}]
#: A grid entry: a range string ``"1..10"``, ``"10..50:10"``, a comma list ``"10,20"``, one
#: value, or a TOML array of numbers, strings or booleans.
GRID_VALUE = Leaf(_grid_value, {"anyOf": [*_SCALAR, {"type": "array", "minItems": 1,
                                                      "items": {"anyOf": _SCALAR}}]})


class SweepTable(Table):
    """``[sweep]``."""

    kind: Annotated[str, text(what="a sweep kind (analyze, bounds, simulate, scenario, call)")]
    base: Annotated[str, text(what="a file path")] | None = None
    seed: Annotated[int, integer(0, 2**63 - 1, "", "a non-negative 63-bit integer")] = 0
    combine: Annotated[str, choice(("product", "zip"))] = "product"
    metrics: list[Annotated[str, text()]] | None = Field(default=None, min_length=1)
    function: Annotated[str, text(what="'package.module:function'")] | None = None
    options: dict[str, Any] = Field(default_factory=dict)
    set: dict[str, Any] = Field(default_factory=dict)
    name: Annotated[str, text(nonempty=False, what="text")] = ""
    description: Annotated[str, text(nonempty=False, what="text")] = ""


class SweepFile(Table):
    """A sweep file."""

    sweep: SweepTable
    grid: dict[str, Annotated[Any, GRID_VALUE]] = Field(min_length=1)
