"""The world's numba kernels: the entries the compiled classes call (`rtsim.world.compiled`
says why the results are bit for bit the Python ones), each the world's own kernel source
(`rtsim.world.jit`) compiled with those it calls — the motion (`rtsim.world.motion`), the
EKF (`rtsim.world.ekf`), the follow-the-leader law (`rtsim.world.ftl`), CPython's hypot
and remainder (`rtsim.world.exactmath`). The controller's kernels, which call these, are in
`rtsim.control.kernels`.

`kernels` compiles `ENTRIES` (or loads them from the cache) once per process, and each of
`LAZY_ENTRIES` when it is first read; numba is imported only then.
"""

from __future__ import annotations

import math
import sys
import types
from collections.abc import Iterable
from typing import Any

import numpy as np

from rtsim.world.ekf import ekf_command, ekf_predict, ekf_update
from rtsim.world.estimates import (
    est_carry,
    est_command_ftl,
    est_hold,
    est_scan,
    new_estimates,
)
from rtsim.world.exactmath import cpython_hypot, cpython_remainder
from rtsim.world.ftl import ftl_command, ftl_project, ftl_reference, trace_point
from rtsim.world.jit import Subs, build, cached
from rtsim.world.motion import (
    GROUP_ROWS,
    belief_step,
    follower_advance,
    group_advance,
    leader_travel,
    world_advance,
)

__all__ = ["announce", "available", "built_entry", "entry", "follow_with", "kernels"]

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


def entry(fn: Any, args: tuple[Any, ...]) -> Any:
    """The compiled function that numba's dispatcher ``fn`` runs for arguments typed as
    ``args``, to be called directly: a dispatcher types every argument at every call, and
    a tuple of arrays (the law's geometry, a rollout's pack) it types in Python, ≈ 2–4 µs
    a call (`ftl_command`: ≈ 5 µs through the dispatcher, ≈ 2 µs without). The same
    machine code, so the same numbers. Only for a caller whose arguments keep those types
    at every call (an array of another dtype, dimension or layout would be misread: the
    callers here build theirs once, with their dtypes); ``fn`` itself when it is not a
    dispatcher (the Python twins, a benchmark's timing wrapper) or has no build for those
    types yet (its first call compiles one)."""
    overloads = getattr(fn, "overloads", None)
    if overloads is None:
        return fn
    key = _type_key(args)
    if key is not None:
        found = _BUILT.get((fn, key))
        if found is not None:
            return found
    typed = None if key is None else _TYPED.get((fn, key))
    if typed is None:
        typed = tuple(fn.typeof_pyval(a) for a in args)
        if key is not None:
            _TYPED[(fn, key)] = typed
    built = overloads.get(typed)
    if built is None:
        return fn
    if key is not None:
        _BUILT[(fn, key)] = built.entry_point
    return built.entry_point


def built_entry(fn: Any, args: tuple[Any, ...]) -> Any:
    """`entry` of ``fn`` for ``args``' types after compiling (or loading from the cache) its
    build for them, without running it (a no-op when it has that build; ``fn`` itself when
    it is not a dispatcher; a sweep's next point finds the build by `_TYPED`, not typing
    its arguments again: ≈ 0.5 ms a call)."""
    overloads = getattr(fn, "overloads", None)
    if overloads is None:
        return fn
    key = _type_key(args)
    if key is not None:  # (a build found once stays the dispatcher's for those types:
        found = _BUILT.get((fn, key))  # `entry`'s, without typing or keying again)
        if found is not None:
            return found
    typed = None if key is None else _TYPED.get((fn, key))
    if typed is None or typed not in overloads:
        fn.compile(tuple(map(fn.typeof_pyval, args)))
    return entry(fn, args)


#: numba's types of `entry`'s arguments, by the dispatcher and `_type_key` of the
#: arguments: a world made again (a sweep's next point) looks its builds up without typing
#: its arrays again (≈ 0.8 ms of a Test 2 lap's set-up); the build itself is looked up at
#: every call, so a build compiled later is found
_TYPED: dict[tuple[Any, Any], tuple[Any, ...]] = {}
#: ... and the compiled function found for them, once there is one (a build, once made, is
#: the dispatcher's for those types: looking it up again hashed numba's types, ≈ 20 per
#: argument)
_BUILT: dict[tuple[Any, Any], Any] = {}


def _type_key(a: Any) -> Any:
    """What numba's ``typeof`` reads of an argument of `entry` (its Python type; an int's
    size; an array's dtype, dimensions, layout, writability and alignment; a tuple's
    items'), or None for a value it does not cover (typed every time)."""
    t = type(a)
    if t is float or t is bool:
        return t
    if t is int:
        return t if a.bit_length() < 32 else None  # (numba's intp)
    if t is np.ndarray:  # (the flags as one int: C, F contiguous, aligned, writeable)
        return (t, a.dtype, a.ndim, a.flags.num & _LAYOUT)
    if t is tuple:  # (map, not a generator: ≈ 2× faster on a world's argument tuples)
        keys = tuple(map(_type_key, a))
        return None if None in keys else keys
    return None


