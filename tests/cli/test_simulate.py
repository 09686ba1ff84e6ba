"""``rtsim simulate`` and the simulator's plots."""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402

import rtsim.plots  # noqa: E402
from rtsim.cli import main  # noqa: E402
from rtsim.model.task import Task  # noqa: E402
from rtsim.plots import gantt, response_histogram  # noqa: E402
from rtsim.sim import ResponseHistogram, simulate  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "tasksets" / "example.toml"  # (5, 40), (200, 250), (25, 500)
PAPER = REPO / "tasksets" / "barrel_robots.toml"


def _json(capsys, argv):
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


def test_simulate_json_example(capsys):
    out = _json(capsys, ["simulate", str(EXAMPLE), "--horizon", "1000", "--json"])
    tasks = {t["name"]: t for t in out["tasks"]}
    assert [t["name"] for t in out["tasks"]] == ["tau1", "tau2", "tau3"]
    # released in [0, 1000): 25, 4, 2 jobs
    assert [tasks[n]["released"] for n in ("tau1", "tau2", "tau3")] == [25, 4, 2]
    assert [tasks[n]["jobs"] for n in ("tau1", "tau2", "tau3")] == [25, 4, 2]
    # by hand: tau2 = 200 + 6·5 = 230; tau3 = 25 + 2·200 + 13·5 = 490 (R = 490 is a fixed
    # point: ⌈490/40⌉ = 13, ⌈490/250⌉ = 2; 485 is not: 25 + 400 + 65 = 490)
    assert tasks["tau2"]["max_response"] == 230.0
    assert tasks["tau3"]["max_response"] == 490.0
    assert tasks["tau3"]["wcrt_analysis"] == 490.0
    for t in out["tasks"]:
        for key in ("aborted", "skipped", "mean_response", "misses"):
            assert key in t


def test_simulate_writes_jobs_and_manifest(tmp_path, capsys):
    jobs = tmp_path / "out" / "jobs.csv"
    ex = tmp_path / "example_bcet.toml"  # --exec uniform needs best cases
    ex.write_text(EXAMPLE.read_text().replace("[[tasks]]\n", "[[tasks]]\nbcet = 1\n"))
    assert (
        main(
            [
                "simulate",
                str(ex),
                "--horizon",
                "1000",
                "--seed",
                "4",
                "--exec",
                "uniform",
                "--jobs",
                str(jobs),
            ]
        )
        == 0
    )
    text = capsys.readouterr().out
    assert "tau1" in text and "max_response" in text
    df = pd.read_csv(jobs)
    for col in ("task", "job", "release", "start", "finish", "response", "deadline", "missed"):
        assert col in df.columns
    assert len(df) == 31
    man = json.loads((jobs.parent / "manifest.json").read_text())
    assert man["seed"] == 4 and man["command"] == "simulate"
    assert man["inputs"]["exec"] == "uniform" and man["outputs"] == ["jobs.csv"]
    assert man["inputs"]["taskset"]["tasks"][0]["name"] == "tau1"


def test_simulate_parquet_trace_and_figures(tmp_path, capsys):
    pq = tmp_path / "j.parquet"
    tr = tmp_path / "figs" / "trace.csv"
    g = tmp_path / "figs" / "gantt.png"
    h = tmp_path / "figs" / "hist.png"
    assert (
        main(
            [
                "simulate",
                str(PAPER),
                "--horizon",
                "3000",
                "--suspension",
                "idle",
                "--jobs",
                str(pq),
                "--trace",
                str(tr),
                "--gantt",
                str(g),
                "--gantt-range",
                "0..600",
                "--histogram",
                str(h),
            ]
        )
        == 0
    )
    capsys.readouterr()
    assert len(pd.read_parquet(pq)) > 0
    trace = pd.read_csv(tr)
    assert set(trace.loc[~trace["on_cpu"], "segment"]) == {"radio"}
    for png in (g, h):
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (tmp_path / "manifest.json").exists()
    assert json.loads((tmp_path / "figs" / "manifest.json").read_text())["outputs"] == [
        "trace.csv",
        "gantt.png",
        "hist.png",
    ]


