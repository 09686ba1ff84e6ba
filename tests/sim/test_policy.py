"""The scheduling-policy interface of the virtual CPU: fp and edf by name, hand-worked EDF
schedules (ties, suspensions, overload, jitter), a third policy written here in a few lines
(non-preemptive fixed priority: the one-file change docs/scheduling.md shows), and the
``[scheduler] policy`` key and ``--scheduler`` option."""

from __future__ import annotations

import json
from typing import Any

import pandas as pd
import pytest

from rtsim.cli import main
from rtsim.config.taskset import load_taskset, parse_taskset, taskset_to_dict
from rtsim.errors import InputError, TaskSetError
from rtsim.model.task import Segment, Task
from rtsim.sim import CPU, simulate
from rtsim.sim.policy import (
    SCHEDULERS,
    EarliestDeadlineFirst,
    FixedPriority,
    SchedulingPolicy,
    register_scheduler,
    resolve_scheduler,
)


class NonPreemptiveFP(FixedPriority):
    """Fixed priority, non-preemptive: a running job keeps the CPU until it completes or
    suspends (the whole policy: a name and a preemption test)."""

    name = "np-fp"

    def preempts(self, key: Any, running: Any) -> bool:
        return False


@pytest.fixture
def np_fp():
    register_scheduler(NonPreemptiveFP)
    yield NonPreemptiveFP
    SCHEDULERS.pop("np-fp", None)


def rows(
    res: Any, cols: tuple[str, ...] = ("task", "job", "start", "finish", "preemptions")
) -> list[tuple]:
    df = res.jobs.sort_values(["start", "task"])
    return [tuple(r) for r in df[list(cols)].itertuples(index=False)]


def test_registry_and_resolution(np_fp):
    assert isinstance(resolve_scheduler("fp"), FixedPriority)
    assert isinstance(resolve_scheduler("edf"), EarliestDeadlineFirst)
    assert isinstance(resolve_scheduler("np-fp"), NonPreemptiveFP)
    assert isinstance(resolve_scheduler(NonPreemptiveFP), NonPreemptiveFP)
    edf = resolve_scheduler("rtsim.sim.policy:EarliestDeadlineFirst")  # by module:Name
    assert isinstance(edf, EarliestDeadlineFirst)
    pol = EarliestDeadlineFirst()
    assert resolve_scheduler(pol) is pol
    with pytest.raises(
        InputError,
        match=r"--scheduler: must be one of fp, edf, rr, np-fp or "
        r"'package.module:Name', got 'edd' "
        r"\(did you mean 'edf'\?\)",
    ):
        resolve_scheduler("edd", where="--scheduler")
    with pytest.raises(InputError, match="cannot load 'nosuchmod:X'"):
        resolve_scheduler("nosuchmod:X")
    with pytest.raises(InputError, match="is not a SchedulingPolicy subclass"):
        resolve_scheduler("rtsim.sim.policy:SCHEDULERS")
    with pytest.raises(TypeError, match="name must be a non-empty string"):
        register_scheduler(type("Nameless", (SchedulingPolicy,), {}))


def test_edf_hand_schedule():
    # a = (2, 5), b = (4, 7), U = 0.971, b above a under FP; EDF meets every deadline.
    # Worked by hand:
    # 0-2 a0 (d5), 2-6 b0 (d7), 6-8 a1 (d10, arrived 5: b0's d7 is earlier), 8-12 b1 (d14),
    # 12-14 a2 (d15), 14-15 b2 (d21), 15-17 a3 (d20 < 21: preempts b2), 17-20 b2, 20-22 a4,
    # 22-26 b3 (d28), 26-28 a5 (d30), 28-32 b4 (d35), 32-34 a6 (d35 = b4's: b4 keeps the CPU)
    ts = [Task("a", 2, 5, priority=2), Task("b", 4, 7, priority=1)]
    res = simulate(ts, 35, scheduler="edf", record_jobs=True)
    assert res.misses == 0 and res.scheduler == "edf"
    assert rows(res) == [
        ("a", 0, 0, 2, 0),
        ("b", 0, 2, 6, 0),
        ("a", 1, 6, 8, 0),
        ("b", 1, 8, 12, 0),
        ("a", 2, 12, 14, 0),
        ("b", 2, 14, 20, 1),
        ("a", 3, 15, 17, 0),
        ("a", 4, 20, 22, 0),
        ("b", 3, 22, 26, 0),
        ("a", 5, 26, 28, 0),
        ("b", 4, 28, 32, 0),
        ("a", 6, 32, 34, 0),
    ]
    fp = simulate(ts, 35, record_jobs=True)
    assert fp.misses > 0  # b above a: a's job 0 finishes at 6 > 5