#: the bits of ``ndarray.flags.num`` numba's ``typeof`` reads (numpy's C API, stable):
#: NPY_ARRAY_C_CONTIGUOUS, F_CONTIGUOUS, ALIGNED, WRITEABLE
_LAYOUT = 0x0001 | 0x0002 | 0x0100 | 0x0400


#: the kernels the classes call, by the name they have in `kernels`'s namespace (each
#: compiled with the kernel sources it calls: `rtsim.world.jit.build`)
ENTRIES: dict[str, Any] = {
    "advance_group": group_advance,
    "advance_world": world_advance,
    "hypot": cpython_hypot,
    "leader_travel": leader_travel,
    "est_carry": est_carry,
    "est_command_ftl": est_command_ftl,
}

#: the entries compiled (or loaded) only when first read from the namespace: the
#: estimates' scan, which the fused scan runs inside its own kernel (`rtsim.world.scanstep`:
#: only a world whose scan does not fuse calls it); the law's reference and trace point,
#: which a world reads only while it is set up (by their Python twins:
#: `rtsim.world.compiled.CompiledTraceFollower.initial`; inside the estimates' and the
#: rollout's kernels they are compiled anyway); the EKF's
#: predict without a command, which the shipped scenarios never run; the remainder, which
#: only kernels call (`rtsim.control.kernels.warm_all` builds them too); one filter's
#: steps, one piece of the belief, the law's command and the record of a held command,
#: which the compiled world runs inside its estimates' kernels (`rtsim.world.estimates`:
#: `est_command_ftl` holds the command the law gives), the law's projection, which the
#: truth log runs inside its own (`rtsim.coupling.physical`), and only a filter or a law driven on
#: its own calls (each an entry of its own only then: inside the kernels that call it, it
#: is compiled without numba's wrappers, not optimised nor emitted on its own,
#: `rtsim.world.jit`)
LAZY_ENTRIES: dict[str, Any] = {
    "advance_follower": follower_advance,
    "est_scan": est_scan,
    "ftl_reference": ftl_reference,
    "trace_point": trace_point,
    "ekf_predict": ekf_predict,
    "ftl_command": ftl_command,
    "ftl_project": ftl_project,
    "est_hold": est_hold,
    "remainder": cpython_remainder,
    "ekf_command": ekf_command,
    "ekf_update": ekf_update,
    "belief_step": belief_step,
}

#: the lazy entries that run a motion model's parts (built with its substitutions)
LAZY_MOTION = ("ekf_command", "belief_step", "advance_follower", "est_scan")

#: the entries that run a motion model's parts (built again for a model other than the
#: unicycle: `kernels`)
MOTION_ENTRIES = (
    "advance_group",
    "advance_world",
    "leader_travel",
    "est_carry",
    "est_command_ftl",
)

#: about how long compiling `ENTRIES` takes, CPU s on a 2-core machine (numba 0.68; measured
#: with a fresh NUMBA_CACHE_DIR, docs/performance.md: the first run's 11.4 s less the cached
#: run's 1.9 s, less the rollout's `rtsim.control.kernels.COMPILE_S`, with the scan's kernel)
COMPILE_S = 4.5

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


class _Namespace(types.SimpleNamespace):
    """The kernels by name; a name of `LAZY_ENTRIES` is built when it is first read."""

    def __getattr__(self, name: str) -> Any:
        fn = LAZY_ENTRIES.get(name)
        if fn is None:
            raise AttributeError(name)
        subs: Subs = vars(self).get("subs", ()) if name in LAZY_MOTION else ()
        built = build(dict(subs).get(fn, fn), subs)  # (a part the model replaces: its own)
        setattr(self, name, built)
        return built


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
        ns = _Namespace(**{name: build(fn) for name, fn in ENTRIES.items()})
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
        base = {k: v for k, v in vars(_KERNELS).items() if k not in LAZY_MOTION}
        model_ns = _Namespace(**base)
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
    S = np.zeros((len(GROUP_ROWS), 1))
    ns.advance_group(S, 0, 1, 20.0, 10.0, 10.0)
    seg = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0])  # (x, y, heading, cos, sin, curvature)
    G = (np.zeros(1), seg, 100.0, np.array([0.0, -1.0, 1.0]))  # (path.geometry_arrays)
    ns.advance_world(S, 1, 30.0, 10.0, 10.0, 1.0, 2.0, 10.0, 10.0, 0.01, 0.0, G)
    nan1 = np.full(1, math.nan)
    ns.leader_travel(1.0, 2.0, 10.0, 10.0, 0.02)
    E = new_estimates(1)
    E[0, 3] = E[0, 7] = E[0, 11] = E[0, 14] = 1.0
    ns.est_carry(E, 0, 20.0, 1.0, np.empty((1, 7)))
    ns.est_command_ftl(
        0, 30.0, 0.0, 1.0, 2.0, 0.01, 0.0, 0.0, E, 1.0, G, nan1, nan1.copy(), 0.5, 10.0, 1.0,
        1.0, 0.5, 0.1, S, 10.0, 10.0, 10.0,
    )  # fmt: skip
    # (the rollout's kernels: rtsim.control.kernels, when a run first rolls out)
