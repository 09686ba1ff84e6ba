"""Clearance and the settled start (rtsim.world.ideal, issue 33)."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from rtsim.config.scenario import load_scenario
from rtsim.errors import ScenarioError
from rtsim.world.formation import CLEARANCE_MARGIN, DEFAULT_CLEARANCE, fan, fan_step
from rtsim.world.ideal import check_clearance, ideal_lap, settled_start
from rtsim.world.path import rounded_rectangle


def test_fan_step_gives_the_clearance_as_the_chord() -> None:
    """Neighbours at rho_d one step apart are 2 r_F + clearance + the 5 cm margin apart: the
    chord 2 rho sin(step / 2)."""
    step = fan_step(325.0, 25.0, 10.0)
    assert 2 * 325.0 * math.sin(step / 2) == pytest.approx(65.0)
    # with no clearance the laser's step (half-widths plus 1 deg, a 55.7 cm chord) is kept
    assert fan_step(325.0, 25.0, 0.0) == pytest.approx(2 * math.asin(25 / 325) + math.radians(1.0))


def test_the_default_fan_keeps_the_clearance_over_a_lap_without_error() -> None:
    path = rounded_rectangle(800, 400, 120)
    form = fan(6, 325.0, r_F=25.0, clearance=DEFAULT_CLEARANCE)
    d = check_clearance(path, form, 25.0, start_s=339.0)
    assert d >= 2 * 25.0 + DEFAULT_CLEARANCE + CLEARANCE_MARGIN - 0.05
    # the same group at the laser's step alone comes within 6 cm of touching: refused
    tight = replace(fan(6, 325.0, r_F=25.0), clearance=DEFAULT_CLEARANCE)
    with pytest.raises(ScenarioError, match=r"6 followers .* radius 120 cm\) with clearance 10"):
        check_clearance(path, tight, 25.0, start_s=339.0)


@pytest.mark.parametrize("n", [9, 10])
def test_test2_refuses_followers_that_cannot_fit_its_turns(n: int) -> None:
    """Test 2's fan puts follower 9 on the inner side of the 120 cm turns, further off the
    trace than the turn's radius: refused before the run, in one line naming the count, the
    radius and the clearance."""
    with pytest.raises(ScenarioError) as info:
        load_scenario("test2", overrides={"formation.followers": n})
    msg = str(info.value)
    assert "\n" not in msg
    assert f"{n} followers do not fit" in msg
    assert "radius 120 cm" in msg and "clearance 10 cm" in msg


def test_a_smaller_clearance_fits_more() -> None:
    """The clearance is the scenario's key (cm)."""
    s = load_scenario("test2", overrides={"formation.followers": 8, "formation.clearance": 0})
    assert s.world.formation.clearance == 0.0


def test_the_group_starts_settled_on_a_straight() -> None:
    """Test 2's leader starts where every follower stands on the first straight: the start
    moves from 0 to the fan's depth plus r_F; each follower's error-free place there is its
    place on straights (rho_d, beta_d), heading along the straight."""
    s = load_scenario("test2", overrides={"formation.followers": 6})
    w = s.world
    depth = max(
        abs(r * math.cos(b)) for r, b in zip(w.formation.rho_d, w.formation.beta_d, strict=True)
    )
    assert w.start_s == pytest.approx(depth + 25.0)
    lap = ideal_lap(w.path, w.formation, w.start_s)
    rel = lap.xy[:, 0, :] - lap.leader[0, :2]
    assert np.hypot(rel[:, 0], rel[:, 1]) == pytest.approx(w.formation.rho_d, abs=0.01)
    assert np.arctan2(rel[:, 1], rel[:, 0]) % (2 * math.pi) == pytest.approx(
        w.formation.beta_d, abs=1e-4
    )
    given = load_scenario("test2", overrides={"leader.start_on": "given"})
    assert given.world.start_s == 0.0


def test_settled_start_without_a_long_straight_takes_the_longest() -> None:
    path = rounded_rectangle(300, 100, 120)
    form = fan(2, 325.0, r_F=25.0)
    assert settled_start(path, form, 25.0, 0.0) == pytest.approx(300.0)


def test_the_command_line_refuses_a_count_that_does_not_fit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Exit 2, one line naming the count, the turn radius and the clearance; nothing run."""
    from rtsim.cli import main

    out = tmp_path / "nine"
    rc = main(["scenario", "test2", "--set", "formation.followers=9", "--out", str(out), "-q"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and err.startswith("rtsim: ")
    assert "9 followers do not fit" in err and "120 cm" in err and "clearance 10 cm" in err
    assert not (out / "summary.json").exists()
