"""Execution-time models and the determinism of random runs."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import rtsim.sim
from rtsim.errors import InputError
from rtsim.model.task import Segment, Task
from rtsim.sim import WCET, Empirical, Uniform, simulate, task_rngs


def test_public_api_is_pinned():
    assert sorted(rtsim.sim.__all__) == sorted(
        [
            "CPU",
            "EPS",
            "Empirical",
            "ExecModel",
            "HOOK_EVENTS",
            "HookEvent",
            "JOB_COLUMNS",
            "Job",
            "ResponseHistogram",
            "SimResult",
            "TRACE_COLUMNS",
            "TaskStats",
            "Uniform",
            "WCET",
            "build_cpu",
            "resolve_exec_model",
            "resolve_window",
            "simulate",
            "task_rngs",
            "EarliestDeadlineFirst",
            "FixedPriority",
            "SCHEDULERS",
            "SchedulingPolicy",
            "register_scheduler",
            "resolve_scheduler",
        ]
    )
    for name in rtsim.sim.__all__:
        assert hasattr(rtsim.sim, name)


def _exec_times(res, task):
    j = res.jobs[(res.jobs["task"] == task) & res.jobs["finish"].notna()].sort_values("job")
    return list(j["exec_time"])


def test_wcet_is_the_default():
    res = simulate([Task("a", 2.5, 10, priority=1, bcet=1)], 50, record_jobs=True)
    assert _exec_times(res, "a") == [2.5] * 5


def test_uniform_bounds_and_mean():
    # task bcet 1, wcet 3: draws in [1, 3], mean 2 (sd 1/sqrt(3)); 2000 jobs -> 4 sigma 0.052
    res = simulate(
        [Task("a", 3, 10, priority=1, bcet=1)],
        20_000,
        exec_model="uniform",
        seed=1,
        record_jobs=True,
    )
    x = np.array(_exec_times(res, "a"))
    assert len(x) == 2000
    assert x.min() >= 1 and x.max() <= 3
    assert abs(x.mean() - 2.0) < 4 * (2 / np.sqrt(12)) / np.sqrt(len(x))
    assert len(set(x)) == len(x)  # continuous draws


def test_uniform_segment_bcets():
    # segment bcet wins; else task bcet scaled by segment share; no bcet -> wcet
    segs = (Segment("x", 4, bcet=4), Segment("y", 2))
    t = Task("c", 6, 100, priority=1, bcet=3, segments=segs)  # y: bcet 3*2/6 = 1
    res = simulate([t], 1000, exec_model="uniform", record_trace=True)
    tr = res.trace
    x = tr[tr["segment"] == "x"]
    y = tr[tr["segment"] == "y"]
    assert np.allclose(x["end"] - x["start"], 4.0)
    dy = (y["end"] - y["start"]).to_numpy()
    assert dy.min() >= 1.0 and dy.max() <= 2.0 and dy.std() > 0
    res2 = simulate([Task("d", 6, 100, priority=1)], 500, exec_model="uniform", record_jobs=True)
    assert _exec_times(res2, "d") == [6.0] * 5


def test_same_seed_same_trace_other_seed_differs():
    ts = [
        Task("a", 2, 7, priority=1, bcet=0.5),
        Task("b", 4, 11, priority=2, bcet=1),
        Task("c", 3, 17, priority=3, bcet=0.1),
    ]
    r1 = simulate(ts, 500, exec_model="uniform", seed=42, record_trace=True, record_jobs=True)
    r2 = simulate(ts, 500, exec_model="uniform", seed=42, record_trace=True, record_jobs=True)
    r3 = simulate(ts, 500, exec_model="uniform", seed=43, record_trace=True)
    pd.testing.assert_frame_equal(r1.trace, r2.trace)
    pd.testing.assert_frame_equal(r1.jobs, r2.jobs)
    assert not r1.trace.equals(r3.trace)
    g1 = simulate(ts, 500, exec_model="uniform", seed=np.random.default_rng(5), record_jobs=True)
    g2 = simulate(ts, 500, exec_model="uniform", seed=np.random.default_rng(5), record_jobs=True)
    pd.testing.assert_frame_equal(g1.jobs, g2.jobs)


def test_adding_a_task_does_not_reshuffle_the_others():
    a = Task("a", 2, 10, priority=2, bcet=0.5)
    b = Task("b", 3, 10, priority=3, bcet=0.5)
    extra = Task("zz", 1, 5, priority=1, bcet=0.2)  # new and of highest priority
    r1 = simulate([a, b], 300, exec_model="uniform", seed=7, record_jobs=True)
    r2 = simulate([extra, a, b], 300, exec_model="uniform", seed=7, record_jobs=True)
    # (equal up to rounding: preemptions by zz split the CPU time into pieces)
    assert _exec_times(r2, "a") == pytest.approx(_exec_times(r1, "a"), rel=1e-12)
    assert _exec_times(r2, "b") == pytest.approx(_exec_times(r1, "b"), rel=1e-12)
    # and the per-task stream is what task_rngs documents
    rng = task_rngs(7, ["a"])["a"]
    assert _exec_times(r1, "a")[:3] == pytest.approx(list(rng.uniform(0.5, 2.0, size=3)), rel=1e-12)


def test_empirical_replay_and_bootstrap(tmp_path):
    csv = tmp_path / "times.csv"
    csv.write_text("task,segment,exec_time\na,,1.0\na,,2.0\na,,1.5\nc,x,0.5\nc,x,0.25\n")
    model = Empirical.from_csv(csv)
    assert model.samples[("a", "a")] == (1.0, 2.0, 1.5)
    ts = [
        Task("a", 3, 10, priority=1),
        Task("c", 3, 10, priority=2, segments=(Segment("x", 1), Segment("y", 2))),
    ]
    res = simulate(ts, 70, exec_model=model, record_jobs=True, record_trace=True)
    assert _exec_times(res, "a") == [1.0, 2.0, 1.5, 1.0, 2.0, 1.5, 1.0]
    tr = res.trace
    x = tr[tr["segment"] == "x"].sort_values("job")
    assert list(x["end"] - x["start"]) == [0.5, 0.25] * 3 + [0.5]
    y = tr[tr["segment"] == "y"]
    assert np.allclose(y["end"] - y["start"], 2.0)  # no samples: WCET fallback
    boot = Empirical.from_csv(csv, mode="bootstrap")
    r1 = simulate(ts, 700, exec_model=boot, seed=3, record_jobs=True)
    r2 = simulate(ts, 700, exec_model=boot, seed=3, record_jobs=True)
    xa = _exec_times(r1, "a")
    assert set(xa) == {1.0, 2.0, 1.5} and xa == _exec_times(r2, "a")


def test_empirical_without_segment_column(tmp_path):
    csv = tmp_path / "t.csv"
    csv.write_text("task,exec_time\na,0.5\n")
    res = simulate(
        [Task("a", 3, 10, priority=1)], 30, exec_model=Empirical.from_csv(csv), record_jobs=True
    )
    assert _exec_times(res, "a") == [0.5] * 3


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("task,time\na,1\n", "missing column 'exec_time'"),
        ("task,exec_time\na,-1\n", "row 2: exec_time must be a non-negative number"),
        ("task,exec_time\na,fast\n", "row 2: exec_time must be"),
    ],
)
def test_empirical_bad_files(tmp_path, text, match):
    csv = tmp_path / "bad.csv"
    csv.write_text(text)
    with pytest.raises(InputError, match=match):
        Empirical.from_csv(csv)


def test_models_are_callables_with_one_signature():
    t = Task("a", 3, 10, bcet=1)
    rng = np.random.default_rng(0)

    class J:  # the fields a model may read
        task = t
        name = "a"
        index = 0

    seg = t.chain()[0]
    assert WCET()(J(), seg, rng) == 3.0
    v = Uniform()(J(), seg, rng)
    assert 1.0 <= v <= 3.0
