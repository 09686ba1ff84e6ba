"""The world's numba kernels, as plain Python kernel sources (`rtsim.world.jit`): the
follow-the-leader law's search and projection, CPython's hypot and remainder
(`rtsim.world.compiled` for the classes that call them and why the results are bit for bit
the Python ones). The motion and the EKF are the world's own functions
(`rtsim.world.motion`, `rtsim.world.ekf`), compiled with the kernels that call them; the
controller's kernels, which call these, are in `rtsim.control.kernels`.

`kernels` compiles `ENTRIES` (or loads them from the cache) once per process;
numba is imported only then.
"""

from __future__ import annotations

import math
import sys
import types
from collections.abc import Iterable
from typing import Any

import numpy as np

from rtsim.world.ekf import ekf_command, ekf_predict, ekf_update
from rtsim.world.ftl import _BISECT, _NEWTON, _NEWTON_REACH, _SCALE_MIN, FTL_STEP
from rtsim.world.jit import Subs, build, cached, kernel
from rtsim.world.motion import follower_advance
from rtsim.world.path import along

__all__ = ["announce", "available", "follow_with", "kernels"]

_KERNELS: Any = None
_AVAILABLE: bool | None = None


def available() -> bool:
    """Whether numba can be imported (the compiled backend can run)."""
    global _AVAILABLE
    if _AVAILABLE is None:
        try:
            import numba  # noqa: F401
        except Exception:  # ImportError, or a numba that does not fit this numpy
            _AVAILABLE = False
        else:
            _AVAILABLE = True
    return _AVAILABLE


# -- the kernels, as plain Python (numba compiles them; the names are what they call) ---------


@kernel
def _index(s0: Any, lap: float, s: float) -> tuple[int, float]:
    """LeaderPath's segment index at arc length s (bisect_right − 1) and u = s mod lap."""
    u = s % lap
    lo, hi = 0, s0.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if u < s0[mid]:
            hi = mid
        else:
            lo = mid + 1
    return lo - 1, u


@kernel
def _point(
    s0: Any, poses: Any, kappa: Any, lap: float, o: float, s: float
) -> tuple[float, float, float]:
    """TraceFollower.point: LeaderPath.pose(s) moved ``o`` to the left."""
    x, y, h = _pose(s0, poses, kappa, lap, s)
    return x - o * math.sin(h), y + o * math.cos(h), h


@kernel
def _scale(s0: Any, kappa: Any, lap: float, o: float, s: float) -> float:
    k, _ = _index(s0, lap, s)
    return max(_SCALE_MIN, 1.0 - kappa[k] * o)


@kernel
def _gap(
    s0: Any,
    poses: Any,
    kappa: Any,
    lap: float,
    o: float,
    s: float,
    xl: float,
    yl: float,
    rho2: float,
) -> float:
    x, y, _ = _point(s0, poses, kappa, lap, o, s)
    return (x - xl) ** 2 + (y - yl) ** 2 - rho2


@kernel
def _search(
    s0: Any,
    poses: Any,
    kappa: Any,
    lap: float,
    o: float,
    s: float,
    s_l: float,
    xl: float,
    yl: float,
    rho: float,
) -> float:
    """TraceFollower._search (``s`` the last reference, NaN for none); returns s_ref."""
    rho2 = rho * rho
    if not math.isnan(s) and s <= s_l:
        s_n = s
        for _ in range(_NEWTON):
            x, y, h = _point(s0, poses, kappa, lap, o, s_n)
            dx, dy = x - xl, y - yl
            dg = 2.0 * (dx * math.cos(h) + dy * math.sin(h)) * _scale(s0, kappa, lap, o, s_n)
            if dg > -1e-6 * rho:
                break
            step = (dx * dx + dy * dy - rho2) / dg
            s_n -= step
            if abs(s_n - s) > _NEWTON_REACH or s_n > s_l:
                break
            if abs(step) < 1e-9:
                return s_n
    limit = int(lap / FTL_STEP) + 2
    if math.isnan(s) or s > s_l:
        s = s_l
    lo = hi = s
    if _gap(s0, poses, kappa, lap, o, s, xl, yl, rho2) > 0.0:
        lo = s
        for _ in range(limit):
            hi = min(lo + FTL_STEP, s_l)
            if _gap(s0, poses, kappa, lap, o, hi, xl, yl, rho2) <= 0.0 or hi >= s_l:
                break
            lo = hi
    else:
        hi = s
        for _ in range(limit):
            lo = hi - FTL_STEP
            if _gap(s0, poses, kappa, lap, o, lo, xl, yl, rho2) > 0.0:
                break
            hi = lo
    for _ in range(_BISECT):
        mid = 0.5 * (lo + hi)
        if _gap(s0, poses, kappa, lap, o, mid, xl, yl, rho2) > 0.0:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-7:
            break
    return 0.5 * (lo + hi)


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


