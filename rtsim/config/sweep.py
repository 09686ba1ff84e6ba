"""Sweep files: the typed model of the file's shape, and the grid's values.

The model checks everything that does not depend on what is registered or on the base file,
all at once: the tables and their keys, the types, the seed's range, ``combine``, ``metrics``
as a list of names, and every grid entry — a range string ``"1..10"``, ``"10..50:10"``, a
comma list ``"10,20"``, one value, or a TOML array — expanded to its values (finite numbers,
integers within 64 bits, text or booleans, all of one type: each is a results column). What a
sweep's names mean (a kind, its options and metrics, dotted paths into the base file) is
checked by `rtsim.sweep.spec`, which sits above the registered sweep kinds: its
``load_sweep`` (public as ``rtsim.sweep.load_sweep``) reads the file with `read_sweep`, as
the other loaders read theirs.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Annotated, Any

from pydantic import Field

from rtsim.config.fields import Leaf, Table, choice, integer, problem, text
from rtsim.config.load import parse_toml
from rtsim.errors import InputError, SweepError
from rtsim.examples import packaged_text, shipped_hint
from rtsim.io.limits import read_input
from rtsim.io.ranges import parse_values

__all__ = [
    "SweepFile",
    "SweepTable",
    "GRID_VALUE",
    "Scalar",
    "grid_values",
    "read_sweep",
    "sweep_special",
]

Scalar = int | float | str | bool


def _tidy(v: float) -> int | float:
    r = float(f"{v:.12g}")
    return int(r) if r.is_integer() else r


def _value_type(v: Any) -> str:
    """The column type of a grid value: ``bool``, ``number`` (int or float) or ``text``."""
    if isinstance(v, bool):
        return "bool"
    return "number" if isinstance(v, int | float) else "text"


def grid_values(raw: Any) -> tuple[Scalar, ...]:
    """The values of one grid entry (module doc); a problem raises a validation error.

    Range strings give integers when every value is integral, else floats rounded to 12
    significant digits (so ``"0.1..0.3:0.1"`` gives 0.1, 0.2, 0.3)."""
    if isinstance(raw, str):
        try:
            vals = parse_values(raw, "")
        except InputError as exc:
            raise problem(
                f"{str(exc).removeprefix(': ')} (use a TOML list for text values)"
            ) from None
        if all(float(v).is_integer() for v in vals):
            return tuple(int(v) for v in vals)
        return tuple(_tidy(v) for v in vals)
    if isinstance(raw, bool | int | float):
        raw = [raw]
    if not isinstance(raw, list):
        raise problem(f"expected a list or a range string, got {type(raw).__name__}")
    if not raw:
        raise problem("empty list")
    for v in raw:
        if not isinstance(v, bool | int | float | str):
            raise problem(f"values must be numbers, text or booleans, got {v!r}")
        if isinstance(v, float) and not math.isfinite(v):
            raise problem(f"value {v!r} is not finite")
        if isinstance(v, int) and not isinstance(v, bool) and not -(2**63) <= v < 2**63:
            raise problem(f"value {v!r} does not fit a 64-bit integer column")
    kinds = {_value_type(v) for v in raw}
    if len(kinds) > 1:
        first = _value_type(raw[0])
        odd = next(v for v in raw if _value_type(v) != first)
        raise problem(
            f"values must all be of one type (a results column has one), got "
            f"{first} {raw[0]!r} and {_value_type(odd)} {odd!r}"
        )
    return tuple(raw)


_SCALAR = [{"type": "number"}, {"type": "string"}, {"type": "boolean"}]
#: A grid entry (`grid_values`): validated and expanded to a tuple of its values.
GRID_VALUE = Leaf(
    grid_values,
    {"anyOf": [*_SCALAR, {"type": "array", "minItems": 1, "items": {"anyOf": _SCALAR}}]},
)


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
    grid: dict[str, Annotated[tuple[Scalar, ...], GRID_VALUE]] = Field(min_length=1)


def sweep_special(loc: tuple[int | str, ...], what: str) -> str | None:
    """The messages of a sweep file that say more than the model's own."""
    if loc == ("sweep",) and what.startswith("missing"):
        return "missing [sweep] table"
    if loc == ("grid",) and (what.startswith("missing") or what == "must not be empty"):
        return "empty grid (give at least one parameter under [grid])"
    return None


def read_sweep(path: str | os.PathLike[str]) -> tuple[dict[str, Any], str, Path, str]:
    """A sweep file read as the other loaders read theirs (`rtsim.config.load.parse_toml`):
    its TOML tables, the name errors give it, the directory its relative paths start from,
    and its text; ``path`` a file, or a shipped example by name (``smoke``)."""
    shipped = packaged_text(path, "sweep")
    if shipped is not None:
        raw, source, base = shipped.encode("utf-8"), f"{os.fspath(path)}.toml (packaged)", Path()
    else:
        source, base = os.fspath(path), Path(path).resolve().parent
        try:
            raw = read_input(source, "sweep")
        except FileNotFoundError:
            raise SweepError(f"{source}: no such file{shipped_hint(source, 'sweep')}") from None
        except OSError as exc:
            raise SweepError(f"{source}: cannot read sweep file: {exc.strerror or exc}") from None
    data = parse_toml(raw, source, SweepError)
    return data, source, base.resolve(), raw.decode("utf-8")
