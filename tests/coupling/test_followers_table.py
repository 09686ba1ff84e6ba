"""``ScenarioResult.followers`` and ``followers.csv``: the windows table in long form, one row
per window and follower (issue 34, item 5)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rtsim.cli import main
from rtsim.coupling.scenario_run import run_scenario
from rtsim.coupling.tidy import followers_frame


@pytest.fixture(scope="module")
def run():  # type: ignore[no-untyped-def]
    return run_scenario("test2", overrides={"formation.followers": 3}, duration_s=6, seed=0)


def test_one_row_per_window_and_follower(run) -> None:  # type: ignore[no-untyped-def]
    wide, long = run.windows, run.followers
    n = 3
    assert len(long) == n * len(wide)
    assert list(long["follower"]) == [1, 2, 3] * len(wide)
    assert list(long["window"]) == [w for w in wide["window"] for _ in range(n)]
    assert not [c for c in long.columns if c.startswith("f1_")]
    for k in (1, 2, 3):
        rows = long[long["follower"] == k].reset_index(drop=True)
        for col in ("x", "v_est", "msb_separation_pred", "msb_bearing_true", "viol_separation"):
            np.testing.assert_array_equal(rows[col].to_numpy(), wide[f"f{k}_{col}"].to_numpy())
        np.testing.assert_array_equal(rows["lost"].to_numpy(), wide[f"f{k}_lost"].to_numpy())
        np.testing.assert_array_equal(rows["t"].to_numpy(), wide["t"].to_numpy())
        dx = wide[f"f{k}_x_est"] - wide[f"f{k}_x"]
        dy = wide[f"f{k}_y_est"] - wide[f"f{k}_y"]
        np.testing.assert_allclose(rows["error"], np.sqrt(dx**2 + dy**2), rtol=1e-12)
    assert (long["error"] >= 0).all() and long["error"].max() < 25  # within r_H: tracked


def test_a_per_follower_question_is_a_groupby(run) -> None:  # type: ignore[no-untyped-def]
    worst = run.followers.groupby("follower")["viol_separation"].max()
    wide = run.windows
    assert list(worst) == [wide[f"f{k}_viol_separation"].max() for k in (1, 2, 3)]


def test_followers_csv_is_the_same_table(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    argv = ["scenario", "test2", "--set", "formation.followers=3", "--duration", "6"]
    assert main([*argv, "--no-figures", "--quiet", "--out", str(out)]) == 0
    capsys.readouterr()
    got = pd.read_csv(out / "followers.csv")
    wide = pd.read_csv(out / "windows.csv")
    want = followers_frame(wide)
    assert len(got) == 3 * len(wide)
    pd.testing.assert_frame_equal(got, want, check_dtype=False)


def test_no_follower_columns_no_rows() -> None:
    empty = followers_frame(pd.DataFrame({"window": [0], "t": [0.0]}))
    assert list(empty.columns) == ["window", "t", "follower"] and empty.empty
