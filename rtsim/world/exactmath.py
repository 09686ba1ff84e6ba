"""CPython's ``math.hypot`` and ``math.remainder`` as kernel sources (`rtsim.world.jit`):
numba's ``hypot`` uses another algorithm and numba has no ``remainder``, so the compiled
kernels carry CPython's (`rtsim.world.compiled` says why the results are bit for bit the
interpreter's). `math_hypot` is ``math.hypot`` itself as a kernel source: the plain-Python
twin of a kernel swaps it in for `cpython_hypot` (`HYPOT_SUBS`), so that the ``python``
backend computes with the interpreter's own function.

(Named apart from ``math``'s functions: a kernel's callees are found by the names its code
reads, ``math.hypot``'s attribute name among them.)
"""

from __future__ import annotations

import math

from rtsim.world.jit import Subs, kernel

__all__ = ["HYPOT_SUBS", "cpython_hypot", "cpython_remainder", "math_hypot"]


@kernel
def _dl_mul(x: float, y: float) -> tuple[float, float]:
    """x·y and its exact rounding error (Dekker's product with Veltkamp's split)."""
    z = x * y
    c = 134217729.0 * x  # 2^27 + 1
    xh = c - (c - x)
    xl = x - xh
    c = 134217729.0 * y
    yh = c - (c - y)
    yl = y - yh
    return z, ((xh * yh - z) + xh * yl + xl * yh) + xl * yl


@kernel(inline=True)
def _hypot_core(ax: float, ay: float, scale: float) -> float:
    """CPython's vector_norm of (ax, ay) scaled by ``scale`` (2^-e, e the exponent
    ``math.frexp`` gives the larger, a normal number), before it is scaled back: the
    caller divides by ``scale``."""
    csum, frac1, frac2 = 1.0, 0.0, 0.0
    for v in (ax, ay):
        v *= scale
        hi, lo = _dl_mul(v, v)
        t = csum + hi
        frac2 += (csum - t) + hi
        csum = t
        frac1 += lo
    h = math.sqrt(csum - 1.0 + (frac1 + frac2))
    hi, lo = _dl_mul(-h, h)
    t = csum + hi
    frac2 += (csum - t) + hi
    csum = t
    frac1 += lo
    v = csum - 1.0 + (frac1 + frac2)
    return h + v / (2.0 * h)


@kernel
def cpython_hypot(x: float, y: float) -> float:
    """CPython's ``math.hypot`` of two coordinates (its vector_norm: scaled by a power of
    two, the squares summed with their exact errors, a square root and one differential
    correction); `rtsim.world.kernels.kernels` checks it against ``math.hypot`` before a
    kernel uses it."""
    ax, ay = abs(x), abs(y)
    if math.isinf(ax) or math.isinf(ay):  # before NaN, as CPython: hypot(inf, nan) = inf
        return math.inf
    if math.isnan(ax) or math.isnan(ay):
        return math.nan
    mx = ax if ax > ay else ay
    if mx == 0.0:
        return mx
    # one frexp: mx = m·2^e exactly, so m / mx is 2^-e exactly (ldexp(1.0, -e) without
    # calling it), and mx / DBL_MIN (exact) has the same m
    m, e = math.frexp(mx)
    if e < -1021:  # subnormal: CPython divides by DBL_MIN first
        dmin = 2.2250738585072014e-308
        scale = m / (mx / dmin)
        return dmin * (_hypot_core(ax / dmin, ay / dmin, scale) / scale)
    scale = m / mx
    h = _hypot_core(ax, ay, scale)
    if e < 1024:  # h / 2^-e is h · 2^e (both exact scalings, one rounding): 2^e = mx / m
        return h * (mx / m)
    return h / scale  # (2^1024 overflows)


@kernel
def math_hypot(x: float, y: float) -> float:
    """``math.hypot`` (the plain-Python twin's `cpython_hypot`: `HYPOT_SUBS`)."""
    return math.hypot(x, y)


#: the substitution that makes a kernel's plain-Python twin call ``math.hypot``
#: (`rtsim.world.jit.specialise`)
HYPOT_SUBS: Subs = ((cpython_hypot, math_hypot),)


@kernel
def cpython_remainder(x: float, y: float) -> float:
    """CPython's ``math.remainder`` (its m_remainder) for finite ``y`` ≠ 0: x − n·y with n the
    integer nearest x / y, ties to even, computed exactly with fmod (``%`` of non-negative
    operands, which is fmod; fmod(|x|, |y|) is |x| itself when |x| < |y|, a bearing's
    change within a turn: no call then)."""
    if math.isnan(x):
        return x
    absx, absy = abs(x), abs(y)
    m = absx if absx < absy else absx % absy
    c = absy - m
    if m < c:
        r = m
    elif m > c:
        r = -c
    else:
        r = m - 2.0 * ((0.5 * (absx - m)) % absy)
    return math.copysign(1.0, x) * r
