"""The coupling's send (`World.sender`, one Python call) against `World.command`, the
reference: the same followers, estimates, held commands and draws, bit for bit."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rtsim.config.scenario import load_scenario
from rtsim.world import World

SCEN = Path(__file__).resolve().parents[2] / "experiments" / "scenarios"


def _state(world: World) -> list[object]:
    fol = world.followers
    out: list[object] = [list(v) for v in (fol.x, fol.y, fol.th, fol.v, fol.w)]
    out += [list(fol.cmd_v), list(fol.cmd_w), world.t_ms, world.leader.s, world.leader.speed]
    arr = world._arr
    if arr is not None:
        out += [arr.E.tobytes(), list(arr.last)]
    out.append(world._normals(3))  # (the draws still to come: the same stream position)
    return out


@pytest.mark.parametrize("name", ["test1", "test2"])
def test_sender_is_command_bit_for_bit(name: str) -> None:
    cfg = load_scenario(SCEN / f"{name}.toml").world
    a = World(cfg, np.random.default_rng(5))
    b = World(cfg, np.random.default_rng(5))
    send = b.sender()
    if send is None:  # (the law is not fused here: the coupling calls World.command)
        assert not a._ftl_fused
        return
    t = 0.0
    for step in range(400):  # (more holds than a row's first room: the rows grow)
        t += 120.0
        if step % 40 == 0:  # (between scans the held commands pile up: the rows grow)
            for w in (a, b):
                w.estimate(w.scan(t))
        for i in range(1, cfg.n + 1):
            ts = t + 10.0 * i + (step % 3)
            a.command(i, ts)
            send(i - 1, ts)
        if step % 50 == 0:
            assert _state(a) == _state(b)
    assert _state(a) == _state(b)
    assert b._arr is not None and b._arr.E.shape[1] > 39  # (the rows grew on the way)
    with pytest.raises(IndexError):
        send(cfg.n, t + 100.0)