def test_edf_equal_deadline_does_not_preempt_and_ties_go_by_arrival():
    # p (3, d 6) runs from 0; q arrives at 2 with the same absolute deadline 6: no preemption
    ts = [Task("p", 3, 20, 6, priority=2), Task("q", 1, 20, 4, priority=1, offset=2)]
    assert rows(simulate(ts, 20, scheduler="edf", record_jobs=True)) == [
        ("p", 0, 0, 3, 0),
        ("q", 0, 3, 4, 0),
    ]
    # with q's deadline one ms earlier it preempts
    ts[1] = Task("q", 1, 20, 3, priority=1, offset=2)
    assert rows(simulate(ts, 20, scheduler="edf", record_jobs=True)) == [
        ("p", 0, 0, 4, 1),
        ("q", 0, 2, 3, 0),
    ]
    # z (d 3) holds the CPU until 3; m (arrived 0) and n (arrived 1, priority 1) both have
    # deadline 6: the earlier arrival, m, goes first although n has the higher priority
    ts = [
        Task("z", 3, 20, 3, priority=3),
        Task("m", 1, 20, 6, priority=2),
        Task("n", 1, 20, 5, priority=1, offset=1),
    ]
    assert rows(simulate(ts, 20, scheduler="edf", record_jobs=True)) == [
        ("z", 0, 0, 3, 0),
        ("m", 0, 3, 4, 0),
        ("n", 0, 4, 5, 0),
    ]
    # equal deadline and arrival: the task order (priority) decides
    ts = [Task("u", 1, 5, priority=2), Task("v", 1, 5, priority=1)]
    assert rows(simulate(ts, 5, scheduler="edf", record_jobs=True)) == [
        ("v", 0, 0, 1, 0),
        ("u", 0, 1, 2, 0),
    ]


def test_edf_with_an_idle_suspension_and_cpu_mode():
    # w: compute 2, suspend 3, compute 1, d 10; s: 4 ms, d 8. EDF: s first (d 8 < 10)
    w = Task(
        "w",
        6,
        10,
        priority=1,
        segments=(Segment("c1", 2), Segment("radio", 3, "suspend"), Segment("c2", 1)),
    )
    s = Task("s", 4, 10, 8, priority=2)
    idle = simulate([w, s], 10, scheduler="edf", suspension="idle", record_jobs=True)
    assert rows(idle) == [("s", 0, 0, 4, 0), ("w", 0, 4, 10, 0)]
    cpu = simulate([w, s], 10, scheduler="edf", suspension="cpu", record_jobs=True)
    assert rows(cpu) == [("s", 0, 0, 4, 0), ("w", 0, 4, 10, 0)]
    # FP (w above s), idle: w 0-2, s 2-5, w resumes at 5 and preempts s: 5-6, s 6-7
    fp = simulate([w, s], 10, suspension="idle", record_jobs=True)
    assert rows(fp) == [("w", 0, 0, 6, 0), ("s", 0, 2, 7, 1)]
    # under EDF a suspended job that resumes with an earlier deadline preempts
    w2 = Task("w", 6, 10, 7, priority=1, segments=w.segments)
    s2 = Task("s", 4, 10, 9, priority=2)
    r = simulate([w2, s2], 10, scheduler="edf", suspension="idle", record_jobs=True)
    assert rows(r) == [("w", 0, 0, 6, 0), ("s", 0, 2, 7, 1)]


