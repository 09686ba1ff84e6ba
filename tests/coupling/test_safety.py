"""Safe means no contact (issue 33): a full lap of Test 2 with six followers under plan, on a
seed no document uses."""

from __future__ import annotations

import pytest

from rtsim.coupling.scenario_run import run_scenario


@pytest.fixture(scope="module")
def six() -> dict:  # type: ignore[type-arg]
    res = run_scenario(
        "test2",
        seed=29,
        overrides={"formation.followers": 6},
        record_jobs=False,
        windows=False,
    )
    return res.summary


def test_no_contact_and_the_true_gap_at_least_10_cm(six: dict) -> None:  # type: ignore[type-arg]
    assert six["collisions"] == 0
    assert six["min_robot_distance_cm"] >= 2 * 25.0 + 10.0
    assert six["missed"] == 0 and six["tracks_lost"] == 0


def test_no_window_beyond_5pct_from_the_settled_start(six: dict) -> None:  # type: ignore[type-arg]
    assert six["violations_beyond_5pct"] == {
        "localization": 0,
        "separation": 0,
        "path_diversion": 0,
        "bearing": 0,
    }


def test_plan_laps_within_2pct_of_the_oracle(six: dict) -> None:  # type: ignore[type-arg]
    assert six["lap_oracle_s"] > 105.1  # slower than a lap at V_Ld: the turns bind
    assert abs(six["lap_time_s"] / six["lap_oracle_s"] - 1.0) <= 0.02
    assert six["lap_over_oracle"] == pytest.approx(six["lap_time_s"] / six["lap_oracle_s"])
