"""numpy's standard normals drawn in compiled code: the same numbers, in the same order, as
``numpy.random.Generator(PCG64).standard_normal`` (docs/performance.md).

A world's laser noise is 361 standard normals a scan from its generator. numpy draws them
with its PCG64 bit generator and its ziggurat (``random_standard_normal``); `standard_normals`
writes both out as a kernel source — the 128-bit step of pcg64.h in 64-bit halves (its
emulated path), the XSL RR output, numpy's ziggurat with its own tables
(`rtsim.world.ziggurat`) — so the scan's kernel draws its noise itself instead of taking a
block numpy drew ahead. The generator's state lives in a `PCGState` array of four uint64
(state high, low, increment high, low) that `state_of` reads from a ``PCG64`` and
`set_state` writes back, so numpy and the kernel can take turns on one stream.

The Python run of the kernel source is the reference the tests compare with numpy's own
draws (the compiled run must match both); its uint64 products wrap, as C's do, so a Python
caller runs it under ``numpy.errstate(over="ignore")``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rtsim.world.jit import kernel
from rtsim.world.ziggurat import FI, KI, NOR_INV_R, NOR_R, WI

__all__ = ["PCGState", "pcg64_next", "set_state", "standard_normals", "state_of"]

#: a PCG64's state as `standard_normals` reads it: uint64 (state high, low, inc high, low)
PCGState = NDArray[np.uint64]

_U = np.uint64
M32 = _U(0xFFFFFFFF)
M8 = _U(0xFF)
M52 = _U(0x000FFFFFFFFFFFFF)
#: pcg64.h's PCG_DEFAULT_MULTIPLIER_128, high and low halves, and the low half's 32-bit limbs
MUL_HI = _U(2549297995355413924)
MUL_LO = _U(4865540595714422341)
MUL_LO0 = MUL_LO & M32
MUL_LO1 = MUL_LO >> _U(32)
ZERO, ONE = _U(0), _U(1)
S8, S11, S32, S58, S63, S64 = _U(8), _U(11), _U(32), _U(58), _U(63), _U(64)
#: next_double's scale: the top 53 bits of a draw as a double in [0, 1)
TO_DOUBLE = 1.0 / 9007199254740992.0
#: the ziggurat's tables as arrays (numba keeps them as constants of the code)
KI_A = np.array(KI, dtype=np.uint64)
WI_A = np.array(WI, dtype=np.float64)
FI_A = np.array(FI, dtype=np.float64)
_TWO64 = 1 << 64


@kernel
def pcg64_next(sh: Any, sl: Any, ih: Any, il: Any) -> tuple[Any, Any, Any]:
    """numpy's PCG64 step from state (``sh``, ``sl``) with increment (``ih``, ``il``) (pcg64.h:
    state · multiplier + increment mod 2^128, with the 64×64 → 128-bit product of the low
    halves in 32-bit limbs) and its output (XSL RR): the new state's halves and the uint64."""
    x0 = sl & M32
    x1 = sl >> S32
    w0 = x0 * MUL_LO0
    t = x1 * MUL_LO0 + (w0 >> S32)
    w1 = (t & M32) + x0 * MUL_LO1
    hi = x1 * MUL_LO1 + (t >> S32) + (w1 >> S32) + (sh * MUL_LO + sl * MUL_HI)
    lo = sl * MUL_LO + il
    hi = hi + ih + (ONE if lo < il else ZERO)
    v = hi ^ lo
    rot = hi >> S58
    return hi, lo, (v >> rot) | (v << ((S64 - rot) & S63))


@kernel
def standard_normals(G: Any, out: Any, m: int) -> None:
    """The next ``m`` standard normals of the PCG64 whose state is ``G`` (`PCGState`,
    advanced) into ``out[:m]``: numpy's ``random_standard_normal`` (its ziggurat: 8 bits of a
    draw pick the layer, one its sign, 52 its magnitude; the wedges and the tail rejected
    with further draws as numpy does)."""
    sh, sl, ih, il = G[0], G[1], G[2], G[3]
    for i in range(m):
        while True:
            sh, sl, r = pcg64_next(sh, sl, ih, il)
            idx = np.int64(r & M8)
            r = r >> S8
            rabs = (r >> ONE) & M52
            x = rabs * WI_A[idx]
            if r & ONE:
                x = -x
            if rabs < KI_A[idx]:
                break
            if idx == 0:  # the tail, 1.0 - U for U (numpy's)
                while True:
                    sh, sl, u = pcg64_next(sh, sl, ih, il)
                    xx = -NOR_INV_R * math.log1p(-((u >> S11) * TO_DOUBLE))
                    sh, sl, u = pcg64_next(sh, sl, ih, il)
                    yy = -math.log1p(-((u >> S11) * TO_DOUBLE))
                    if yy + yy > xx * xx:
                        break
                x = -(NOR_R + xx) if (rabs >> S8) & ONE else NOR_R + xx
                break
            sh, sl, u = pcg64_next(sh, sl, ih, il)
            d = (u >> S11) * TO_DOUBLE
            if (FI_A[idx - 1] - FI_A[idx]) * d + FI_A[idx] < math.exp(-0.5 * x * x):
                break
        out[i] = x
    G[0] = sh
    G[1] = sl


def state_of(bit_generator: np.random.BitGenerator, G: PCGState | None = None) -> PCGState:
    """``bit_generator``'s state (a ``PCG64``'s) as a `PCGState` (into ``G`` when given)."""
    st = bit_generator.state["state"]
    s, inc = int(st["state"]), int(st["inc"])
    if G is None:
        G = np.empty(4, dtype=np.uint64)
    G[0], G[1], G[2], G[3] = s >> 64, s & 0xFFFFFFFFFFFFFFFF, inc >> 64, inc & 0xFFFFFFFFFFFFFFFF
    return G


def set_state(bit_generator: np.random.BitGenerator, G: PCGState) -> None:
    """Set ``bit_generator``'s state (a ``PCG64``'s) to ``G`` (its buffered 32 bits kept as
    they are)."""
    state = dict(bit_generator.state)
    h, lo, ih, il = (int(v) for v in G)
    state["state"] = {"state": (h << 64 | lo) % _TWO64**2, "inc": (ih << 64 | il) % _TWO64**2}
    bit_generator.state = state