def test_edf_abort_skip_and_jitter():
    # overloaded: x (3, 5, d 4, abort) and y (3, 5, d 5): EDF runs x first each period
    x = Task("x", 3, 5, 4, priority=2, overload="abort")
    y = Task("y", 3, 5, 5, priority=1, overload="skip")
    res = simulate([x, y], 15, scheduler="edf", record_jobs=True)
    jobs = res.jobs.set_index(["task", "job"])
    # 0-3 x0 (d 4 < 5), 3-6 y0 (late: d 5), so y1 (arrives at 5) is skipped; x1 (d 9) waits
    # for y0 (d 5 is earlier) and runs 6-9
    assert (jobs.loc[("x", 0), "finish"], jobs.loc[("y", 0), "finish"]) == (3.0, 6.0)
    assert bool(jobs.loc[("y", 0), "missed"]) and bool(jobs.loc[("y", 1), "skipped"])
    assert jobs.loc[("x", 1), "finish"] == 9.0
    # worst-case jitter: a's first job released at t0 = J_a = 2 with deadline 5 (from arrival
    # 0); b (d 6) arrived at 2, released at once; a goes first (d 5 < 8)
    a = Task("a", 2, 10, 5, priority=2, jitter=2.0)
    b = Task("b", 2, 10, 6, priority=1)
    r = simulate([a, b], 10, scheduler="edf", jitter="worst", record_jobs=True)
    assert rows(r, ("task", "job", "arrival", "release", "start", "finish")) == [
        ("a", 0, 0, 2, 2, 4),
        ("b", 0, 2, 2, 4, 6),
    ]


def test_third_policy_is_one_class(np_fp):
    # lo runs 0-3; hi (released at 1) waits for it under np-fp, preempts it under fp
    ts = [Task("hi", 1, 5, priority=1, offset=1), Task("lo", 3, 10, priority=2)]
    np_rows = rows(simulate(ts, 6, scheduler="np-fp", record_jobs=True))
    assert np_rows == [("lo", 0, 0, 3, 0), ("hi", 0, 3, 4, 0)]
    fp_rows = rows(simulate(ts, 6, record_jobs=True))
    assert fp_rows == [("lo", 0, 0, 4, 1), ("hi", 0, 1, 2, 0)]
    # a class given directly works too, and a suspension still lets the next job in
    w = Task(
        "w",
        4,
        20,
        priority=2,
        segments=(Segment("c", 1), Segment("r", 2, "suspend"), Segment("d", 1)),
    )
    h = Task("h", 3, 20, priority=1, offset=0.5)
    r = simulate([w, h], 20, scheduler=NonPreemptiveFP, suspension="idle", record_jobs=True)
    # w 0-1, suspends 1-3; h runs 1-4 (w resumed at 3 waits); w 4-5
    assert rows(r) == [("w", 0, 0, 5, 0), ("h", 0, 1, 4, 0)]


def test_taskset_file_scheduler_key(tmp_path):
    text = (
        'name = "s"\n[scheduler]\npolicy = "edf"\n[[tasks]]\nname = "a"\nwcet = 2\n'
        'period = 5\n[[tasks]]\nname = "b"\nwcet = 4\nperiod = 7\n'
    )
    f = tmp_path / "s.toml"
    f.write_text(text)
    ts = load_taskset(f)
    assert ts.scheduler == "edf"
    assert simulate(ts, 35).scheduler == "edf"
    assert simulate(ts, 35).misses == 0 and simulate(ts, 35, scheduler="fp").misses > 0
    d = taskset_to_dict(ts)
    assert d["scheduler"] == {"policy": "edf"}
    assert parse_taskset(d, "again").scheduler == "edf"
    assert "scheduler" not in taskset_to_dict(load_taskset())  # fp: not written
    for bad, match in (
        (
            '[scheduler]\npolicy = "edd"\n',
            r"s.toml: \[scheduler\]: policy: must be one "
            r"of fp, edf, rr.*, got 'edd'",
        ),
        (
            '[scheduler]\npolcy = "edf"\n',
            r"s.toml: \[scheduler\]: unknown key 'polcy' "
            r"\(did you mean 'policy'\?\)",
        ),
        ('scheduler = "edf"\n', r"s.toml: \[scheduler\]: must be a table"),
        ("[scheduler]\npolicy = 3\n", r"policy: must be a policy name, got 3"),
    ):
        f.write_text(bad + text.split('\n[scheduler]\npolicy = "edf"\n')[1])
        with pytest.raises(TaskSetError, match=match):
            load_taskset(f)


