"""experiments/followers.py --quick: the follower-count and Hough-radius sweep's outputs."""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import pandas as pd
import pytest


def _module():  # type: ignore[no-untyped-def]
    root = Path(__file__).resolve().parents[2]
    spec = importlib.util.spec_from_file_location(
        "followers_exp", root / "experiments" / "followers.py"
    )
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_followers_experiment_quick(tmp_path: Path) -> None:
    """A row per run, the summary equal to the runs' sums recomputed here, the lost tracks'
    causes summing to the total, and the reasons' columns from the analysis by hand."""
    mod = _module()
    assert mod.main(["--quick", "--out", str(tmp_path)]) == 0
    runs = pd.read_csv(tmp_path / "followers.csv", keep_default_na=False)
    summ = pd.read_csv(tmp_path / "followers_summary.csv")
    assert len(runs) == 4 and (runs["error"] == "").all()
    causes = runs[[f"lost_{c}" for c in mod.CAUSES]].sum(axis=1)
    assert (causes == runs["tracks_lost"]).all()
    for r in summ.itertuples(index=False):
        sel = runs[(runs["test"] == r.test) & (runs["n"] == r.n)]
        assert r.missed == sel["missed"].sum() and r.tracks_lost == sel["tracks_lost"].sum()
    # w_sch over the straight's path-diversion bound T_eps·rho_d/V_Ld, Test 2 (325 cm, 30 cm/s)
    t2 = summ[(summ["test"] == "test2") & (summ["n"] == 2)].iloc[0]
    # to 1e-12: at the declared pandas floor a CSV float parses one ulp off
    assert t2.wsch_over_path == pytest.approx(t2.w_sch / (1000 * 0.025 * 325 / 30), rel=1e-12)
    # the fan's widest offset with 3 followers: one step beyond 15°, the step whose chord is
    # 2·r_F + clearance = 65 cm: 325·sin(15° + 2·asin(32.5/325)) to the right
    width = 325 * math.sin(math.radians(15.0) + 2 * math.asin(32.5 / 325))
    assert math.isclose(summ[(summ["test"] == "test2") & (summ["n"] == 3)].iloc[0].width_cm, width)
    assert (tmp_path / "followers.png").stat().st_size > 0
    assert "| test2 | 3 | 25 |" in (tmp_path / "followers.md").read_text()
    assert (
        json.loads((tmp_path / "manifest.json").read_text())["command"]
        == "experiments/followers.py"
    )


def test_followers_experiment_grid_options(tmp_path: Path) -> None:
    """--followers/--hough-radius/--seeds/--tests pick the grid: one row per run with the
    sensing and progress columns, lost causes summing to the total; a bad list is one line
    and exit 2."""
    mod = _module()
    argv = ["--followers", "2,4", "--hough-radius", "15,30", "--seeds", "0", "--tests", "test2"]
    assert mod.main([*argv, "--out", str(tmp_path), "--workers", "1"]) == 0
    runs = pd.read_csv(tmp_path / "followers.csv", keep_default_na=False)
    assert sorted(zip(runs["n"], runs["r_H"], strict=True)) == [(2, 15), (2, 30), (4, 15), (4, 30)]
    assert (runs["test"] == "test2").all() and (runs["seed"] == 0).all()
    for col in ("confusions", "fix_error_p95_cm", "laps", "leader_cm", "lap_s", "cpu_s"):
        assert col in runs
    causes = runs[[f"lost_{c}" for c in mod.CAUSES]].sum(axis=1)
    assert (causes == runs["tracks_lost"]).all()
    assert (runs["laps"] >= 1.0).all()
    assert (tmp_path / "followers.png").stat().st_size > 0
    assert mod.main(["--followers", "2,x", "--out", str(tmp_path)]) == 2
