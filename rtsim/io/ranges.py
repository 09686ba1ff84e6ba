"""Parameter lists on the command line and in sweep files.

Accepted: ``5``, ``1..10``, ``10..50:10``, ``10,20,30``.
"""

from __future__ import annotations

import math
import re

from rtsim.errors import InputError

__all__ = ["parse_values", "parse_int_values"]

_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
#: ``1-10``: a range written with a dash (the hint points to ``1..10``)
_DASH = re.compile(r"^\s*(\d+(?:\.\d*)?)\s*-\s*(\d+(?:\.\d*)?)\s*$")
_RANGE = re.compile(rf"^\s*({_NUM})\s*\.\.\s*({_NUM})\s*(?::\s*({_NUM})\s*)?$")


def _num(text: str, what: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise InputError(f"{what}: cannot parse {text!r} as a number") from None
    if not math.isfinite(v):
        raise InputError(f"{what}: {text!r} is not finite")
    return v


def parse_values(text: str, what: str = "value") -> list[float]:
    """Parse a value, a comma list, or an inclusive range ``a..b[:step]`` (step defaults to 1).

    ``what`` names the option or key in error messages.
    """
    text = str(text).strip()
    if not text:
        raise InputError(f"{what}: empty value")
    m = _RANGE.match(text)
    if m:
        a, b = _num(m.group(1), what), _num(m.group(2), what)
        step = _num(m.group(3), what) if m.group(3) else 1.0
        if step <= 0:
            raise InputError(f"{what}: range step must be positive in {text!r}")
        if b < a:
            raise InputError(f"{what}: range end is below its start in {text!r}")
        count = int(math.floor((b - a) / step + 1e-9)) + 1
        if count > 1_000_000:
            raise InputError(f"{what}: range {text!r} has too many values ({count})")
        return [a + i * step for i in range(count)]
    if ".." in text:
        raise InputError(f"{what}: cannot parse range {text!r} (expected a..b or a..b:step)")
    dash = _DASH.match(text)
    if dash:  # 1-10: a range written with a dash
        raise InputError(
            f"{what}: cannot parse {text!r}: ranges are written "
            f"{dash.group(1)}..{dash.group(2)} (a..b or a..b:step), lists 1,2,5"
        )
    return [_num(part.strip(), what) for part in text.split(",")]


def parse_int_values(text: str, what: str = "value") -> list[int]:
    """As `parse_values`, but every value must be an integer."""
    out = []
    for v in parse_values(text, what):
        if v != int(v):
            raise InputError(f"{what}: {v:g} is not an integer in {text!r}")
        out.append(int(v))
    return out
