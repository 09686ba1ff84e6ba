"""One form per parameter (issue 31 item 3): a coupled run's r_H has one home, the
scenario's ``[sensing] r_H``; the task set's ``[window] r_H`` is what the set means alone, and
the manifest records which value the run used and that it replaced the set's."""

from __future__ import annotations

import tomllib
from dataclasses import replace
from pathlib import Path

import pytest

from rtsim.analysis.kinematics import R_H_DEFAULT
from rtsim.config.scenario import AdjustConfig, load_scenario, parse_scenario, scenario_bytes
from rtsim.control.policy import AdjustOptions
from rtsim.coupling import ScenarioInputs, run_scenario, scenario_inputs
from rtsim.errors import InputError
from rtsim.world.config import DEFAULT_THRESHOLDS

SCEN = Path(__file__).resolve().parents[2] / "experiments" / "scenarios"


def test_the_manifest_records_the_runs_r_h_and_the_set_it_replaced() -> None:
    same = scenario_inputs("test2").resolved["r_H"]
    assert same == {"value": 25.0, "from": "sensing.r_H", "taskset": 25.0, "replaced": False}
    inp = scenario_inputs("test2", overrides={"sensing.r_H": 31.5})
    assert inp.resolved["r_H"] == {
        "value": 31.5,
        "from": "sensing.r_H",
        "taskset": 25.0,  # barrel_robots.toml's [window] r_H
        "replaced": True,
    }
    # the window's cost is computed with the run's r_H, not the set's
    assert inp.taskset.window is not None and inp.taskset.window.r_H == 31.5
    assert inp.world.thresholds.r_H == 31.5


def test_a_hand_made_input_runs_with_the_worlds_r_h() -> None:
    """A ScenarioInputs made by hand whose task set says another r_H: the coupling sizes the
    window from the world's r_H (its one home), so the run equals the fitted one."""
    sc = load_scenario("test2", overrides={"world.backend": "python"})
    fitted = ScenarioInputs(sc.world, sc.load_taskset())
    other = ScenarioInputs(sc.world, sc.load_taskset().with_window(r_H=40.0))
    a = run_scenario(fitted, duration_s=2.0, record_jobs=False)
    b = run_scenario(other, duration_s=2.0, record_jobs=False)
    assert a.windows is not None and b.windows is not None
    assert a.windows["hough_ms"].equals(b.windows["hough_ms"])
    assert a.summary == b.summary


def test_one_default_r_h() -> None:
    """A file that leaves ``[sensing] r_H`` out runs with the one default (25 cm)."""
    raw, path = scenario_bytes("test2")
    data = tomllib.loads(raw.decode("utf-8"))
    del data["sensing"]["r_H"]
    sc = parse_scenario(data, str(path), SCEN)
    assert sc.world.thresholds.r_H == R_H_DEFAULT == DEFAULT_THRESHOLDS.r_H == 25.0
    assert sc.load_taskset().window.r_H == R_H_DEFAULT  # type: ignore[union-attr]


def test_adjust_is_validated_once_and_typed() -> None:
    """The scenario's [adjust] policy is made once, when the file is read; the run's inputs
    carry it typed (no dict of keys for the coupling to pop), and a scenario whose
    ``adjust`` was replaced since makes the new one."""
    sc = load_scenario("test2", overrides={"adjust.policy": "margin", "adjust.margin": 0.25})
    inp = scenario_inputs(sc)
    assert isinstance(inp.adjust, AdjustOptions)
    assert inp.adjust.policy is sc.policy()  # the instance made when the file was read
    assert type(inp.adjust.policy).__name__ == "MarginPolicy" and inp.adjust.policy.margin == 0.25
    assert dict(inp.adjust)["margin"] == 0.25 and inp.adjust["policy"] == "margin"
    other = replace(sc, adjust=sc.adjust.model_copy(update={"policy": "plan"}))
    assert other.policy().name == "plan" and other.policy() is not sc.policy()


def test_policies_declare_their_options_once() -> None:
    from rtsim.control.policy import ADJUSTMENT_POLICIES, MarginPolicy, PlanPolicy

    assert ADJUSTMENT_POLICIES["safe"].params == {"margin": 0.1, "z": 1.0, "windows": 2.0}
    assert PlanPolicy().windows == 2 and MarginPolicy().margin == 0.1
    assert "margin" not in AdjustConfig.model_fields  # no policy key in the scenario model
    with pytest.raises(InputError, match=r"^windows: must be an integer in \[1, 20\], got 2\.5$"):
        PlanPolicy(windows=2.5)
