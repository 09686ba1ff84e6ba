"""The coupling's send (`World.sender`, one Python call in the compiled world) against the
python world's `World.command`, the reference: the same followers, estimates, held commands
and draws, bit for bit; and the scan hook's reads of a `Scan` made by its constructor."""

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
    out += [world.held_command(i) for i in range(1, world.n + 1)]
    out += [world.estimate_at(i, world.t_ms) for i in range(1, world.n + 1)]
    out.append(world._normals(3))  # (the draws still to come: the same stream position)
    return out


@pytest.mark.parametrize("name", ["test1", "test2"])
def test_sender_is_the_python_worlds_command_bit_for_bit(name: str) -> None:
    a = World(
        load_scenario(SCEN / f"{name}.toml", overrides={"world.backend": "python"}).world,
        np.random.default_rng(5),
    )
    cfg = load_scenario(SCEN / f"{name}.toml").world
    b = World(cfg, np.random.default_rng(5))
    send = b.sender()
    assert a.sender() is None
    if send is None:  # (the law is not fused here: the coupling calls World.command)
        assert not b._ftl_fused
        return
    t = 0.0
    for step in range(400):  # (more holds than a row's first room: the rows grow)
        t += 120.0
        if step % 40 == 0:  # (between scans the held commands pile up: the rows grow)
            for w in (a, b):
                w.estimate(w.scan(t))
        for i in range(1, cfg.n + 1):
            ts = t + 10.0 * i + (step % 3)
            assert a.command(i, ts) == send(i - 1, ts)
        if step % 50 == 0:
            assert _state(a) == _state(b)
    assert _state(a) == _state(b)
    assert b._arr is not None and b._arr.E.shape[1] > 39  # (the rows grew on the way)
    with pytest.raises(IndexError):
        b.command(cfg.n + 1, t + 100.0)


def test_hooks_read_a_constructed_scan_as_the_worlds(monkeypatch: pytest.MonkeyPatch) -> None:
    """The scan hook reads the world's scans' field lists at once (`Scan.fields`); a `Scan`
    made by its constructor, with arrays, gives the same windows table."""
    from rtsim.coupling import scenario_run
    from rtsim.world.scan import Scan

    def run() -> object:
        return scenario_run.run_scenario("test2", record_jobs=False, duration_s=15.0).windows

    want = run()
    real = World.scan_estimate
    calls = [0]

    def rebuilt(self: World, t_ms: float) -> Scan:
        calls[0] += 1
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

    monkeypatch.setattr(World, "scan_estimate", rebuilt)
    got = run()
    assert calls[0] == len(want)  # (every window's scan was the constructor's)
    world = World(load_scenario(SCEN / "test2.toml").world, np.random.default_rng(0))
    assert "_plain" not in world.scan_estimate(0.0)._raw  # (the constructor's: slower reads)
    pd.testing.assert_frame_equal(got, want, check_exact=True)
