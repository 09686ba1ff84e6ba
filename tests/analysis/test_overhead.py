"""Context-switch overhead in the analysis, matched to the simulator's ``overhead`` (SPEC §8)."""

from __future__ import annotations

import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rtsim.analysis.rta import analyze, response_time, stretches
from rtsim.cli import main
from rtsim.config.taskset import load_taskset, parse_taskset
from rtsim.errors import TaskSetError
from rtsim.model.task import Segment, Task
from rtsim.model.taskset import TaskSet
from rtsim.sim import simulate


def test_hand_worked_overhead():
    # o = 0.5: hp costs 1 + 2·0.5 = 2, lo costs 3 + 0.5 = 3.5; R = 3.5 + 2⌈R/5⌉ → 5.5, 7.5, 7.5.
    hp, lo = Task("h", 1, 5, priority=1), Task("l", 3, 20, priority=2)
    assert response_time(lo, [hp], 0.5) == 7.5
    assert response_time(hp, [], 0.5) == 1.5
    res = simulate([hp, lo], 100, overhead=0.5)
    assert res.tasks["l"].max_response <= 7.5 and res.tasks["h"].max_response == 1.5


def test_stretches_count_compute_runs_between_suspensions():
    segs = (Segment("a", 1), Segment("b", 1), Segment("r", 5, "suspend"), Segment("c", 1))
    assert stretches(Task("w", 8, 40, segments=segs)) == 2
    assert stretches(Task("p", 1, 4)) == 1
    assert stretches(load_taskset().at_window(300.0).task("window")) == 2


@st.composite
def overhead_sets(draw: st.DrawFn) -> tuple[list[Task], float, str, str]:
    n = draw(st.integers(2, 4))
    tasks = []
    for k in range(n):
        segs = tuple(
            Segment(
                f"s{i}",
                draw(st.sampled_from([0.25, 0.5, 1.0, 1.5, 3.0])),
                draw(st.sampled_from(["compute", "compute", "suspend"])),
            )
            for i in range(draw(st.integers(1, 3)))
        )
        period = float(draw(st.integers(8, 60)))
        tasks.append(
            Task(
                f"t{k}",
                sum(s.wcet for s in segs),
                period,
                priority=k + 1,
                offset=draw(st.sampled_from([0.0, 0.0, period / 3])),
                jitter=draw(st.sampled_from([0.0, 0.0, 1.0, 2.5])),
                segments=segs,
            )
        )
    o = draw(st.sampled_from([0.0, 0.05, 0.2, 0.5]))
    return (
        tasks,
        o,
        draw(st.sampled_from(["cpu", "idle"])),
        draw(st.sampled_from(["worst", "random"])),
    )


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(overhead_sets())
def test_simulated_overhead_within_analysis(spec):
    tasks, o, mode, jitter = spec
    ana = analyze(TaskSet(tuple(tasks)), overhead=o)
    res = simulate(tasks, 600.0, overhead=o, suspension=mode, jitter=jitter, seed=2)
    for a in ana.tasks:
        if a.schedulable:
            sim = res.tasks[a.name]
            assert sim.misses == 0
            assert sim.max_response is None or sim.max_response <= a.wcrt + 1e-9, (a, sim)


def test_analysis_without_overhead_can_be_optimistic():
    # The same set: without charging o the analysis says 5.0, the simulation shows more.
    hp, lo = Task("h", 1, 5, priority=1), Task("l", 3, 20, priority=2)
    assert response_time(lo, [hp]) == 4.0
    assert simulate([hp, lo], 100, overhead=0.5).tasks["l"].max_response > 4.0


def test_file_key_and_cli(tmp_path, capsys):
    f = tmp_path / "o.toml"
    f.write_text(
        'overhead = 0.5\n[[tasks]]\nname = "h"\nwcet = 1\nperiod = 5\n'
        '[[tasks]]\nname = "l"\nwcet = 3\nperiod = 20\noffset = 2\n'
    )
    assert load_taskset(f).overhead == 0.5
    assert main(["analyze", str(f), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["overhead"] == 0.5 and out["offsets_ignored"] is True
    assert [t["wcrt"] for t in out["tasks"]] == [1.5, 7.5]
    assert main(["analyze", str(f), "--overhead", "0"]) == 0
    text = capsys.readouterr().out
    assert "offsets: ignored" in text and "overhead" not in text
    assert main(["simulate", str(f), "--horizon", "100", "--json"]) == 0
    sim = json.loads(capsys.readouterr().out)
    assert sim["overhead"] == 0.5 and sim["tasks"][1]["wcrt_analysis"] == 7.5
    assert main(["analyze", str(f), "--overhead", "-1"]) == 2
    with pytest.raises(TaskSetError, match="x.toml: overhead: must be non-negative"):
        parse_taskset({"overhead": -1, "tasks": [{"name": "a", "wcet": 1, "period": 2}]}, "x.toml")
