"""The coupling's send (`World.sender`, one Python call) against `World.command`, the
reference: the same followers, estimates, held commands and draws, bit for bit."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
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


def test_hooks_read_a_constructed_scan_as_the_worlds(monkeypatch: pytest.MonkeyPatch) -> None:
    """The scan hook reads the world's scans' field lists at once (`scenario_run._fields`);
    a `Scan` made by its constructor, with arrays, gives the same windows table."""
    from rtsim.coupling import scenario_run
    from rtsim.world.scan import Scan

    def run() -> object:
        return scenario_run.run_scenario("test2", record_jobs=False, duration_s=15.0).windows

    want = run()
    real = World.scan

    def rebuilt(self: World, t_ms: float) -> Scan:
        s = real(self, t_ms)
        raw = s._raw
        arrays = {k: np.asarray(raw[k]) for k in ("points", "lost", "reacquired", "searched")}
        return Scan(
            s.t_ms,
            s.leader_pose,
            arrays["points"],
            s.measured,
            s.truth,
            s.centre,
            s.in_window,
            arrays["lost"],
            arrays["reacquired"],
            s.changes,
            s.violations,
            arrays["searched"],
            list(raw["cause"]),
            voted=None if raw["voted"] is None else np.asarray(raw["voted"]),
            fix_error=None if raw["fix_error"] is None else np.asarray(raw["fix_error"]),
            neighbour=None if raw["neighbour"] is None else np.asarray(raw["neighbour"]),
            cells=raw["cells"],
        )

    monkeypatch.setattr(World, "scan", rebuilt)
    got = run()
    world = World(load_scenario(SCEN / "test2.toml").world, np.random.default_rng(0))
    assert "_plain" not in world.scan(0.0)._raw  # (the constructor's: the slower reads)
    pd.testing.assert_frame_equal(got, want, check_exact=True)
