"""The building blocks of the input models: numbers with their range and unit, choices,
names, and the strict table every model derives from.

A numeric key is declared once, with everything that is known about it::

    speed: Annotated[float, number(0, 1000, "cm/s", "a ground robot at most 10 m/s",
                                   lo_open=True)]

The range and unit are the field's metadata: the validator refuses a value outside the range
(no coercion: ``"5"`` and ``true`` are not numbers, ``1.0`` is not an integer), the JSON
Schema carries ``minimum``/``exclusiveMinimum``/``maximum``, ``unit`` and ``why``, and
``docs/input_ranges.md`` is generated from them (`rtsim.config.docs`). A value keeps its
TOML type (an int stays an int), so the runtime objects are built from exactly what the
file says.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from pydantic import BaseModel, ConfigDict, GetCoreSchemaHandler, GetJsonSchemaHandler
from pydantic_core import PydanticCustomError, core_schema

from rtsim._numbers import is_int, is_real
from rtsim._suggest import did_you_mean
from rtsim.errors import InputError
from rtsim.io.limits import Range
from rtsim.registry import Registry

__all__ = [
    "Table",
    "Leaf",
    "number",
    "ranged",
    "integer",
    "choice",
    "plugin",
    "text",
    "problem",
    "Range",
    "range_of",
]


class Table(BaseModel):
    """A TOML table: unknown keys are errors, nothing is coerced, frozen once valid."""

    model_config = ConfigDict(strict=True, extra="forbid", frozen=True, validate_default=False)


def problem(message: str) -> PydanticCustomError:
    """A validation error whose text is ``message`` as written (one line)."""
    return PydanticCustomError("rtsim", "{problem}", {"problem": message})


def _shown(value: Any) -> str:
    return str(int(value)) if is_int(value) else f"{float(value):.6g}"


def _check_number(r: Range, deg: bool) -> Any:
    unit = f" {r.unit}" if r.unit else ""

    def check(value: Any) -> Any:
        if r.integer:
            if not is_int(value):
                raise problem(f"must be an integer, got {value!r}")
        elif not is_real(value):
            raise problem(f"must be a number, got {value!r}")
        x = float(value)
        if math.isnan(x):
            raise problem(f"must be finite, got {value!r}")
        if deg and math.isfinite(x):
            x = math.radians(x)
        if r.admits(x):
            return value
        if math.isinf(x) and not (r.inf and x > 0):
            raise problem(f"must be finite, got {value!r}")
        if r.integer and x < r.lo:
            raise problem(f"must be an integer >= {r.lo:g}, got {value!r}")
        if r.lo == 0 and not r.lo_open and x < 0:
            raise problem(f"must be non-negative, got {value!r}")
        if r.lo >= 0 and x <= 0:
            raise problem(f"must be positive, got {value!r}")
        rad = " (in radians)" if deg else ""
        shown = f"{x:.6g}" if deg else _shown(value)
        raise problem(f"{shown}{unit}{rad} is outside {r.text()} ({r.why})")

    return check


def _schema(r: Range, deg: bool) -> dict[str, Any]:
    scale = 180.0 / math.pi if deg else 1.0
    out: dict[str, Any] = {"type": "integer" if r.integer else "number"}
    if not r.inf:  # TOML's inf has no JSON form: a key that takes it has no maximum here
        out["exclusiveMaximum" if r.hi_open else "maximum"] = r.hi * scale
    out["exclusiveMinimum" if r.lo_open else "minimum"] = r.lo * scale
    return out


class Leaf:
    """Field metadata that validates a TOML value itself (strictly, keeping its type) and
    gives its JSON Schema: ``Annotated[float, number(...)]``."""

    def __init__(
        self, check: Callable[[Any], Any], schema: dict[str, Any], rng: Range | None = None
    ) -> None:
        self.check = check
        self.schema = schema
        self.range = rng

    def __get_pydantic_core_schema__(
        self, source: Any, handler: GetCoreSchemaHandler
    ) -> core_schema.CoreSchema:
        return core_schema.no_info_plain_validator_function(self.check)

    def __get_pydantic_json_schema__(
        self, schema: core_schema.CoreSchema, handler: GetJsonSchemaHandler
    ) -> dict[str, Any]:
        return dict(self.schema)


def number(
    lo: float,
    hi: float,
    unit: str,
    why: str,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    inf: bool = False,
    integer: bool = False,
    deg: bool = False,
) -> Leaf:
    """A number between ``lo`` and ``hi`` (in ``unit``; ``inf`` also accepted when ``inf``).

    ``deg``: the key is the ``_deg`` twin of an angle whose range (``lo``, ``hi``) is in
    radians; the value is converted before it is checked, so both spellings accept the same
    angles.
    """
    r = Range("", lo, hi, unit, why, lo_open, hi_open, inf, integer)
    schema = _schema(r, deg)
    schema.update({"unit": "deg" if deg else unit, "why": why})
    if inf:
        schema["inf"] = "inf (TOML) is also accepted: none"
    return Leaf(_check_number(r, deg), schema, r)


def ranged(r: Range, *, deg: bool = False) -> Leaf:
    """A number in the range ``r`` declared by a lower layer (`rtsim.io.limits`, a world
    spec's field: a key that layer checks too, with the same range); ``deg``: as `number`'s."""
    return number(
        r.lo,
        r.hi,
        r.unit,
        r.why,
        lo_open=r.lo_open,
        hi_open=r.hi_open,
        inf=r.inf,
        integer=r.integer,
        deg=deg,
    )


def integer(lo: float, hi: float, unit: str, why: str) -> Leaf:
    """An integer between ``lo`` and ``hi`` (both included)."""
    return number(lo, hi, unit, why, integer=True)


def choice(values: Sequence[str], *, renamed: Mapping[str, str] | None = None) -> Leaf:
    """One of ``values`` (a string), with a did-you-mean; ``renamed``: old names and their
    new ones (an old name is an error naming its replacement)."""
    names = tuple(values)
    shown = (
        " or ".join(f"'{v}'" for v in names) if len(names) == 2 else ("one of " + ", ".join(names))
    )

    def check(value: Any) -> Any:
        if isinstance(value, str) and value in names:
            return value
        raise problem(
            f"must be {shown}, got {value!r}{did_you_mean(value, names, renamed=renamed)}"
        )

    return Leaf(check, {"type": "string", "enum": list(names)})


def plugin(registry: Registry[Any]) -> Leaf:
    """The name of a plug-in of ``registry`` (`rtsim.registry`): a registered name, an
    installed entry point, or ``package.module:Name`` (code: only when the reader allows it),
    resolved while the file is validated (an old name says its new one: the registry's
    ``renamed``).

    Its JSON Schema is a string, with the built-in names as ``examples`` (an installed
    plug-in or a ``module:Name`` is valid too, so they are no ``enum``)."""

    def check(value: Any) -> Any:
        try:
            registry.resolve(value, "")
        except InputError as exc:
            raise problem(str(exc).removeprefix(": ")) from None
        return value

    schema = {
        "type": "string",
        "minLength": 1,
        "examples": list(registry),
        "description": f"a {registry.kind}: {', '.join(registry)}, an installed plug-in "
        f"or 'package.module:Name'",
    }
    return Leaf(check, schema)


def text(*, nonempty: bool = True, what: str = "a non-empty string") -> Leaf:
    """A string (non-empty unless ``nonempty`` is false)."""

    def check(value: Any) -> Any:
        if not isinstance(value, str) or (nonempty and not value.strip()):
            raise problem(f"must be {what}, got {value!r}")
        return value

    schema: dict[str, Any] = {"type": "string"}
    if nonempty:
        schema["minLength"] = 1
    return Leaf(check, schema)


def range_of(metadata: Sequence[Any]) -> Range | None:
    """The `Range` among a field's metadata (None: not a number field)."""
    return next((m.range for m in metadata if isinstance(m, Leaf) and m.range), None)
