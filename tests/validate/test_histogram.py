"""``rtsim histogram``: PNG + CSV per task from a simulation, a scenario directory and a sweep
point, with the bounds computed by hand."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pandas as pd
import pytest

from rtsim.cli import main
from rtsim.sweep import run_sweep
from rtsim.validate import histogram_table

REPO = Path(__file__).resolve().parents[2]
PAPER = REPO / "tasksets" / "barrel_robots.toml"


def _wcrt(e: float, hp: list[tuple[float, float]]) -> float:
    r = e + sum(c for c, _ in hp)
    while True:
        nxt = e + sum(math.ceil(r / p - 1e-9) * c for c, p in hp)
        if nxt <= r + 1e-12:
            return r
        r = nxt


def test_simulation_histograms_png_csv_and_hand_bounds(tmp_path: Path) -> None:
    out = tmp_path / "h"
    horizon = 4000.0
    assert (
        main(
            [
                "histogram",
                str(PAPER),
                "--horizon",
                str(horizon),
                "--window",
                "250",
                "--out",
                str(out),
                "--bins",
                "20",
            ]
        )
        == 0
    )
    for task in ("dead_reckoning", "window", "command"):
        assert (out / f"histogram-{task}.png").stat().st_size > 1000
    hist = pd.read_csv(out / "histogram.csv")
    counts = hist.groupby("task")["count"].sum()
    # jobs released in [0, H): ceil(H/p), all completed (the set is schedulable at w = 250)
    assert counts["dead_reckoning"] == math.ceil(horizon / 40)
    assert counts["window"] == math.ceil(horizon / 250)
    assert counts["command"] == math.ceil(horizon / 500)
    assert (hist.groupby("task").size() == 20).all()
    b = pd.read_csv(out / "bounds.csv").set_index(["task", "line"])["value"]
    g = 106 + math.pi * 25**2 * 2 * 0.001 + 68 * 0.1 + 2 * 4 + 67 + 1  # Eq 1, Eq 5
    assert b["dead_reckoning", "WCRT (exact RTA)"] == pytest.approx(5.0)
    assert b["window", "WCRT (exact RTA)"] == pytest.approx(_wcrt(g, [(5, 40)]), abs=1e-9)
    assert b["command", "WCRT (exact RTA)"] == pytest.approx(
        _wcrt(25, [(5, 40), (g, 250)]), abs=1e-9
    )
    assert b["command", "deadline"] == pytest.approx(500.0)
    w_sch = (0.5 * (25 + 5) + g) / (1 - 5 / 40)  # Eq 11 dominates for the paper's set
    assert b["window", "w_sch"] == pytest.approx(w_sch, rel=1e-12)
    man = json.loads((out / "manifest.json").read_text())
    assert man["command"] == "histogram" and "histogram.csv" in man["outputs"]


def test_scenario_dir_histogram_counts_its_jobs(tmp_path: Path) -> None:
    d = tmp_path / "scen"
    d.mkdir()
    rows = [
        ("window", k, 250.0 * k, 250.0 * k, 250.0 * k + r, r, 250.0 * (k + 1), False)
        for k, r in enumerate([200.0, 210.0, 205.0, 230.0])
    ]
    rows += [
        ("dead_reckoning", k, 40.0 * k, 40.0 * k, 40.0 * k + 5, 5.0, 40.0 * (k + 1), False)
        for k in range(25)
    ]
    pd.DataFrame(
        rows,
        columns=["task", "job", "release", "start", "finish", "response", "deadline", "missed"],
    ).to_csv(d / "jobs.csv", index=False)
    (d / "summary.json").write_text(json.dumps({"w_sch": 240.0}))
    out = tmp_path / "h"
    assert main(["histogram", "--scenario", str(d), "--out", str(out), "--bins", "5"]) == 0
    hist = pd.read_csv(out / "histogram.csv")
    assert hist.groupby("task")["count"].sum().to_dict() == {"window": 4, "dead_reckoning": 25}
    assert (out / "histogram-window.png").is_file()
    b = pd.read_csv(out / "bounds.csv").set_index(["task", "line"])["value"]
    assert b["window", "deadline"] == pytest.approx(240.0)  # analysed at summary's w_sch
    assert b["dead_reckoning", "WCRT (exact RTA)"] == pytest.approx(5.0)


def test_sweep_point_histogram_agrees_with_the_sweep_table(tmp_path: Path) -> None:
    spec = tmp_path / "s.toml"
    spec.write_text(
        f'[sweep]\nkind = "simulate"\nbase = "{PAPER.as_posix()}"\nseed = 3\n'
        '[sweep.options]\nhorizon = 3000\nexec = "uniform"\n'
        '[sweep.set]\n"tasks.command.bcet" = 10\n[grid]\nn = [1, 3]\n'
    )
    sweep_dir = tmp_path / "sw"
    table = run_sweep(spec, sweep_dir, workers=1)
    out = tmp_path / "h"
    assert main(["histogram", "--sweep", str(sweep_dir), "--point", "1", "--out", str(out)]) == 0
    hist = pd.read_csv(out / "histogram.csv")
    counts = hist.groupby("task")["count"].sum()
    row = table.iloc[1]
    for task in ("dead_reckoning", "window", "command"):
        assert counts[task] == row[f"jobs.{task}"]
    # the re-run is the same run: its largest response lies in the last occupied bin
    last = hist[(hist["task"] == "command") & (hist["count"] > 0)].iloc[-1]
    assert last["lo"] <= row["max_response.command"] <= last["hi"]


def test_sweep_point_histogram_runs_the_points_scheduler(tmp_path: Path) -> None:
    """A point's ``scheduler`` option is re-run too: under EDF task a (C 2, T 10) waits behind
    b (C 5, D 6) and responds in 7 ms, under FP in 2 ms."""
    base = tmp_path / "set.toml"
    base.write_text(
        '[[tasks]]\nname = "a"\nwcet = 2\nperiod = 10\npriority = 1\n'
        '[[tasks]]\nname = "b"\nwcet = 5\nperiod = 7\ndeadline = 6\npriority = 2\n'
    )
    spec = tmp_path / "s.toml"
    spec.write_text(
        f'[sweep]\nkind = "simulate"\nbase = "{base.as_posix()}"\n'
        '[sweep.options]\nhorizon = 700\nscheduler = "edf"\n[grid]\nseed = [0]\n'
    )
    table = run_sweep(spec, tmp_path / "sw", workers=1)
    assert table.iloc[0]["max_response.a"] == 7.0
    out = tmp_path / "h"
    assert (
        main(["histogram", "--sweep", str(tmp_path / "sw"), "--point", "0", "--out", str(out)]) == 0
    )
    hist = pd.read_csv(out / "histogram.csv")
    last = hist[(hist["task"] == "a") & (hist["count"] > 0)].iloc[-1]
    assert last["lo"] <= 7.0 <= last["hi"]


def test_histogram_table_bins_reach_the_bound_lines() -> None:
    from rtsim.analysis.validation import TaskBounds

    jobs = pd.DataFrame({"task": ["a"] * 4, "response": [1.0, 2.0, 3.0, math.nan]})
    b = {"a": TaskBounds("a", 10.0, 12.0, None, None, False, False)}
    t = histogram_table(jobs, 11, b)
    assert t["count"].sum() == 3
    assert t["lo"].iloc[0] == 1.0 and t["hi"].iloc[-1] == pytest.approx(12.0)


@pytest.mark.parametrize(
    "argv, msg",
    [
        (["--out", "x"], "exactly one of FILE"),
        (["--sweep", "nowhere", "--out", "x"], "--sweep needs --point"),
        ([str(PAPER), "--out", "x"], "needs --horizon"),
        (["--scenario", "nowhere", "--out", "x"], "no jobs.csv"),
    ],
)
def test_histogram_bad_input_exits_2(argv: list[str], msg: str, capsys) -> None:
    assert main(["histogram", *argv]) == 2
    assert msg in capsys.readouterr().err
