"""The compiled backend's truth as arrays (`CompiledFollowerGroup.state`) and the scan's look
at it in one compiled call (`rtsim.world.scan.truth_look`) give the Python reference's
numbers bit for bit: the group's rows against the Python group's lists over whole runs, and
each scan's truth, changes, violations and fix errors against `World._changes` in Python.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from rtsim.config.scenario import load_scenario
from rtsim.world import compiled
from rtsim.world.follower import ROWS, FollowerGroup
from rtsim.world.world import World

needs_numba = pytest.mark.skipif(not compiled.available(), reason="numba is not importable")


def _bits(x: Any) -> str:
    """``x`` (floats, bools, nested in lists, tuples and dicts) as text that names every
    float exactly (``repr`` round-trips a float, -0.0 included): equal text, equal bits."""
    return repr(x)


def _worlds(n: int, overrides: dict[str, Any]) -> tuple[World, World]:
    over = {"formation.followers": n, **overrides}
    py = World(load_scenario("test2", overrides={**over, "world.backend": "python"}).world,
               np.random.default_rng(3))  # fmt: skip
    co = World(load_scenario("test2", overrides={**over, "world.backend": "compiled"}).world,
               np.random.default_rng(3))  # fmt: skip
    return py, co


def _fixes(scan: Any) -> list[Any]:
    """A scan's fixes as `World._changes` takes them (`rtsim.world.locmodels.Fix`)."""
    f = [scan.as_lists(k) for k in ("measured", "in_window", "lost", "searched", "reacquired")]
    nb = scan.neighbour
    return [
        (tuple(m), w, lo, s, r, nb[k]) for k, (m, w, lo, s, r) in enumerate(zip(*f, strict=True))
    ]


@needs_numba
@pytest.mark.parametrize(
    ("n", "overrides"),
    [
        (2, {}),
        (5, {"localization.model": "gaussian", "world.step_ms": 7.0}),
    ],
)
def test_truth_arrays_match_the_python_group(n: int, overrides: dict[str, Any]) -> None:
    """Python and compiled worlds in lockstep (scans, estimates, commands at uneven times):
    every row of the group (positions, headings, speeds, odometers, commands, times) and
    every scan's look (truth in the leader's frame, changes, violations, fix errors) the
    same floats; the compiled look also against `World._changes` run on its own scans."""
    py, co = _worlds(n, overrides)
    assert type(py.followers) is FollowerGroup
    assert isinstance(co.followers, compiled.CompiledFollowerGroup)
    assert co.followers.state.shape == (len(ROWS), n)
    rng = np.random.default_rng(11)
    t = 0.0
    shadow = World.__new__(World)  # (the Python reference's `_changes` state, on co's data)
    shadow._prev = None
    shadow._r_H, shadow._T_beta = co._r_H, co._T_beta
    shadow._sep_limit_l, shadow._travel_limit_l = co._sep_limit_l, co._travel_limit_l
    moved = 0.0
    for _ in range(120):
        t += float(rng.uniform(40.0, 120.0))
        a, b = py.scan(t), co.scan(t)
        for field in ("truth", "measured", "in_window", "lost", "reacquired", "points"):
            assert _bits(a.as_lists(field)) == _bits(b.as_lists(field)), field
        for field in ("changes", "violations"):
            assert _bits(a.as_lists(field)) == _bits(b.as_lists(field)), field
            assert {k: v.tolist() for k, v in getattr(b, field).items()} == a.as_lists(field)
        assert _bits(a.fix_error) == _bits(b.fix_error)
        _, errors, changes, viol = shadow._changes(
            b.as_lists("truth"), co.followers.values("odometer"), _fixes(b)
        )
        assert _bits(changes) == _bits(b.as_lists("changes"))
        assert viol == b.as_lists("violations")
        assert _bits(errors) == _bits(list(b.fix_error))
        for w, s in ((py, a), (co, b)):
            w.estimate(s)
        for name in ROWS:
            assert _bits(py.followers.values(name)) == _bits(co.followers.values(name)), name
        for i in rng.permutation(n) + 1:
            t += float(rng.uniform(0.0, 15.0))
            assert _bits(py.command(int(i), t)) == _bits(co.command(int(i), t))
        moved = sum(co.followers.values("odometer"))
    assert moved > 100.0 * n  # (the followers drove: the comparison saw real motion)
    assert _bits(py.state()) == _bits(co.state())
    for i in range(1, n + 1):
        assert _bits(py.relative(i)) == _bits(co.relative(i))


@needs_numba
def test_group_readers_get_floats_and_the_same_numbers() -> None:
    """`values`, `positions`, `states` and `pose` give plain floats on both classes."""
    py, co = _worlds(3, {})
    for w in (py, co):
        w.advance(250.0)
    for name in ROWS:
        a, b = py.followers.values(name), co.followers.values(name)
        assert all(type(v) is float for v in b) and _bits(a) == _bits(b)
    assert _bits(py.followers.positions()) == _bits(co.followers.positions())
    assert _bits(py.followers.states()) == _bits(co.followers.states())
    assert all(type(v) is float for row in co.followers.states() for v in row)
    assert _bits(py.followers.pose(1)) == _bits(co.followers.pose(1))
    lp = py.leader.pose
    rows = py.followers.relative_rows(lp), co.followers.relative_rows(lp)
    assert _bits([list(r) for r in rows[0]]) == _bits([list(r) for r in rows[1]])


@needs_numba
def test_relative_rows_kernel_is_relative_state() -> None:
    """`group_relative` (compiled) against `relative_state` on random poses and the wraps'
    edges: a follower on the leader's point (ρ = 0), headings a multiple of π apart."""
    rng = np.random.default_rng(5)
    p = load_scenario("test2").world.follower
    pi = math.pi
    for _ in range(200):
        n = 4
        x, y = rng.uniform(-300, 300, n), rng.uniform(-300, 300, n)
        th = rng.uniform(-20, 20, n)
        lp = (float(x[0]), float(y[0]), float(rng.choice([0.0, pi, -pi, 3 * pi, 1.3])))
        th[1] = lp[2] - pi
        th[2] = lp[2] + pi
        v = rng.uniform(0, 90, n)
        a, b = FollowerGroup(x, y, th, v, p), compiled.CompiledFollowerGroup(x, y, th, v, p)
        rows = a.relative_rows(lp), b.relative_rows(lp)
        assert _bits([list(r) for r in rows[0]]) == _bits([list(r) for r in rows[1]])


@needs_numba
def test_a_changed_state_is_refused_clearly() -> None:
    """The kernels are called for one dtype, shape and layout of the state array
    (`rtsim.world.kernels.entry`): another is refused with one line naming the field."""
    _, co = _worlds(2, {})
    fol = co.followers
    good = fol.state.copy()
    with pytest.raises(ValueError, match=r"followers\.state: .*float64.*\(9, 2\).*float32"):
        fol.state = good.astype(np.float32)
    with pytest.raises(ValueError, match=r"followers\.state: .*\(9, 3\)"):
        fol.state = np.zeros((9, 3))
    with pytest.raises(ValueError, match=r"followers\.state: .*C-contiguous"):
        fol.state = np.asfortranarray(good)
    with pytest.raises(ValueError, match=r"followers\.x: 2 values expected, got shape \(3,\)"):
        fol.x = [1.0, 2.0, 3.0]
    fol.state = good + 1.0  # (the right array: copied into the state the kernels hold)
    assert fol.values("x") == (good[0] + 1.0).tolist()
    fol.cmd_v = [3.0, 4.0]
    assert fol.values("cmd_v") == [3.0, 4.0] and not math.isnan(fol.state.sum())