def test_simulate_paper_set_reports_window_bounds(capsys):
    out = _json(
        capsys,
        [
            "simulate",
            str(PAPER),
            "--horizon",
            "5000",
            "--followers",
            "3",
            "--hough-radius",
            "25",
            "--json",
        ],
    )
    win = out["window"]
    assert win["n"] == 3 and win["r_H"] == 25.0
    assert win["mode"] == "w_sch" and win["w"] == pytest.approx(win["w_sch"])
    assert win["w_rta"] < win["w_sch"]
    chain = next(t for t in out["tasks"] if t["name"] == "window")
    assert chain["max_response"] == pytest.approx(chain["wcrt_analysis"], abs=1e-9)
    assert out["misses"] == 0
    text_out = main(
        ["simulate", str(PAPER), "--horizon", "5000", "--window", str(win["w_rta"] - 1)]
    )
    assert text_out == 0
    text = capsys.readouterr().out
    assert "w_sch" in text and "w_rta" in text


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        (["--window", "300"], "has no \\[window\\]"),
        (["--gantt", "x.png", "--gantt-range", "5..1"], "--gantt-range"),
        (["--jobs", "out.txt"], "must end in .csv or .parquet"),
    ],
)
def test_simulate_input_errors_exit_2(tmp_path, capsys, extra, match):
    argv = ["simulate", str(EXAMPLE), "--horizon", "100"]
    argv += [str(tmp_path / a) if a.endswith((".png", ".txt")) else a for a in extra]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("rtsim: ") and len(err.strip().splitlines()) == 1
    assert pytest.importorskip("re").search(match, err)


def test_simulate_bad_taskset_same_error_as_analyze(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('[[tasks]]\nname = "a"\nperiod = 10\n')
    assert main(["simulate", str(bad), "--horizon", "100"]) == 2
    sim_err = capsys.readouterr().err
    assert "bad.toml" in sim_err and "wcet" in sim_err
    if main(["analyze", str(bad)]) == 2:  # the analyze command exists
        assert capsys.readouterr().err == sim_err


def test_plots_public_api():
    assert set(rtsim.plots.__all__) >= {"gantt", "response_histogram"}


def test_gantt_draws_one_bar_per_trace_row_in_range():
    res = simulate(
        [Task("hi", 2, 5, priority=1), Task("lo", 4, 10, priority=2)],
        20,
        record_jobs=True,
        record_trace=True,
    )
    fig = gantt(res.trace, jobs=res.jobs, start=0, end=10)
    ax = fig.axes[0]
    in_range = res.trace[(res.trace["end"] > 0) & (res.trace["start"] < 10)]
    assert len(ax.collections) == len(in_range)
    assert len(ax.lines) == int(((res.jobs["deadline"] >= 0) & (res.jobs["deadline"] <= 10)).sum())
    assert [t.get_text() for t in ax.get_yticklabels()] == ["hi", "lo"]
    assert ax.get_xlim() == (0.0, 10.0)
    plt.close(fig)


def test_histogram_lines_and_running_histogram():
    hist = ResponseHistogram(1.0)
    for v in (3.2, 3.7, 5.1):
        hist.add(v)
    edges, counts = hist.arrays()
    assert list(edges) == [3.0, 4.0, 5.0, 6.0] and list(counts) == [2, 0, 1]
    fig = response_histogram(hist, lines={"WCRT (analysis)": 6.0, "deadline": 8.0, "w_sch": None})
    ax = fig.axes[0]
    xs = sorted(line.get_xdata()[0] for line in ax.lines if len(line.get_xdata()))
    assert xs == [6.0, 8.0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "WCRT (analysis) = 6" in labels and "w_sch: none" in labels
    plt.close(fig)
    fig = response_histogram(np.array([1.0, 2.0, np.nan]), lines={"deadline": 3.0}, bins=4)
    assert sum(p.get_height() for p in fig.axes[0].patches) == 2
    plt.close(fig)


def test_exec_uniform_without_bcet_is_an_input_error(tmp_path, capsys):
    """It used to run every job at its WCET, silently."""
    out = tmp_path / "jobs.csv"
    assert (
        main(
            ["simulate", str(EXAMPLE), "--horizon", "1000", "--exec", "uniform", "--jobs", str(out)]
        )
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert err == (
        f"rtsim: {EXAMPLE}: task 'tau1': --exec uniform needs a bcet (times are "
        "uniform in [bcet, wcet]); add bcet = ... to the task or use --exec wcet"
    )
    assert not out.exists()
    assert (
        main(
            [
                "histogram",
                str(EXAMPLE),
                "--horizon",
                "1000",
                "--exec",
                "uniform",
                "--out",
                str(tmp_path / "h"),
            ]
        )
        == 2
    )
    assert "task 'tau1': --exec uniform needs a bcet" in capsys.readouterr().err
