"""Traces written while the run goes (``--trace``, ``--perfetto``, ``--gantt``) are the files
the whole tables gave: the Perfetto file streamed from records on disk has the bytes of
``write_perfetto`` on the in-memory tables (its tracks, lanes of aborted jobs, unfinished
jobs and counters included), on random task sets too; trace tables written in chunks have
the bytes of ``to_csv``; the Gantt chart drawn from the rows kept for its range is the PNG
drawn from the whole run."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rtsim.cli import main
from rtsim.export.perfetto import stream_perfetto, write_perfetto
from rtsim.io.spool import Spool
from rtsim.model.task import Task
from rtsim.model.taskset import TaskSet
from rtsim.sim import simulate

ROOT = Path(__file__).resolve().parents[2]
BARREL = ROOT / "tasksets" / "barrel_robots.toml"


def _barrel() -> TaskSet:
    from rtsim.config.taskset import load_taskset

    return load_taskset(BARREL)


def _both(
    tmp_path: Path, ts: object, horizon: float, tasks: list[str] | None = None, **kw: object
) -> tuple[bytes, bytes]:
    """(write_perfetto on the whole tables, stream_perfetto from spools) of one run."""
    res = simulate(ts, horizon, record_jobs=True, record_trace=True, **kw)  # type: ignore[arg-type]
    a = write_perfetto(
        tmp_path / "whole.json", res.jobs, res.trace, tasks=tasks, metadata={"seed": 1}
    )
    with Spool(tmp_path / "j.spool") as js, Spool(tmp_path / "t.spool") as tr:
        res2 = simulate(ts, horizon, job_sink=js, trace_sink=tr, **kw)  # type: ignore[arg-type]
        assert res2.jobs is None and res2.trace is None
        b = stream_perfetto(tmp_path / "streamed.json", js, tr, tasks=tasks, metadata={"seed": 1})
    assert not (tmp_path / "j.spool").exists()
    return a.read_bytes(), b.read_bytes()


def _abort_set() -> TaskSet:
    return TaskSet(
        (
            Task(name="hi", wcet=3, bcet=1, period=4, priority=1, jitter=0.5),
            Task(name="mid", wcet=2, bcet=1, period=7, priority=2, overload="abort"),
            Task(name="lo", wcet=4, bcet=1, period=10, priority=3, overload="skip"),
            Task(name="bg", wcet=6, bcet=2, period=25, priority=4),
        )
    )


def test_streamed_perfetto_is_byte_identical_with_aborted_lanes(tmp_path: Path) -> None:
    """Aborted jobs that had started block their lane (the tracks 'mid (2)', ...)."""
    a, b = _both(tmp_path, _abort_set(), 3000.0, exec_model="uniform", seed=7, overhead=0.05)
    assert a == b
    assert b'"mid (3)"' in b, "the run puts aborted jobs' successors on further tracks"


def test_streamed_perfetto_shows_blocking_as_the_whole_tables_do(tmp_path: Path) -> None:
    """A job waiting for a shared resource is a ``blocked`` slice in the streamed file too
    (``rtsim simulate --perfetto`` streams; it once labelled the wait a suspension)."""
    from rtsim.model.task import CriticalSection as CS

    ts = TaskSet(
        (
            Task("H", 2, 50, priority=1, offset=1, critical_sections=(CS("R", 0, 1),)),
            Task("L", 6, 50, priority=3, critical_sections=(CS("R", 0, 4),)),
        )
    )
    a, b = _both(tmp_path, ts, 50.0)
    assert a == b
    assert b.count(b'"cat":"blocked"') == 1 and b'"blocked by L on R"' in b


@pytest.mark.parametrize(
    "kw",
    [
        {"window": 150.0, "suspension": "idle", "seed": 2},  # overloaded: a backlog, suspensions
        {"window": 135.0, "suspension": "cpu", "jitter": "worst"},
        {"window": 300.0, "scheduler": "edf", "seed": 4},
    ],
)
def test_streamed_perfetto_is_byte_identical_on_the_papers_set(tmp_path: Path, kw: dict) -> None:
    a, b = _both(tmp_path, _barrel(), 4000.0, tasks=None, **kw)
    assert a == b and len(a) > 10_000


@settings(max_examples=25, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.integers(1, 6), st.integers(3, 30), st.sampled_from(["finish-late", "abort", "skip"])
        ),
        min_size=1,
        max_size=4,
    ),
    st.integers(0, 3),
)
def test_streamed_perfetto_equals_whole_tables_on_random_sets(
    tmp_path_factory: pytest.TempPathFactory, spec: list, seed: int
) -> None:
    tasks = tuple(
        Task(
            name=f"t{i}",
            wcet=float(c),
            bcet=max(0.5, c / 3),
            period=float(p),
            priority=i + 1,
            overload=o,
        )
        for i, (c, p, o) in enumerate(spec)
    )
    tmp = tmp_path_factory.mktemp("rand")
    a, b = _both(
        tmp, TaskSet(tasks), 300.0, tasks=[t.name for t in tasks], exec_model="uniform", seed=seed
    )
    assert a == b


def test_records_out_of_start_order_fall_back_to_the_whole_tables(tmp_path: Path) -> None:
    """Job 1 starts before job 0 finishes and comes first (not how a run records them):
    the streaming writer notices and builds the tables, with the same bytes."""
    from rtsim.sim.records import JOB_COLUMNS, TRACE_COLUMNS

    jobs = pd.DataFrame(
        {
            "task": ["a", "a", "a"],
            "job": [1, 0, 2],
            "release": [1.0, 0.0, 6.0],
            "start": [1.0, 0.0, 6.0],
            "finish": [3.0, 5.0, 7.0],
            "response": [2.0, 5.0, 1.0],
            "deadline": [5.0, 4.0, 10.0],
            "period": [5.0] * 3,
            "missed": [False, True, False],
            "preemptions": [0, 1, 0],
            "aborted": [False] * 3,
            "skipped": [False] * 3,
            "exec_time": [2.0, 3.0, 1.0],
            "arrival": [1.0, 0.0, 6.0],
        }
    )
    trace = pd.DataFrame(
        {
            "task": ["a"] * 5,
            "job": [0, 1, 0, 2, 3],
            "segment": ["s"] * 5,
            "kind": ["compute"] * 5,
            "on_cpu": [True] * 5,
            "start": [0.0, 1.0, 3.0, 6.0, 8.0],
            "end": [1.0, 3.0, 5.0, 7.0, 9.0],
        }
    )
    from rtsim.sim.records import jobs_frame, trace_frame

    jobs, trace = jobs_frame(jobs[list(JOB_COLUMNS)]), trace_frame(trace[list(TRACE_COLUMNS)])
    a = write_perfetto(tmp_path / "a.json", jobs, trace)
    with Spool(tmp_path / "j") as js, Spool(tmp_path / "t") as tr:
        js.write_rows(list(jobs.itertuples(index=False, name=None)))
        tr.write_rows(list(trace.itertuples(index=False, name=None)))
        b = stream_perfetto(tmp_path / "b.json", js, tr)
    assert a.read_bytes() == b.read_bytes()
    assert b'"a (2)"' in a.read_bytes() and b"(unfinished)" in a.read_bytes()


def test_scenario_perfetto_streamed_equals_whole_tables(tmp_path: Path) -> None:
    from rtsim.coupling import run_scenario
    from rtsim.io.columns import read_columns

    out = tmp_path / "run"
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
                str(tmp_path / "p.json"),
            ]
        )
        == 0
    )
    res = run_scenario("test2", duration_s=6, record_trace=True)
    tasks = [t.name for t in sorted(res.inputs.taskset.tasks, key=lambda t: t.priority)]
    ref = write_perfetto(
        tmp_path / "ref.json",
        res.jobs,
        res.trace,
        tasks=tasks,
        windows=read_columns(out / "windows.csv"),
        metadata={
            "command": "scenario",
            "scenario": res.summary["scenario"],
            "mode": res.summary["mode"],
            "seed": 0,
        },
    )
    assert (tmp_path / "p.json").read_bytes() == ref.read_bytes()
    assert b"(unfinished)" in ref.read_bytes()
    assert (out / "jobs.csv").read_bytes() == res.jobs.to_csv(index=False).encode()
    assert not [p for p in out.iterdir() if p.name.startswith(".")], "no scratch file left"


def test_simulate_trace_gantt_and_jobs_are_the_whole_tables_files(
    tmp_path: Path, monkeypatch
) -> None:
    """--trace/--jobs written in chunks (tiny chunks: many of them) have the bytes of
    to_csv on the whole tables; the Gantt PNG drawn from the rows kept for its range is the
    one drawn from the whole run."""
    import rtsim.sim.records as records
    from rtsim.cli.simulate import GANTT_DPI, _save_gantt

    monkeypatch.setattr(records, "CHUNK_ROWS", 64)
    args = ["--horizon", "3000", "--window", "150", "--suspension", "idle", "--seed", "2"]
    assert (
        main(
            [
                "simulate",
                str(BARREL),
                *args,
                "--trace",
                str(tmp_path / "t.csv"),
                "--jobs",
                str(tmp_path / "j.csv"),
                "--gantt",
                str(tmp_path / "g.png"),
                "--gantt-range",
                "100..900",
            ]
        )
        == 0
    )
    res = simulate(
        _barrel(),
        3000.0,
        window=150.0,
        suspension="idle",
        seed=2,
        record_jobs=True,
        record_trace=True,
    )
    assert (tmp_path / "t.csv").read_bytes() == res.trace.to_csv(index=False).encode()
    assert (tmp_path / "j.csv").read_bytes() == res.jobs.to_csv(index=False).encode()
    _save_gantt(res, str(tmp_path / "ref.png"), (100.0, 900.0), "png", GANTT_DPI)
    assert (tmp_path / "g.png").read_bytes() == (tmp_path / "ref.png").read_bytes()


def test_a_long_gantt_range_is_cut_and_says_so(tmp_path: Path, monkeypatch) -> None:
    import importlib

    g = importlib.import_module("rtsim.plots.gantt")  # (rtsim.plots.gantt is also a function)
    monkeypatch.setattr(g, "GANTT_MAX_JOBS", 50)
    titles: list[str] = []
    real = g.gantt
    monkeypatch.setattr(g, "gantt", lambda *a, **k: titles.append(k["title"]) or real(*a, **k))
    assert (
        main(
            [
                "simulate",
                str(ROOT / "tasksets" / "example.toml"),
                "--horizon",
                "20000",
                "--gantt",
                str(tmp_path / "g.png"),
                "--gantt-range",
                "0..10000",
            ]
        )
        == 0
    )
    # 50 jobs of (40, 250, 500 ms periods): 10000 ms hold 250 + 40 + 20 = 310 jobs
    assert titles == [
        f"schedule 0..{10000 * 50 / 310:g} ms (of ..10000 ms: at most 50 jobs are drawn)"
    ]
