"""The compiled world's follower group: its truth as one array that compiled kernels advance
(`rtsim.world.compiled.FollowerArrays`, `rtsim.world.motion.group_advance`), bit for
bit the Python group's lists (`rtsim.world.follower.FollowerGroup`, the reference)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from rtsim.world import compiled
from rtsim.world.config import WorldConfig
from rtsim.world.follower import FollowerGroup, FollowerParams
from rtsim.world.formation import chevron
from rtsim.world.motion import GROUP_ROWS
from rtsim.world.path import rounded_rectangle
from rtsim.world.world import World

needs_numba = pytest.mark.skipif(not compiled.available(), reason="numba is not importable")
FIELDS = ("x", "y", "th", "v", "w", "cmd_v", "cmd_w", "odometer", "t")


def _hex(group: FollowerGroup) -> dict[str, list[str]]:
    out = {}
    for f in FIELDS:
        values = getattr(group, f)
        assert all(type(v) is float for v in values), f
        out[f] = [v.hex() for v in values]
    return out


def _pair(rng: np.random.Generator, n: int, p: FollowerParams) -> tuple[Any, Any]:
    args = (
        rng.uniform(-500, 500, n),
        rng.uniform(-500, 500, n),
        rng.uniform(-7, 7, n),
        rng.uniform(0, 60, n),
    )
    t0 = float(rng.uniform(0, 50))
    return FollowerGroup(*args, p, t0), compiled.FollowerArrays(*args, p, t0)


@needs_numba
@pytest.mark.parametrize("seed", range(6))
def test_group_array_matches_the_lists(seed: int) -> None:
    """Random interleavings of one follower's advance, every follower's (again at a time
    reached: nothing to do), commands realised with noise and held, as the world makes
    them: every field bit for bit the Python group's, floats, at every step."""
    rng = np.random.default_rng(seed)
    p = FollowerParams(max_accel=float(rng.choice([40.0, 100.0, 1e5])))
    n = int(rng.integers(1, 10))
    a, b = _pair(rng, n, p)
    assert _hex(a) == _hex(b)
    t = 50.0
    for _ in range(300):
        step = float(rng.choice([1.0, 10.0, 33.3]))
        op = rng.integers(0, 4)
        if op == 0:
            t += float(rng.uniform(0, 60))
            for g in (a, b):
                g.advance_all(t, step)
        elif op == 1:
            k, tk = int(rng.integers(0, n)), t + float(rng.uniform(0, 60))
            for g in (a, b):
                g.advance(k, tk, step)
        elif op == 2:
            back = t - float(rng.uniform(0, 5))
            for g in (a, b):
                g.advance_all(back, step)  # (there already, but after `advance` at first)
        else:
            k = int(rng.integers(0, n))
            cmd = float(rng.uniform(-20, 200)), float(rng.uniform(-1, 1))
            nv, nw = rng.standard_normal(2).tolist()
            assert a.apply_drawn(k, *cmd, nv, nw) == b.apply_drawn(k, *cmd, nv, nw)
        assert _hex(a) == _hex(b)
        assert a.truth() == b.truth()
        assert [list(r) for r in a.xy] == [r.tolist() for r in b.xy]
        assert all(a.pose(k) == b.pose(k) for k in range(n))


@needs_numba
def test_group_fields_write_through() -> None:
    """A field read is its row as a list; an item assigned to it, or a whole field
    assigned, writes the array (as on the Python group's lists), and a time moved back
    makes `advance_all` integrate again; the lists are read again once the array changed."""
    rng = np.random.default_rng(3)
    p = FollowerParams()
    a, b = _pair(rng, 3, p)
    for g in (a, b):
        g.advance_all(100.0, 10.0)
        g.cmd_v[1] += 15.0
        g.cmd_w = [0.1, -0.2, 0.3]
        g.t[2] = 60.0
        g.advance_all(100.0, 10.0)  # (follower 3 again, from 60 ms)
    assert _hex(a) == _hex(b)
    S = b.S
    assert S.shape == (len(GROUP_ROWS), 3)
    assert b.W.base is S and b.W.shape == (3, 3)
    assert S[GROUP_ROWS.index("cmd_v"), 1] == a.cmd_v[1]
    x = b.x
    assert b.x is x  # (one list until the array changes)
    b.advance_all(200.0, 10.0)
    assert b.x is not x and b.x == S[GROUP_ROWS.index("x")].tolist()
    S[GROUP_ROWS.index("x"), 0] = 7.0  # (written by another: said with `changed`)
    b.changed()
    assert b.x[0] == 7.0