def test_cli_scheduler_option(tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text(
        '[[tasks]]\nname = "a"\nwcet = 2\nperiod = 5\n[[tasks]]\nname = "b"\nwcet = 4\nperiod = 7\n'
    )
    jobs = tmp_path / "out" / "jobs.csv"
    assert (
        main(
            [
                "simulate",
                str(f),
                "--horizon",
                "35",
                "--scheduler",
                "edf",
                "--json",
                "--jobs",
                str(jobs),
            ]
        )
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    assert out["scheduler"] == "edf" and out["misses"] == 0
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["inputs"]["scheduler"] == "edf"
    df = pd.read_csv(jobs)
    assert df[df["task"] == "b"]["preemptions"].sum() == 1
    assert main(["simulate", str(f), "--horizon", "35", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["scheduler"] == "fp"
    assert main(["simulate", str(f), "--horizon", "35", "--scheduler", "edd"]) == 2
    assert "--scheduler: must be one of fp, edf" in capsys.readouterr().err


def test_cpu_object_takes_a_policy_and_hooks_run_under_edf():
    cpu = CPU(scheduler="edf", record_jobs=True)
    seen: list[tuple[str, int, float]] = []
    cpu.on("job_end", lambda job: seen.append((job.name, job.index, cpu.env.now)))
    cpu.add_task(Task("a", 2, 5, priority=2))
    cpu.add_task(Task("b", 4, 7, priority=1))
    cpu.env.run(until=cpu.start(14))
    assert seen[:4] == [("a", 0, 2.0), ("b", 0, 6.0), ("a", 1, 8.0), ("b", 1, 12.0)]
    assert cpu.result().scheduler == "edf"


def test_the_docs_example_is_a_one_file_policy(tmp_path, monkeypatch, capsys):
    """docs/scheduling.md's example, written to a file as it stands, used by path."""
    import re
    import sys
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[2] / "docs" / "scheduling.md").read_text()
    code = re.search(r"```python\n(# my_policies.py\n.+?)```", doc, flags=re.S).group(1)
    (tmp_path / "my_policies.py").write_text(code)
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        ts = tmp_path / "s.toml"
        ts.write_text(
            '[scheduler]\npolicy = "my_policies:NonPreemptiveFP"\n'
            '[[tasks]]\nname = "hi"\nwcet = 1\nperiod = 5\noffset = 1\npriority = 1\n'
            '[[tasks]]\nname = "lo"\nwcet = 3\nperiod = 10\npriority = 2\n'
        )
        jobs = tmp_path / "jobs.csv"
        assert main(["simulate", str(ts), "--horizon", "6", "--jobs", str(jobs)]) == 2
        assert "--allow-code" in capsys.readouterr().err  # a file names code: refused
        assert (
            main(["simulate", str(ts), "--horizon", "6", "--jobs", str(jobs), "--allow-code"]) == 0
        )
        df = pd.read_csv(jobs).sort_values("start")
        assert list(zip(df["task"], df["start"], df["finish"], strict=True)) == [
            ("lo", 0.0, 3.0),
            ("hi", 3.0, 4.0),
        ]
        assert "scheduler np-fp" in capsys.readouterr().out
        assert "np-fp" in SCHEDULERS  # the decorator registered it on import
    finally:
        SCHEDULERS.pop("np-fp", None)
        sys.modules.pop("my_policies", None)
