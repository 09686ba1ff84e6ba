"""`rtsim.world.kernels.entry`: a kernel called through its compiled function, not its
dispatcher — the same numbers, and the dispatcher kept wherever the types are not built."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtsim.config.scenario import load_scenario
from rtsim.world import World
from rtsim.world.ftl import ftl_project
from rtsim.world.hough import Accumulator
from rtsim.world.kernels import available, entry, kernels
from rtsim.world.rangefinder import Rangefinder

pytestmark = pytest.mark.skipif(not available(), reason="numba is not installed")


def test_entry_is_the_dispatchers_build_or_the_dispatcher() -> None:
    """Built types: the build's entry point, which gives the dispatcher's results on random
    arguments; types without a build, or a plain function: the argument itself."""
    law = World(load_scenario("test2").world, np.random.default_rng(0)).follow_law
    assert law is not None
    assert not hasattr(law._project, "overloads")  # (a lazy entry: built at its first read)
    disp = kernels().ftl_project
    G = law._G
    direct = entry(disp, (G, 0, 0.0, 0.0, 0.0))
    assert direct is not disp and not hasattr(direct, "overloads")
    rng = np.random.default_rng(5)
    for _ in range(200):
        k = int(rng.integers(0, 2))
        s, x, y = (rng.random(3) * [2000.0, 600.0, 600.0]).tolist()
        assert direct(G, k, s, x, y) == disp(G, k, s, x, y)
    unbuilt = (G, 0, np.float32(1.0), 0.0, 0.0)  # (a float32 s: no build for it)
    assert entry(disp, unbuilt) is disp
    assert entry(ftl_project, (G, 0, 0.0, 0.0, 0.0)) is ftl_project


def test_the_compiled_worlds_calls_go_direct() -> None:
    """The compiled world's law, rangefinder and Hough accumulator hold the builds' entry
    points (the Python world its plain functions); both give the same fixes on a scan."""
    cfg = load_scenario("test2").world
    fast = World(cfg, np.random.default_rng(3))
    law = fast.follow_law
    assert law is not None
    filters = [f._predict for f in fast.filters] + [f._update for f in fast.filters]
    filters += [f._command for f in fast.filters] + [fast.followers._advance]
    assert fast._fused is not None  # (the scan: one compiled call, `rtsim.world.scanstep`)
    for fn in (law._command, law._project, law._reference, fast._fused._step, *filters):
        assert not hasattr(fn, "overloads") and not hasattr(fn, "__code__")
    assert not hasattr(Rangefinder(25.0, 300.0, 1.0, True)._fn, "__code__")
    assert hasattr(Rangefinder(25.0, 300.0, 1.0, False)._fn, "__code__")
    acc = Accumulator(2, 25.0, 30.0, True)
    ref = Accumulator(2, 25.0, 30.0, False)
    assert hasattr(ref._every, "__code__") and acc._every is None  # (built at its first call)
    a = np.linspace(0.0, math.pi, 40)
    px, py = 150.0 + 25.0 * np.cos(a), 25.0 * np.sin(a)
    owner = np.zeros(40, dtype=np.int64)
    cx, cy = np.array([150.0, 0.0]), np.array([3.0, 80.0])
    got = acc.locate(px, py, owner, cx, cy, 20.0).tolist()
    assert got[0][2] > 0 and math.isnan(got[1][0])  # a peak in the first, none in the second
    assert repr(got) == repr(ref.locate(px, py, owner, cx, cy, 20.0).tolist())  # (NaN too)
    assert not hasattr(acc._every, "overloads") and not hasattr(acc._every, "__code__")


def test_entry_types_a_changed_argument_again() -> None:
    """The types `entry` keeps per dispatcher and argument kinds (a sweep's next world) are
    numba's own typing of the same arguments, and an argument whose dtype, dimensions,
    layout, writability, int size or tuple shape changed is typed again, not served the kept
    types (`_type_key`)."""
    from rtsim.world.kernels import _BUILT, _TYPED, _type_key

    disp = kernels().hypot
    a = np.zeros(4)
    ro = np.zeros(4)
    ro.flags.writeable = False
    variants = [
        (0.0, 0.0),
        (a, 0.0),
        (a.astype(np.float32), 0.0),
        (np.zeros((2, 2)), 0.0),
        (np.zeros((4, 4))[:, 0], 0.0),  # strided: layout A
        (np.zeros((4, 4), order="F"), 0.0),
        (ro, 0.0),
        (np.frombuffer(bytearray(40), dtype=np.float64, count=4, offset=1), 0.0),  # unaligned
        ((a, a), 1),
        ((a, a, a), 1),
        (True, 1),
    ]
    keys = [_type_key(v) for v in variants]
    assert len(set(keys)) == len(keys) and None not in keys
    assert _type_key((2**40,)) is None and _type_key(([1.0],)) is None  # typed every time
    # (whether it owns its data is not read: a C-contiguous view has its owner's key)
    assert _type_key((np.zeros((2, 4))[1], 0.0)) == keys[1]
    for v in variants:
        entry(disp, v)
        entry(disp, v)  # (the second from the kept types)
        typed = _TYPED[(disp, _type_key(v))]
        assert typed == tuple(disp.typeof_pyval(x) for x in v)
        # (a build found is kept: the same machine code as the dispatcher's for them)
        built = disp.overloads.get(typed)
        kept = _BUILT.get((disp, _type_key(v)))
        assert kept is (None if built is None else built.entry_point)
    # a build looked up at every call: the kept types of an unbuilt signature find no build
    unbuilt = (np.float32(1.0), 0.0)
    assert entry(disp, unbuilt) is disp and (disp, _type_key(unbuilt)) not in _BUILT


def test_built_entry_compiles_only_a_signature_it_has_not_built(monkeypatch) -> None:
    """`built_entry` asks numba to compile only when the arguments' types have no build yet
    (a sweep's next point finds its builds by the kept types, without typing again), and
    returns the build's entry either way."""
    import numba

    from rtsim.world.kernels import built_entry

    disp = numba.njit(lambda x, y: x + y)  # (a dispatcher of its own: no build yet)
    calls: list[object] = []
    real = disp.compile
    monkeypatch.setattr(disp, "compile", lambda sig: calls.append(sig) or real(sig))
    first = built_entry(disp, (1.0, 2.0))
    assert len(calls) == 1 and first is not disp and first(1.0, 2.0) == 3.0
    assert built_entry(disp, (1.0, 2.0)) is first and len(calls) == 1  # (kept: no compile)
    other = built_entry(disp, (np.zeros(2), 2.0))  # (other types: compiled, then its entry)
    assert len(calls) == 2 and other is not first and other(np.ones(2), 2.0).tolist() == [3.0, 3.0]
