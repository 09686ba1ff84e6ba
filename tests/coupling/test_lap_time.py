"""summary.json ``lap_time_s`` (issue 10 item 4): the simulated time at which the leader first
completes its lap; None with ``lap_time_note`` when the run stops before."""

from __future__ import annotations

from pathlib import Path

import pytest

from rtsim.config.scenario import load_scenario
from rtsim.coupling import duration
from rtsim.coupling.scenario_run import run_scenario

PIN = Path(__file__).parents[1] / "data" / "policy_pin" / "pin1.toml"


def test_lap_time_at_constant_speed_is_the_paths_lap_time() -> None:
    # fixed-wsch keeps V_L = V_Ld = the start speed: the lap takes lap_length / V_Ld, and the
    # linear interpolation between window completions is exact at constant speed
    sc = load_scenario(PIN)
    res = run_scenario(PIN, seed=0, policy="fixed-wsch", record_jobs=False)
    assert (res.windows["v_leader"] == sc.world.leader_speed).all()
    assert res.summary["lap_time_s"] == pytest.approx(
        sc.world.path.lap_length / sc.world.leader_speed, rel=1e-9
    )
    assert "lap_time_note" not in res.summary
    assert res.summary["laps"] >= 1.0


def test_a_slowed_leader_takes_longer_and_the_run_covers_the_lap() -> None:
    sc = load_scenario(PIN)
    res = run_scenario(PIN, seed=0, policy="margin", record_jobs=False)
    lap = res.summary["lap_time_s"]
    assert lap > sc.world.path.lap_time(sc.world.leader_speed)
    assert res.summary["duration_s"] >= lap


def test_no_lap_time_when_the_duration_is_shorter() -> None:
    res = run_scenario(PIN, seed=0, duration_s=5.0, record_jobs=False)
    assert res.summary["lap_time_s"] is None
    assert res.summary["lap_time_note"] == (
        "the run's duration (5 s) ended before the leader completed its lap"
    )


def test_no_lap_time_when_the_cap_is_reached(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setattr(duration, "LAP_CAP_FACTOR", 0.2)
    # the file's duration (200 s) is exact: a run to the end of the lap here
    text = PIN.read_text(encoding="utf-8")
    assert text.count("\nduration = 200 ") == 1
    f = tmp_path / "short.toml"
    f.write_text(text.replace("\nduration = 200 ", '\nuntil = "lap" '), encoding="utf-8")
    res = run_scenario(f, seed=0, record_jobs=False)
    assert res.summary["lap_time_s"] is None
    assert res.summary["lap_time_note"].startswith(
        "the leader did not complete its lap within the cap of 0.2 lap times at V_Ld"
    )
    assert res.summary["laps"] < 1.0
