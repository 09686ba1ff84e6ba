"""The Perfetto / Chrome Trace Event export, parsed back and checked against the job table and
the execution trace that the same run wrote (rtsim simulate / rtsim scenario)."""

from __future__ import annotations

import json
from collections import defaultdict

import pandas as pd
import pytest

from rtsim.cli import main

US = 1000.0
TOL = 1e-6  # µs


def _check_against_tables(doc: dict, jobs: pd.DataFrame, trace: pd.DataFrame) -> dict:
    ev = doc["traceEvents"]
    names = {
        e["tid"]: e["args"]["name"] for e in ev if e["ph"] == "M" and e["name"] == "thread_name"
    }
    slices = [e for e in ev if e["ph"] == "X"]
    job_sl = {
        (e["name"].rsplit(" #", 1)[0], e["args"]["job"]): e for e in slices if e["cat"] == "job"
    }
    ran = jobs[jobs["start"].notna()]
    assert len(job_sl) == sum(e["cat"] == "job" for e in slices)
    unfinished = {k for k, e in job_sl.items() if e["name"].endswith("(unfinished)")}
    assert len(job_sl) - len(unfinished) == len(ran)
    assert len(unfinished) <= trace["task"].nunique(), "at most one unfinished job per task"
    for r in ran.itertuples():
        e = job_sl[(r.task, r.job)]
        assert e["ts"] == pytest.approx(r.start * US, abs=TOL)
        assert e["ts"] + e["dur"] == pytest.approx(r.finish * US, abs=TOL)
        assert names[e["tid"]].split(" (")[0] == r.task  # the task's own track (or lane)
    segs = [e for e in slices if e["cat"] != "job"]
    assert len(segs) == len(trace)
    by_key = defaultdict(list)
    for e in segs:
        by_key[(names[e["tid"]].split(" (")[0], e["args"]["job"], e["name"])].append(e)
    for r in trace.itertuples():
        cands = by_key[(r.task, r.job, r.segment)]
        e = next(c for c in cands if abs(c["ts"] - r.start * US) <= TOL)
        assert e["ts"] + e["dur"] == pytest.approx(r.end * US, abs=TOL)
        assert e["cat"] == ("compute" if r.on_cpu else "suspension")
        parent = job_sl[(r.task, r.job)]
        assert parent["tid"] == e["tid"], "a segment sits on its job's track"
        assert (
            parent["ts"] - TOL <= e["ts"]
            and e["ts"] + e["dur"] <= parent["ts"] + parent["dur"] + TOL
        ), "segments nest in the job"
    per_tid = defaultdict(list)
    for e in job_sl.values():
        per_tid[e["tid"]].append((e["ts"], e["ts"] + e["dur"]))
    for spans in per_tid.values():  # jobs on one track never overlap (strict nesting)
        spans.sort()
        for (_, end), (start, _) in zip(spans, spans[1:], strict=False):
            assert start >= end - TOL
    busy_trace = sum(e["dur"] for e in segs if e["cat"] == "compute")
    expected = float(
        (trace.loc[trace["on_cpu"], "end"] - trace.loc[trace["on_cpu"], "start"]).sum()
    )
    assert busy_trace == pytest.approx(expected * US, rel=1e-12)
    misses = [e for e in ev if e["ph"] == "i" and e["name"] == "deadline miss"]
    assert len(misses) == int((jobs["missed"] & ~jobs["skipped"]).sum())
    return {"names": names, "job_slices": job_sl}


