"""`rtsim.world.exactmath.cpython_hypot`, as plain Python and compiled, against the
interpreter's ``math.hypot`` bit for bit: random bit patterns over the whole range (zeros,
subnormals, huge and tiny exponents, infinities, NaNs) and the edge cases by hand. Left
out: pairs whose larger magnitude is below 2^-1023, where CPython's vector_norm differs
between versions (3.12 rescales by DBL_MIN, as the kernel does; 3.11 divides by the
larger and rounds some ties the other way)."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from rtsim.world.compiled import available
from rtsim.world.exactmath import cpython_hypot

_SPECIAL = [
    0.0,
    -0.0,
    5e-324,
    -5e-324,
    1e-320,
    2.2250738585072014e-308,  # DBL_MIN
    2.2250738585072009e-308,  # the largest subnormal
    4.450147717014403e-308,
    1e-300,
    1e-17,
    0.5,
    1.0,
    3.0,
    4.0,
    325.0,
    1e300,
    8.98846567431158e307,  # 2^1023
    1.7976931348623157e308,  # DBL_MAX
    math.inf,
    -math.inf,
    math.nan,
]


def _pairs(count: int) -> list[tuple[float, float]]:
    rng = np.random.default_rng(20261129)
    bits = rng.integers(0, 2**64, (count, 2), dtype=np.uint64, endpoint=False)
    anywhere = bits.view(np.float64)  # every exponent, NaNs and infinities included
    near = rng.standard_normal((count, 2)) * 10.0 ** rng.integers(-320, 300, (count, 1))
    equal = np.repeat(anywhere[:, :1], 2, axis=1)
    pairs = [(x, y) for x in _SPECIAL for y in _SPECIAL]
    for block in (anywhere, near, equal):
        pairs.extend(map(tuple, block.tolist()))
    return pairs


def _same(a: float, b: float) -> bool:
    return struct.pack("<d", a) == struct.pack("<d", b) or (math.isnan(a) and math.isnan(b))


def _mismatches(fn: object, pairs: list[tuple[float, float]]) -> list[tuple[float, float]]:
    kept = [(x, y) for x, y in pairs if not max(abs(x), abs(y)) < 2.0**-1023]
    return [(x, y) for x, y in kept if not _same(fn(x, y), math.hypot(x, y))]  # type: ignore[operator]


def test_plain_python_hypot_is_math_hypot() -> None:
    assert _mismatches(cpython_hypot, _pairs(20000)) == []


@pytest.mark.skipif(not available(), reason="numba is not importable")
def test_compiled_hypot_is_math_hypot() -> None:
    from rtsim.world.kernels import kernels  # lazy: compiles (or loads) the kernels

    assert _mismatches(kernels().hypot, _pairs(100000)) == []
