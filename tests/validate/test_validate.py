"""Validation report on a small grid, the w_sim search, and the failure checker.

The small grid (n ∈ {1, 3}, r_H = 20 cm, 100 windows, 2 random sets) runs once per module
in this process; the checks against it are independent of the validation code: bounds
recomputed by hand from Eq 1/5 and the RTA recurrence, w_sim re-tested with ``simulate``.
"""

from __future__ import annotations

import math
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rtsim.analysis.validation import (
    SEARCH_TOL,
    Failure,
    check_results,
    percentiles,
    smallest_passing,
)
from rtsim.cli import main
from rtsim.config.taskset import load_taskset
from rtsim.sim import simulate
from rtsim.validate import QUICK, run_validation

SMALL = replace(QUICK, n=(1, 3), r_H=(20.0,), random_sets=2, histogram_configs=0)
SMALL_ARGS = [
    "--quick",
    "--followers",
    "1,3",
    "--hough-radius",
    "20",
    "--random-sets",
    "2",
    "--histograms",
    "0",
]


@pytest.fixture(scope="module")
def small(tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("validate")
    # SMALL_ARGS must describe the same run: the CLI test resumes a copy of it
    return run_validation(out, SMALL, workers=1)


def _paper(outcome, mode: str) -> pd.DataFrame:
    t = outcome.table
    return t[(t["source"] == "paper") & (t["mode"] == mode)]


def test_small_grid_finds_no_response_above_its_bound(small) -> None:
    assert small.ok
    assert small.point_errors == []
    assert [f for f in small.failures if f.severity == "failure"] == []
    t = small.table
    assert set(t["source"]) == {"paper", "random"}
    assert set(t.loc[t["source"] == "paper", "config"]) == {"n=1,r_H=20", "n=3,r_H=20"}
    checked = t[t["wcrt"].notna()]
    assert len(checked) > 10
    assert (checked["sim_max"] <= checked["wcrt"] + 1e-6).all()
    assert "**PASS**" in (small.out_dir / "report.md").read_text("utf-8")


def _hand_wcrt(e: float, hp: list[tuple[float, float]]) -> float:
    r = e + sum(c for c, _ in hp)
    while True:
        nxt = e + sum(math.ceil(r / p - 1e-9) * c for c, p in hp)
        if nxt <= r + 1e-12:
            return r
        r = nxt


def test_wcet_cpu_w_sim_equals_w_rta_and_w_sch_above(small) -> None:
    rows = _paper(small, "wcet-cpu").drop_duplicates("config")
    assert len(rows) == 2
    for r in rows.to_dict("records"):
        assert r["w_sch"] >= r["w_rta"] - 1e-9
        assert abs(r["w_sim"] - r["w_rta"]) <= SEARCH_TOL
        # independently: simulate at w_sim (no miss) and one tolerance below w_rta (a miss)
        ts = load_taskset().with_window(n=int(r["n"]), r_H=r["r_H"])
        assert simulate(ts, 100 * r["w_sim"], window=r["w_sim"]).misses == 0
        below = r["w_rta"] - SEARCH_TOL
        assert simulate(ts, 100 * below, window=below).misses > 0


def test_wcet_cpu_responses_reach_the_hand_computed_wcrt(small) -> None:
    """At the critical instant the simulated maxima equal the RTA recurrence, by hand."""
    rows = _paper(small, "wcet-cpu")
    for n in (1, 3):
        sub = rows[rows["n"] == n].set_index("task")
        w = float(sub["w_sch"].iloc[0])
        g = 106 + math.pi * 20**2 * n * 0.001 + 34 * n * 0.1 + n * (1 + 2 + 1) + 67 + 1
        r_win = _hand_wcrt(g, [(5, 40)])
        r_cmd = _hand_wcrt(25, [(5, 40), (g, w)])
        for task, want in (("dead_reckoning", 5.0), ("window", r_win), ("command", r_cmd)):
            assert sub.loc[task, "wcrt"] == pytest.approx(want, abs=1e-9)
            assert sub.loc[task, "sim_max"] == pytest.approx(want, abs=1e-6)


def test_counted_idle_w_sim_at_most_w_rta(small) -> None:
    rows = _paper(small, "counted-idle").drop_duplicates("config")
    assert (rows["w_sim"] <= rows["w_rta"]).all()
    # Δt off the CPU and ~15 beams per visible follower instead of 34: strictly below
    assert (rows["w_sim"] < rows["w_rta"] - 10.0).all()
    assert (rows["points_max"] <= rows["points_wcet"]).all()


def test_report_files_and_figure_data_agree_with_the_table(small) -> None:
    out = small.out_dir
    for name in (
        "report.md",
        "validation.csv",
        "results.parquet",
        "failures.csv",
        "summary.json",
        "manifest.json",
        "figures/bounds_vs_n.png",
        "figures/pessimism_wsch.png",
    ):
        assert (out / name).is_file(), name
    assert not (out / "histograms").exists()  # histograms: see test_validate_quick.py
    fig = pd.read_csv(out / "figures" / "bounds_vs_n.csv")
    t = pd.read_csv(out / "validation.csv")
    for r in fig.to_dict("records"):
        sel = t[(t["n"] == r["n"]) & (t["r_H"] == r["r_H"]) & (t["mode"] == "counted-idle")]
        assert sel["w_sim"].iloc[0] == pytest.approx(r["w_sim_counted_idle"], rel=1e-12)


def test_random_sets_reach_the_wcrt_at_the_critical_instant(small) -> None:
    t = small.table
    sync = t[(t["source"] == "random") & (t["mode"] == "wcet-sync") & t["wcrt"].notna()]
    assert len(sync) >= 2
    assert np.allclose(sync["sim_max"], sync["wcrt"], atol=1e-6)


def test_cli_resumes_and_exits_1_on_a_fabricated_exceedance(
    small, monkeypatch, capsys, tmp_path: Path
) -> None:
    copy = tmp_path / "copy"
    shutil.copytree(small.out_dir, copy)
    out = str(copy)
    stamps = {p: p.stat().st_mtime_ns for p in copy.glob("sweeps/*/points/*.json")}
    assert len(stamps) == 4  # 2 paper points + 2 random sets
    import rtsim.validate.tidy as tidy

    real = tidy.tidy_paper

    def inflated(results: pd.DataFrame) -> pd.DataFrame:
        df = real(results)
        i = df.index[(df["task"] == "window") & (df["mode"] == "counted-idle")][0]
        df.loc[i, "sim_max"] = df.loc[i, "wcrt"] + 0.5
        return df

    monkeypatch.setattr(tidy, "tidy_paper", inflated)
    assert main(["validate", *SMALL_ARGS, "--out", out, "--workers", "1"]) == 1
    # the sweeps resumed: no point was recomputed
    assert {p: p.stat().st_mtime_ns for p in copy.glob("sweeps/*/points/*.json")} == stamps
    captured = capsys.readouterr()  # results on stdout, diagnostics on stderr
    assert "FAILURE" in captured.out and "response above WCRT" in captured.out
    assert "FAILURE" not in captured.err
    report = (copy / "report.md").read_text("utf-8")
    assert "**FAIL**" in report
    fails = pd.read_csv(copy / "failures.csv")
    # above the oblivious WCRT, so above the (smaller) suspension-aware one too
    assert list(fails["check"]) == [
        "response above WCRT",
        "response above the suspension-aware WCRT",
    ]


@pytest.mark.parametrize(
    "argv, msg",
    [
        (["--windows", "50"], "windows must be at least 100"),
        (["--followers", "0"], "n must be positive"),
        (["--workers", "0"], "--workers: 0 processes is outside"),
    ],
)
def test_cli_bad_input_exits_2(argv: list[str], msg: str, tmp_path: Path, capsys) -> None:
    assert main(["validate", "--quick", "--out", str(tmp_path), *argv]) == 2
    assert msg in capsys.readouterr().err


def test_checker_flags_a_hand_made_exceedance() -> None:
    rows = [
        {"config": "a", "task": "t1", "mode": "m", "sim_max": 10.0, "wcrt": 10.0 + 1e-9},
        {"config": "a", "task": "t2", "mode": "m", "sim_max": 12.5, "wcrt": 12.0},
        {"config": "b", "task": "t1", "mode": "m", "sim_max": 50.0, "wcrt": math.nan},
        {
            "config": "c",
            "task": "t1",
            "mode": "m",
            "sim_max": 9.0,
            "wcrt": 8.0,
            "assumption_ok": False,
        },
        {
            "config": "d",
            "task": "t1",
            "mode": "m",
            "sim_max": 1.0,
            "wcrt": 2.0,
            "w_sim": 100.02,
            "w_rta": 100.0,
            "w_sch": 99.0,
        },
    ]
    got = check_results(rows)
    assert Failure("a", "t2", "m", "response above WCRT", 12.5, 12.0) in got
    assert Failure("c", "t1", "m", "response above WCRT", 9.0, 8.0, "warning") in got
    assert Failure("d", "*", "m", "w_sim above w_rta", 100.02, 100.0) in got
    assert Failure("d", "*", "m", "w_sch below w_rta", 99.0, 100.0) in got
    assert len(got) == 4


def test_search_finds_a_threshold_to_tolerance() -> None:
    calls: list[float] = []

    def passes(w: float) -> bool:
        calls.append(w)
        return w >= math.pi

    r = smallest_passing(passes, 1.0, 4.0, tol=0.01, scan=5)
    assert math.pi <= r.w <= math.pi + 0.01
    assert r.nonmonotone == 0 and r.evaluations == len(calls)


def test_search_scan_catches_a_non_monotone_gap() -> None:
    # passes on [2, 2.6) and [3.3, inf): bisection alone lands near 2
    r = smallest_passing(lambda w: 2.0 <= w < 2.6 or w >= 3.3, 1.0, 4.0, tol=0.01, scan=10)
    assert 3.3 <= r.w <= 3.31
    assert r.nonmonotone >= 1


def test_search_doubles_hi_and_rejects_a_passing_lo() -> None:
    r = smallest_passing(lambda w: w >= 10.0, 1.0, 2.0, tol=0.01, scan=2)
    assert 10.0 <= r.w <= 10.01 and r.hi_doublings == 3
    with pytest.raises(ValueError, match="already passes"):
        smallest_passing(lambda w: True, 1.0, 2.0)
    with pytest.raises(ValueError, match="no passing window"):
        smallest_passing(lambda w: False, 1.0, 2.0, max_doublings=2)


def test_percentiles_match_sorted_values() -> None:
    v = np.arange(1, 1001, dtype=float)  # 1..1000: p50 = 500.5, p99 = 990.01, p99.9 = 999.001
    got = percentiles(np.append(v, math.nan))
    assert got[50.0] == pytest.approx(500.5)
    assert got[99.0] == pytest.approx(990.01)
    assert got[99.9] == pytest.approx(999.001)
    assert all(math.isnan(x) for x in percentiles([]).values())


def test_checker_orders_the_bounds_under_the_matching_model() -> None:
    # w_sim ≤ w_susp ≤ w_rta ≤ w_sch, w_sim against w_susp only in counted-idle (Δt idle)
    base = {"task": "t", "sim_max": 1.0, "wcrt": 2.0, "w_sch": 240.0, "w_rta": 235.0}
    rows = [
        {
            **base,
            "config": "ok",
            "mode": "counted-idle",
            "w_sim": 210.0,
            "w_susp": 217.0,
            "w_susp_geo": 212.0,
        },
        {**base, "config": "cpu", "mode": "wcet-cpu", "w_sim": 234.99, "w_susp": 217.0},
        {**base, "config": "low", "mode": "counted-idle", "w_sim": 218.0, "w_susp": 217.0},
        {
            **base,
            "config": "brk",
            "mode": "counted-idle",
            "w_sim": 218.0,
            "w_susp": 217.0,
            "assumption_ok": False,
        },
        {
            **base,
            "config": "geo",
            "mode": "counted-idle",
            "w_sim": 213.0,
            "w_susp": 217.0,
            "w_susp_geo": 212.0,
        },
        {
            **base,
            "config": "geob",
            "mode": "counted-idle",
            "w_sim": 213.0,
            "w_susp": 217.0,
            "w_susp_geo": 212.0,
            "geo_assumption_ok": False,
        },
        {**base, "config": "up", "mode": "wcet-cpu", "w_sim": 234.99, "w_susp": 236.0},
    ]
    got = check_results(rows)
    assert got == [
        Failure("low", "*", "counted-idle", "w_sim above w_susp", 218.0, 217.0),
        Failure("brk", "*", "counted-idle", "w_sim above w_susp", 218.0, 217.0, "warning"),
        Failure("geo", "*", "counted-idle", "w_sim above w_susp_geo", 213.0, 212.0),
        Failure("geob", "*", "counted-idle", "w_sim above w_susp_geo", 213.0, 212.0, "warning"),
        Failure("up", "*", "wcet-cpu", "w_susp above w_rta", 236.0, 235.0),
    ]


def test_w_susp_columns_hold_on_the_small_grid(small) -> None:
    rows = _paper(small, "counted-idle").drop_duplicates("config")
    assert (rows["w_sim"] <= rows["w_susp"] + SEARCH_TOL).all()
    assert (rows["w_susp"] < rows["w_rta"]).all() and (rows["w_rta"] < rows["w_sch"]).all()
    assert (rows["w_susp_geo"] <= rows["w_susp"]).all() and (rows["k_geo"] == 20).all()
    assert rows["w_susp_over_w_sim"].between(1.0, 1.1).all()
    cpu = _paper(small, "wcet-cpu")
    assert cpu["w_susp_over_w_sim"].isna().all()
    rnd = small.table[small.table["source"] == "random"]
    assert len(rnd) > 0


def test_edf_checks_flag_w_sim_above_w_edf_and_w_edf_above_w_rta():
    from rtsim.analysis.validation import check_results

    base = {"source": "paper", "task": "window", "w_sch": 237.4, "w_rta": 235.2, "mode": "edf-cpu"}
    rows = [
        {**base, "config": "ok", "w_sim": 234.5, "w_edf": 234.545},
        {**base, "config": "hi", "w_sim": 234.6, "w_edf": 234.545},
        {**base, "config": "bad", "w_sim": 230.0, "w_edf": 235.3},
    ]
    fails = {(f.config, f.check) for f in check_results(rows)}
    assert fails == {("hi", "w_sim above w_edf"), ("bad", "w_edf above w_rta")}


@pytest.mark.slow
@pytest.mark.parametrize(
    ("sig", "code", "line"),
    [(2, 130, "rtsim: interrupted"), (15, 143, "rtsim: terminated")],
    ids=["sigint", "sigterm"],
)
def test_an_interrupted_validate_resumes_where_it_stopped(
    tmp_path: Path, sig: int, code: int, line: str
) -> None:
    """The README's promise for ``validate``: after Ctrl-C (130) or SIGTERM (143), one line
    and no traceback; the rerun keeps the points the first run finished (not recomputed)
    and completes the report."""
    import os
    import subprocess
    import sys
    import time

    out = tmp_path / "v"
    argv = [sys.executable, "-m", "rtsim", "validate", *SMALL_ARGS, "--workers", "1"]
    proc = subprocess.Popen(
        [*argv, "--out", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    deadline = time.monotonic() + 240
    while not list(out.glob("sweeps/*/points/*.json")):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "no point finished in 240 s"
        time.sleep(0.05)
    os.kill(proc.pid, sig)
    stdout, stderr = proc.communicate(timeout=60)
    if proc.returncode == 0:  # the whole run ended before the signal: nothing to resume
        pytest.skip("validate finished before the signal arrived")
    assert proc.returncode == code, stderr
    assert stderr.decode().splitlines()[-1:] == [line] and b"Traceback" not in stderr
    kept = {p: p.stat().st_mtime_ns for p in out.glob("sweeps/*/points/*.json")}
    assert kept
    again = subprocess.run([*argv, "--out", str(out)], capture_output=True, timeout=600)
    assert again.returncode == 0, again.stderr
    assert len(list(out.glob("sweeps/*/points/*.json"))) == 4
    assert {p: p.stat().st_mtime_ns for p in kept} == kept  # not recomputed
    assert (out / "report.md").exists() and not list(out.rglob("*.tmp"))
