"""The world's public API (pinned for the coupling layer) and a fixed-window run of both tests."""

from __future__ import annotations

import inspect
import math
from pathlib import Path

import numpy as np
import pytest

import rtsim.world as world_pkg
from rtsim.config.scenario import load_scenario
from rtsim.world import World, hough_time

SCEN = Path(__file__).resolve().parents[2] / "experiments" / "scenarios"


def test_public_names() -> None:
    assert sorted(world_pkg.__all__) == sorted(set(world_pkg.__all__))
    for name in world_pkg.__all__:
        assert hasattr(world_pkg, name), name
    sig = {
        name: str(inspect.signature(getattr(World, name)))
        for name in (
            "advance",
            "scan",
            "estimate",
            "command",
            "set_leader_speed",
            "relative",
            "segment_at",
            "state",
            "estimated_pose",
        )
    }
    assert sig["advance"] == "(self, t_ms: 'float') -> 'None'"
    assert sig["scan"] == "(self, t_ms: 'float') -> 'Scan'"
    assert sig["command"] == "(self, i: 'int', t_ms: 'float') -> 'tuple[float, float]'"
    for prop in (
        "t_ms",
        "n",
        "leader_speed",
        "leader_desired_speed",
        "leader_pose",
        "leader_omega",
        "lap_length",
        "lap_time",
        "filters",
    ):
        assert isinstance(getattr(World, prop), property), prop


@pytest.mark.parametrize("name", ["test1", "test2"])
def test_fixed_240ms_windows_hold_formation_for_a_lap(name: str) -> None:
    """With commands every 240 ms (about w_sch) at full speed the formation holds through a
    whole lap: no lost track, separation within r_H, and state() is JSON-plain."""
    sc = load_scenario(SCEN / f"{name}.toml")
    world = World(sc.world, np.random.default_rng(0))
    t, lost, worst = 0.0, 0, 0.0
    viol = {k: 0 for k in ("localization", "separation", "path_diversion", "bearing")}
    turn_windows = 0
    while t < 1000 * world.lap_time:
        scan = world.scan(t)
        lost += scan.n_lost
        for k in viol:
            viol[k] += int(scan.violations[k].sum())
        assert hough_time(scan, 0.001, 0.1, 25, 100) < 10.0
        world.estimate(scan)
        for i in (1, 2):
            world.command(i, t + 110.0 + 3 * i)
            rho = world.relative(i)[0]
            worst = max(worst, abs(rho - sc.world.formation.rho_d[i - 1]))
        turn_windows += world.segment_at()[0] == "turn"
        t += 240.0
    assert lost == 0
    assert worst < 25.0
    assert turn_windows > 0
    # in turns the outer follower's travel per window exceeds T_eps·rho_d (SPEC §6/§7)
    assert viol["path_diversion"] > 0
    st = world.state()
    assert set(st) == {"t_ms", "leader", "truth", "estimate"}
    assert all(isinstance(v, float) for v in st["truth"]["x"])
    assert math.isfinite(st["leader"]["s"])