@kernel
def _hypot_core(ax: float, ay: float, mx: float) -> float:
    _, e = math.frexp(mx)
    scale = math.ldexp(1.0, -e)
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
    h += v / (2.0 * h)
    return h / scale


@kernel
def _hypot(x: float, y: float) -> float:
    """CPython's ``math.hypot`` of two coordinates (its vector_norm: scaled by a power of
    two, the squares summed with their exact errors, a square root and one differential
    correction); `kernels` checks it against ``math.hypot`` before a kernel uses it."""
    ax, ay = abs(x), abs(y)
    if math.isnan(ax) or math.isnan(ay):
        return math.nan
    mx = ax if ax > ay else ay
    if math.isinf(mx) or mx == 0.0:
        return mx
    _, e = math.frexp(mx)
    if e < -1021:  # subnormal: CPython divides by DBL_MIN first
        dmin = 2.2250738585072014e-308
        return dmin * _hypot_core(ax / dmin, ay / dmin, mx / dmin)
    return _hypot_core(ax, ay, mx)


@kernel
def _pose(s0: Any, poses: Any, kappa: Any, lap: float, s: float) -> tuple[float, float, float]:
    """LeaderPath.pose(s)."""
    k, u = _index(s0, lap, s)
    return along(poses[k, 0], poses[k, 1], poses[k, 2], kappa[k], u - s0[k])


@kernel
def _project(
    s0: Any, poses: Any, kappa: Any, lap: float, o: float, s: float, x: float, y: float
) -> float:
    """TraceFollower.project's Newton steps from ``s`` on the offset-``o`` trace."""
    for _ in range(6):
        px, py, h = _point(s0, poses, kappa, lap, o, s)
        ds = ((x - px) * math.cos(h) + (y - py) * math.sin(h)) / _scale(s0, kappa, lap, o, s)
        s += ds
        if abs(ds) < 1e-3:
            break
    return s


@kernel
def _ftl_exact(
    s0: Any,
    poses: Any,
    kappa: Any,
    lap: float,
    lateral: Any,
    ahead: Any,
    spacing: Any,
    s_ref: Any,
    s_f: Any,
    gain: float,
    lookahead: float,
    k: int,
    s_l: float,
    xl: float,
    yl: float,
    hl: float,
    v_l: float,
    x: float,
    y: float,
    th: float,
) -> tuple[float, float]:
    """TraceFollower.command whole (with `_hypot`): (v, ω); updates s_ref, s_f."""
    chain = np.empty(ahead.shape[0] + 1, dtype=np.int64)
    m = 0
    j = k
    while j >= 0:
        chain[m] = j
        m += 1
        j = ahead[j]
    s_t, tx, ty, th_t, v_t = s_l, xl, yl, hl, v_l
    v_ref = v_l
    for c in range(m - 1, -1, -1):
        q = chain[c]
        o = lateral[q]
        sr = _search(s0, poses, kappa, lap, o, s_ref[q], s_t, tx, ty, spacing[q])
        s_ref[q] = sr
        px, py, hp = _point(s0, poses, kappa, lap, o, sr)
        dx, dy = tx - px, ty - py
        den = dx * math.cos(hp) + dy * math.sin(hp)
        if den <= 0.1 * _hypot(dx, dy):
            v_ref = v_t
        else:
            v_ref = v_t * (dx * math.cos(th_t) + dy * math.sin(th_t)) / den
        if c > 0:
            tx, ty, th_t = _point(s0, poses, kappa, lap, o, sr)
            s_t, v_t = sr, v_ref
    o = lateral[k]
    sf = s_f[k]
    if math.isnan(sf):
        sf = s_ref[k]
    sf = _project(s0, poses, kappa, lap, o, sf, x, y)
    s_f[k] = sf
    v = v_ref + gain * (s_ref[k] - sf) * _scale(s0, kappa, lap, o, sf)
    if not v > 0.0:
        v = 0.0
    ahead_s = sf + lookahead
    if s_l < ahead_s:
        ahead_s = s_l
    gx, gy, _ = _point(s0, poses, kappa, lap, o, ahead_s)
    dx, dy = gx - x, gy - y
    dist = _hypot(dx, dy)
    if dist < 1e-9:
        return v, 0.0
    alpha = math.atan2(dy, dx) - th
    return v, v * 2.0 * math.sin(alpha) / dist


