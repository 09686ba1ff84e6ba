"""``experiments/validate.py --quick`` in a subprocess: exit 0, its figures and CSVs appear,
and the figure data agree with the validation table they were drawn from."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

REPO = Path(__file__).resolve().parent.parent


@pytest.mark.slow
def test_quick_mode_writes_report_figures_and_csvs(tmp_path: Path) -> None:
    out = tmp_path / "quick"
    env = {**os.environ, "MPLBACKEND": "Agg"}
    proc = subprocess.run(
        [sys.executable, str(REPO / "experiments" / "validate.py"), "--quick", "--out",
         str(out), "--workers", "2", "--quiet"],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=240)
    assert proc.returncode == 0, proc.stderr[-2000:]
    for name in ("report.md", "validation.csv", "results.parquet", "failures.csv",
                 "summary.json", "manifest.json"):
        assert (out / name).is_file(), name
    for fig in ("bounds_vs_n", "pessimism_wsch", "pessimism_wrta", "scheduler_bounds"):
        assert (out / "figures" / f"{fig}.png").stat().st_size > 1000
        assert (out / "figures" / f"{fig}.csv").is_file()
    hists = list(out.glob("histograms/*/histogram-*.png"))
    assert len(hists) == 6  # one configuration, 3 tasks × 2 modes
    assert list(out.glob("histograms/*/histogram-*.csv"))
    table = pd.read_csv(out / "validation.csv")
    paper = table[table["source"] == "paper"]
    assert set(paper["n"]) == {1, 2, 4} and set(paper["r_H"]) == {10, 30}
    assert table.loc[table["source"] == "random", "config"].nunique() == 3
    heat = pd.read_csv(out / "figures" / "pessimism_wsch.csv")
    for r in heat.to_dict("records"):
        sel = paper[(paper["n"] == r["n"]) & (paper["r_H"] == r["r_H"])
                    & (paper["mode"] == r["mode"])]
        assert sel["w_sch"].iloc[0] / sel["w_sim"].iloc[0] == pytest.approx(
            r["w_sch_over_w_sim"], rel=1e-12)
    assert json.loads((out / "summary.json").read_text())["failures"] == 0
    listed = json.loads((out / "manifest.json").read_text())["outputs"]
    assert "report.html" in listed and "report.md" in listed
    assert all((out / name).is_file() for name in listed), listed
    assert pd.read_csv(out / "failures.csv").empty
    # EDF: the edf-cpu search lands at or below w_edf (to the search tolerance), w_edf is at
    # or below w_rta, and the scheduler table covers n = 1..10 × r_H = 10..50
    edf = paper[paper["mode"] == "edf-cpu"].drop_duplicates("config")
    assert len(edf) == 6
    assert (edf["w_sim"] <= edf["w_edf"] + 0.01).all() and (edf["w_edf"] <= edf["w_rta"]).all()
    # (to 1e-12: pandas before 3 may parse a CSV float one ulp off)
    assert np.allclose(edf["w_edf_over_w_sim"], edf["w_edf"] / edf["w_sim"], rtol=1e-12, atol=0)
    sched = pd.read_csv(out / "figures" / "scheduler_bounds.csv")
    assert len(sched) == 50 and set(sched["n"]) == set(range(1, 11))
    assert (sched["w_edf"] <= sched["w_rta"]).all() and (sched["w_rta"] <= sched["w_sch"]).all()
    report = (out / "report.md").read_text()
    assert "## The window under EDF: w_sch, w_rta and w_edf (ms)" in report
