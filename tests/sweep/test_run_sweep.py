"""``rtsim.run_sweep``: the n × r_H sweep in one call (issue 34, item 4): a DataFrame in
memory, a row equal to the direct run with the seed asked for, a grown grid that keeps the
points already finished."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import rtsim
from rtsim.errors import InputError

GRID = {"formation.followers": [1, 2], "sensing.r_H": [20, 30]}


def test_four_rows_with_the_seed_asked_for(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # nothing is written when out is None
    df = rtsim.run_sweep("test2", grid=GRID, duration_s=10, workers=1)
    assert len(df) == 4 and (df["status"] == "ok").all(), df["error"].tolist()
    assert list(df["seed"]) == [0, 0, 0, 0] and list(df["point_seed"]) == [0, 0, 0, 0]
    assert list(zip(df["formation.followers"], df["sensing.r_H"], strict=True)) == [
        (1, 20),
        (1, 30),
        (2, 20),
        (2, 30),
    ]
    assert (df["duration_s"] == 10.0).all() and list(df["n"]) == [1, 1, 2, 2]
    assert list(tmp_path.iterdir()) == []
    # a row is the direct run with that seed and those keys
    direct = rtsim.run_scenario(
        "test2",
        overrides={"formation.followers": 2, "sensing.r_H": 30},
        seed=0,
        duration_s=10,
        record_jobs=False,
    ).summary
    row = df.iloc[3]
    for key in ("windows", "missed", "tracks_lost", "min_msb_over_wsch", "w_sch"):
        assert row[key] == direct[key], key


def test_seeds_and_a_grown_grid_keep_the_finished_points(tmp_path: Path) -> None:
    out = tmp_path / "sweep"
    small = rtsim.run_sweep(
        "test2", grid={"formation.followers": [1]}, seeds=[0, 1], duration_s=2, out=out, workers=1
    )
    assert list(small["seed"]) == [0, 1] and len(small) == 2
    before = {
        json.loads(f.read_text())["key"]: json.loads(f.read_text())["timing"]
        for f in (out / "points").glob("*.json")
    }
    grown = rtsim.run_sweep(
        "test2",
        grid={"formation.followers": [1, 2]},
        seeds=[0, 1],
        duration_s=2,
        out=out,
        workers=1,
    )
    assert list(grown["formation.followers"]) == [1, 1, 2, 2] and list(grown["seed"]) == [0, 1] * 2
    after = {
        json.loads(f.read_text())["key"]: json.loads(f.read_text())["timing"]
        for f in (out / "points").glob("*.json")
    }
    assert len(after) == 4
    for key, timing in before.items():  # the same record, not a second run (its wall time)
        assert after[key] == timing
    assert (
        small.drop(columns=["wall_s"], errors="ignore")
        .iloc[1]
        .equals(grown.drop(columns=["wall_s"], errors="ignore").iloc[1])
    )


def test_another_base_is_still_refused(tmp_path: Path) -> None:
    from rtsim.errors import SweepError

    out = tmp_path / "sweep"
    rtsim.run_sweep("test2", grid={"formation.followers": [1]}, duration_s=1, out=out, workers=1)
    with pytest.raises(SweepError, match="holds results of a different sweep"):
        rtsim.run_sweep("test1", grid={"formation.followers": [1]}, duration_s=1, out=out)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"grid": {}}, r"^run_sweep: grid: expected a mapping"),
        ({"grid": {"seed": [1]}}, r"^run_sweep: grid: give the seeds as seeds="),
        ({"grid": GRID, "seeds": [-1]}, r"^run_sweep: seeds: expected non-negative integers"),
        ({"grid": {"sensing.r_HH": [1]}}, r"^run_sweep: grid\.sensing\.r_HH: .*did you mean"),
    ],
)
def test_bad_calls_are_one_line_errors(kwargs: dict, match: str) -> None:
    with pytest.raises(InputError, match=match) as exc:
        rtsim.run_sweep("test2", duration_s=1, **kwargs)
    assert "\n" not in str(exc.value)
    assert (
        exc.value.__cause__ is None
        and exc.value.__suppress_context__ is True
        or (exc.value.__context__ is None)
    )