@kernel
def _remainder(x: float, y: float) -> float:
    """CPython's ``math.remainder`` (its m_remainder) for finite ``y`` ≠ 0: x − n·y with n the
    integer nearest x / y, ties to even, computed exactly with fmod (``%`` of non-negative
    operands, which is fmod)."""
    if math.isnan(x):
        return x
    absx, absy = abs(x), abs(y)
    m = absx % absy
    c = absy - m
    if m < c:
        r = m
    elif m > c:
        r = -c
    else:
        r = m - 2.0 * ((0.5 * (absx - m)) % absy)
    return math.copysign(1.0, x) * r


#: the kernels the classes call, by the name they have in `kernels`'s namespace (each
#: compiled with the kernel sources it calls: `rtsim.world.jit.build`)
ENTRIES: dict[str, Any] = {
    "advance_follower": follower_advance,
    "ekf_command": ekf_command,
    "ekf_predict": ekf_predict,
    "ekf_update": ekf_update,
    "ftl_exact": _ftl_exact,
    "project": _project,
    "hypot": _hypot,
    "remainder": _remainder,
}

#: the entries that run a motion model's parts (built again for a model other than the
#: unicycle: `kernels`)
MOTION_ENTRIES = ("advance_follower", "ekf_command")

#: about how long compiling `ENTRIES` takes, CPU s on a 2-core machine (numba 0.68; measured
#: with a fresh NUMBA_CACHE_DIR, docs/performance.md)
COMPILE_S = 4.0

_ANNOUNCED = False
#: kernel sources compiled right after these as a rule, with their time (`follow_with`)
_FOLLOWERS: list[tuple[tuple[Any, ...], float]] = []


def follow_with(sources: Iterable[Any], seconds: float) -> None:
    """Count kernel ``sources`` that most runs compile right after the world's (the
    controller's rollout, ``seconds`` to compile) in the world's announcement when they are
    not cached either (`announce` speaks once per process)."""
    _FOLLOWERS.append((tuple(sources), seconds))


def announce(sources: Iterable[Any], seconds: float, subs: Subs = ()) -> bool:
    """Say on stderr, in one line and once per process, that the kernels are being compiled
    (once per install, about ``seconds``), when any of the kernel ``sources`` (with
    ``subs``) has no build in the cache and progress is shown
    (`rtsim.sim.progress.progress_enabled`: a terminal, or ``RTSIM_PROGRESS=1``); nothing
    when they load from the cache. Returns whether it said so."""
    global _ANNOUNCED
    if _ANNOUNCED or all(cached(fn, subs) for fn in sources):
        return False
    _ANNOUNCED = True  # (asked once: a later group compiles under the same line)
    from rtsim.sim.progress import progress_enabled  # lazy: rtsim.sim loads simpy

    if not progress_enabled():
        return False
    from tqdm.auto import tqdm

    line = f"rtsim: compiling the world's kernels (once per install, about {seconds:.0f} s)..."
    tqdm.write(line, file=sys.stderr)  # (above a progress bar that is open, on a line of its own)
    sys.stderr.flush()
    return True


