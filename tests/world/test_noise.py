"""The world's noise stream: normals drawn ahead in blocks are the generator's own sequence."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rtsim.config.scenario import load_scenario
from rtsim.world import World
from rtsim.world.follower import FollowerGroup
from rtsim.world.world import NORMAL_BLOCK, STREAM_BLOCK

SCEN = Path(__file__).resolve().parents[2] / "experiments" / "scenarios"


@pytest.mark.parametrize("sizes", [[2] * 700, [4, 2, 2] * 200 + [NORMAL_BLOCK, 3, 1]])
def test_normals_are_the_generator_sequence(sizes: list[int]) -> None:
    """Whatever the request sizes (across block boundaries), _normals hands out the numbers
    one standard_normal call per request would: the generator's stream after the
    construction's (n, 3) initial-estimate draws."""
    cfg = load_scenario(SCEN / "test2.toml").world
    world = World(cfg, np.random.default_rng(7))
    got = [x for m in sizes for x in world._normals(m)]
    ref = np.random.default_rng(7)
    ref.standard_normal((cfg.n, 3))
    want = [x for m in sizes for x in ref.standard_normal(m).tolist()]
    assert got == want


def test_scans_and_commands_share_the_generator_sequence() -> None:
    """The laser's draws (`World._draw`, 361 per scan) and the commands' (`_normals`, 2 at
    a time from blocks of 512) interleaved, across the draw-ahead block's boundary: each
    reader gets what one standard_normal call per request, in the same order, would give."""
    cfg = load_scenario(SCEN / "test2.toml").world
    world = World(cfg, np.random.default_rng(11))
    ref = np.random.default_rng(11)
    ref.standard_normal((cfg.n, 3))
    ref_z: list[float] = []
    for scan in range(2 * STREAM_BLOCK // 361 + 3):
        got = world._draw(361)
        assert got.tolist() == ref.standard_normal(361).tolist(), scan
        for _ in range(scan % 5):
            if not ref_z:
                ref_z = ref.standard_normal(NORMAL_BLOCK).tolist()
            want, ref_z = ref_z[:2], ref_z[2:]
            assert world._normals(2) == want


def test_apply_drawn_equals_apply() -> None:
    cfg = load_scenario(SCEN / "test1.toml").world
    p = cfg.follower
    a = FollowerGroup([0.0], [0.0], [0.0], [10.0], p)
    b = FollowerGroup([0.0], [0.0], [0.0], [10.0], p)
    nv, nw = np.random.default_rng(3).standard_normal(2).tolist()
    assert a.apply(0, 20.0, 0.1, np.random.default_rng(3)) == b.apply_drawn(0, 20.0, 0.1, nv, nw)
    assert (a.cmd_v, a.cmd_w) == (b.cmd_v, b.cmd_w)
    assert a.cmd_v[0] == pytest.approx(20.0 + p.speed_noise * nv)
