"""Scenario files prepared once per process (rtsim.coupling.prepared): the same inputs while
the scenario file and its task set's file are unchanged, new ones as soon as either changes,
and a file gone or broken meanwhile says so as a first read would."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from rtsim.coupling import scenario_inputs
from rtsim.coupling.prepared import PREPARED_MAX, clear
from rtsim.errors import InputError

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def files(tmp_path: Path) -> tuple[Path, Path]:
    """test2 with its task set as a file beside it."""
    clear()
    ts = tmp_path / "set.toml"
    shutil.copy(ROOT / "tasksets" / "barrel_robots.toml", ts)
    sc = tmp_path / "t2.toml"
    text = (ROOT / "experiments" / "scenarios" / "test2.toml").read_text(encoding="utf-8")
    sc.write_text(text.replace('taskset = "barrel_robots"', 'taskset = "set.toml"'), "utf-8")
    return sc, ts


def test_prepared_once_per_content(files: tuple[Path, Path]) -> None:
    sc, ts = files
    first = scenario_inputs(sc)
    again = scenario_inputs(sc)  # unchanged: the same inputs, a fresh policy instance
    assert again.world is first.world and again.taskset is first.taskset
    assert again.resolved is first.resolved and again.text == first.text
    assert again.adjust.policy is not first.adjust.policy
    assert type(again.adjust.policy) is type(first.adjust.policy)
    assert dict(again.adjust) == dict(first.adjust)
    other = scenario_inputs(sc, overrides={"leader.speed": 20})
    assert other.world is not first.world and other.world.leader_speed == 20.0
    assert scenario_inputs(sc, overrides={"leader.speed": 20}).world is other.world
    assert scenario_inputs(sc).world is first.world
    # the scenario file edited (same length): prepared again
    sc.write_text(sc.read_text("utf-8").replace("speed = 30 ", "speed = 25 "), "utf-8")
    edited = scenario_inputs(sc)
    assert edited.world is not first.world and edited.world.leader_speed == 25.0
    # the task set's file edited (same length): prepared again
    old = ts.read_text("utf-8")
    assert "e_scan = 106" in old and edited.taskset.window.e_scan == 106.0
    ts.write_text(old.replace("e_scan = 106", "e_scan = 107"), "utf-8")
    again = scenario_inputs(sc)
    assert again.taskset is not edited.taskset and again.taskset.window.e_scan == 107.0


def test_a_task_set_gone_is_the_first_read_error(files: tuple[Path, Path]) -> None:
    sc, ts = files
    scenario_inputs(sc)
    ts.unlink()
    with pytest.raises(InputError, match="taskset: file not found"):
        scenario_inputs(sc)


def test_packaged_names_and_the_cache_bound() -> None:
    clear()
    a = scenario_inputs("test2")
    assert scenario_inputs("test2").world is a.world
    for k in range(PREPARED_MAX):  # the least recently used goes first
        scenario_inputs("test1", overrides={"leader.speed": 10 + k})
    assert scenario_inputs("test2").world is not a.world