_BY_MODEL: dict[Subs, Any] = {}


def kernels(motion: Any = None) -> Any:
    """The compiled kernels (a namespace), compiled or loaded from the cache once per
    process (saying so when they compile: `announce`, with the time of the kernels that
    follow (`follow_with`) when those are not cached either). ``motion``: a motion model
    (`rtsim.world.motionmodels.MotionModel`; None: the unicycle) whose parts the
    `MOTION_ENTRIES` run (the others are the unicycle's namespace's)."""
    global _KERNELS
    if _KERNELS is None:
        if not all(cached(fn) for fn in ENTRIES.values()):
            later = sum(s for fns, s in _FOLLOWERS if not all(cached(fn) for fn in fns))
            announce(ENTRIES.values(), COMPILE_S + later)
        ns = types.SimpleNamespace(**{name: build(fn) for name, fn in ENTRIES.items()})
        _warm(ns)
        ns.exact_hypot = _hypot_matches(ns.hypot)
        _KERNELS = ns
    subs: Subs = () if motion is None else motion.subs
    if not subs:
        return _KERNELS
    model_ns = _BY_MODEL.get(subs)
    if model_ns is None:
        swap = dict(subs)
        sources = [swap.get(ENTRIES[name], ENTRIES[name]) for name in MOTION_ENTRIES]
        announce(sources, COMPILE_S, subs)
        model_ns = types.SimpleNamespace(**vars(_KERNELS))
        for name, fn in zip(MOTION_ENTRIES, sources, strict=True):
            setattr(model_ns, name, build(fn, subs))
        model_ns.subs = subs
        _warm(model_ns)
        _BY_MODEL[subs] = model_ns
    return model_ns


def _hypot_matches(fn: Any, count: int = 20000) -> bool:
    """Whether the compiled hypot gives this interpreter's ``math.hypot`` bit for bit on
    ``count`` random pairs over the whole exponent range and the edge cases (a kernel that
    needs a hypot is only used when it does)."""
    rng = np.random.default_rng(20261124)
    a = rng.standard_normal((count, 2)) * 10.0 ** rng.integers(-30, 30, (count, 2))
    edge = [
        (0.0, 0.0),
        (0.0, -3.0),
        (3.0, 4.0),
        (1e-320, 3e-321),
        (1e308, 1e308),
        (5e-324, 0.0),
        (1.0, 1e-17),
        (-0.0, 2.5),
        (325.0, 325.0),
    ]
    pairs = [*edge, *map(tuple, a.tolist())]
    return all(fn(x, y) == math.hypot(x, y) for x, y in pairs)


def _warm(ns: Any) -> None:
    """Call every kernel once on dummy values, so that compiling it (the first time on a
    machine) or loading it from numba's cache happens when the world is built, not inside
    the first window."""
    ns.advance_follower(0.0, 0.0, 0.0, 1.0, 0.0, 2.0, 0.1, 10.0, 0.0, 0.0, 20.0, 10.0)
    ns.ekf_command(*([1.0] * 19))
    ns.ekf_predict(*([1.0] * 16))
    ns.ekf_update(*([1.0] * 15))
    one = np.zeros(1)
    ns.ftl_exact(
        np.zeros(1),
        np.zeros((1, 3)),
        np.zeros(1),
        100.0,
        one,
        np.full(1, -1),
        np.ones(1),
        np.full(1, math.nan),
        np.full(1, math.nan),
        0.5,
        10.0,
        0,
        50.0,
        50.0,
        0.0,
        0.0,
        1.0,
        0.0,
        0.0,
        0.0,
    )
    ns.project(np.zeros(1), np.zeros((1, 3)), np.zeros(1), 100.0, 0.0, 10.0, 20.0, 1.0)
    # (the rollout's kernels: rtsim.control.kernels, when a run first rolls out)