@needs_numba
def test_a_field_read_before_the_array_moved_stays_out_of_it() -> None:
    """A list read before a step, assigned an item after it, writes that item through but
    is not taken as the field again (its other items are the old ones); a field cannot be
    resized or reordered in place (the row would silently disagree with the array)."""
    b = _pair(np.random.default_rng(5), 2, FollowerParams())[1]
    x = b.x
    b.advance_all(500.0, 10.0)
    moved = b.S[GROUP_ROWS.index("x")].tolist()
    assert x != moved
    x[0] = 123.0
    assert b.x == [123.0, moved[1]] and b.x is not x
    cmd_v = b.cmd_v
    for change in (cmd_v.reverse, cmd_v.sort, lambda: cmd_v.append(1.0), cmd_v.clear):
        with pytest.raises(TypeError, match="row of its state array"):
            change()
    with pytest.raises(TypeError):
        cmd_v += [1.0]
    assert b.cmd_v == b.S[GROUP_ROWS.index("cmd_v")].tolist()


@needs_numba
def test_the_rollout_plays_ahead_on_lists() -> None:
    """The compiled world's group is `FollowerArrays` (an instance of its class: a copy of
    it is one, on its own array); the Python rollout's group is the list-based compiled
    group."""
    import copy

    a, b = _pair(np.random.default_rng(6), 2, FollowerParams())
    assert isinstance(b, compiled.FollowerArrays)
    assert b.rollout_group is compiled.CompiledFollowerGroup
    assert a.rollout_group is FollowerGroup
    c = copy.deepcopy(b)
    assert _hex(c) == _hex(b) and c.W.base is c.S and c.xy[0].base is c.S
    c.advance_all(300.0, 10.0)
    b.advance_all(300.0, 10.0)
    assert _hex(c) == _hex(b)


@needs_numba
@pytest.mark.parametrize("accel", [math.inf, 30.0])
def test_world_advance_in_one_call_matches_the_python_world(accel: float) -> None:
    """The compiled `World.advance` (`rtsim.world.motion.world_advance`: followers, leader
    and the leader's pose in one call) against the Python world's, through turns, speed
    changes, commands held and times already reached: the leader's arc length, speed and
    pose (the pose the kernel computed, which `LeaderPath.pose` then returns, is the path's
    own) and the followers' truth, bit for bit (each world on a path of its own)."""
    worlds = [
        World(
            WorldConfig(
                rounded_rectangle(300, 300, 150), 25.0, chevron(3, 390),
                follower=FollowerParams(), step_ms=10.0, start_s=250.0, backend=backend,
                leader_accel_max=accel, leader_decel_max=accel,
            ),
            np.random.default_rng(5),
        )
        for backend in ("python", "compiled")
    ]  # fmt: skip
    rng = np.random.default_rng(8)
    t = 0.0
    for _ in range(400):
        t += float(rng.choice([0.0, rng.uniform(0.0, 80.0)]))
        speed = float(rng.uniform(0.0, 25.0)) if rng.random() < 0.1 else None
        cmd = None  # (now and then a follower's command, realised with noise, held)
        if rng.random() < 0.2:
            k, v, w_, nv, nw = int(rng.integers(0, 3)), *rng.uniform(-1, 1, 4).tolist()
            cmd = (k, 40.0 * v, w_, nv, nw)
        for w in worlds:
            if speed is not None:
                w.set_leader_speed(speed)
            w.advance(t)
            if cmd is not None:
                w.followers.apply_drawn(*cmd)
        a, b = worlds
        la, lb = a.leader, b.leader
        assert (la.s.hex(), la.speed.hex()) == (lb.s.hex(), lb.speed.hex())
        pose = lb.pose  # (the kernel's)
        lb.path.remember(math.nan, pose)  # (forgotten: the path computes it again)
        assert [v.hex() for v in pose] == [v.hex() for v in lb.pose] == [v.hex() for v in la.pose]
        assert _hex(a.followers) == _hex(b.followers)