def test_simulate_perfetto_matches_jobs_and_trace(tmp_path, capsys) -> None:
    """Preemptions, a backlog (overlapping jobs of one task) and misses, all in the trace."""
    ts = tmp_path / "overload.toml"
    ts.write_text(
        '[[tasks]]\nname = "hi"\nwcet = 3\nperiod = 4\nbcet = 3\n'
        '[[tasks]]\nname = "lo"\nwcet = 3\nperiod = 10\nbcet = 1\n',
        "utf-8",
    )
    out = tmp_path / "t.json"
    rc = main(
        [
            "simulate",
            str(ts),
            "--horizon",
            "200",
            "--exec",
            "uniform",
            "--json",
            "--perfetto",
            str(out),
            "--jobs",
            str(tmp_path / "jobs.csv"),
            "--trace",
            str(tmp_path / "trace.csv"),
        ]
    )
    assert rc == 0
    report = json.loads(capsys.readouterr().out)
    doc = json.loads(out.read_text("utf-8"))
    jobs = pd.read_csv(tmp_path / "jobs.csv")
    trace = pd.read_csv(tmp_path / "trace.csv")
    got = _check_against_tables(doc, jobs, trace)
    busy = sum(e["dur"] for e in doc["traceEvents"] if e.get("cat") == "compute")
    assert busy == pytest.approx(report["busy_time"] * US, rel=1e-12)
    assert jobs["missed"].any() and (jobs["preemptions"] > 0).any()
    lo = jobs[jobs["task"] == "lo"]
    assert (lo["response"] > lo["period"]).any(), "a backlog: 'lo' jobs overlap from release"
    assert set(got["names"].values()) == {"hi", "lo"}  # FIFO: started jobs never overlap


def test_overlapping_jobs_of_one_task_go_to_separate_tracks() -> None:
    """Hand-made: job 1 starts before job 0 finishes (as with a non-FIFO policy)."""
    from rtsim.export.perfetto import trace_events

    jobs = pd.DataFrame(
        {
            "task": ["a", "a", "a"],
            "job": [0, 1, 2],
            "release": [0.0, 1.0, 6.0],
            "start": [0.0, 1.0, 6.0],
            "finish": [5.0, 3.0, 7.0],
            "response": [5.0, 2.0, 1.0],
            "deadline": [4.0, 5.0, 10.0],
            "preemptions": [1, 0, 0],
            "missed": [True, False, False],
            "aborted": [False] * 3,
            "skipped": [False] * 3,
        }
    )
    trace = pd.DataFrame(
        {
            "task": ["a"] * 4,
            "job": [0, 1, 0, 2],
            "segment": ["s"] * 4,
            "kind": ["compute"] * 4,
            "on_cpu": [True] * 4,
            "start": [0.0, 1.0, 3.0, 6.0],
            "end": [1.0, 3.0, 5.0, 7.0],
        }
    )
    ev = trace_events(jobs, trace)
    names = {e["tid"]: e["args"]["name"] for e in ev if e.get("name") == "thread_name"}
    tid = {e["args"]["job"]: names[e["tid"]] for e in ev if e.get("cat") == "job"}
    assert tid == {0: "a", 1: "a (2)", 2: "a"}
    _check_against_tables({"traceEvents": ev}, jobs, trace)


def test_scenario_perfetto_has_the_chain_counters_and_suspension(tmp_path) -> None:
    out = tmp_path / "run"
    f = tmp_path / "trace.json"
    assert (
        main(
            [
                "scenario",
                "test2",
                "--duration",
                "6",
                "--no-figures",
                "--out",
                str(out),
                "--perfetto",
                str(f),
            ]
        )
        == 0
    )
    doc = json.loads(f.read_text("utf-8"))
    jobs = pd.read_csv(out / "jobs.csv")
    windows = pd.read_csv(out / "windows.csv")
    from rtsim.coupling import run_scenario

    trace = run_scenario("test2", duration_s=6, record_trace=True).trace
    _check_against_tables(doc, jobs, trace.to_pandas() if hasattr(trace, "to_pandas") else trace)
    ev = doc["traceEvents"]
    radio = [e for e in ev if e["ph"] == "X" and e["name"] == "radio"]
    assert radio and all(e["cat"] == "suspension" for e in radio)
    assert {e["name"] for e in ev if e["ph"] == "X"} >= {
        "scan",
        "hough",
        "estimate[1]",
        "send[2]",
        "recv[1]",
        "sched",
    }
    counters = [e for e in ev if e["ph"] == "C" and e["name"] == "window (ms)"]
    assert [c["args"]["w"] for c in counters] == pytest.approx(list(windows["w"]))
    assert [c["ts"] for c in counters] == pytest.approx(list(windows["t"] * US))
    speed = [e["args"]["v_leader"] for e in ev if e["ph"] == "C" and "speed" in e["name"]]
    assert speed == pytest.approx(list(windows["v_leader"]))
