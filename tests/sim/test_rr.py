"""The ``rr`` policy (POSIX SCHED_RR): fixed priority across levels, round robin with a time
slice within one level. Hand-computed schedules, a unit-step brute force, and the refusals."""

from __future__ import annotations

import random
import subprocess
import sys

import pytest

from rtsim.config.taskset import load_taskset
from rtsim.errors import InputError
from rtsim.model.task import Segment, Task
from rtsim.model.taskset import TaskSet
from rtsim.sim.cpu import CPU
from rtsim.sim.policy import RoundRobin, resolve_scheduler
from rtsim.sim.run import simulate


def _run(tasks, quantum, horizon=20.0, **kw):
    cpu = CPU(scheduler="rr", quantum=quantum, record_trace=True, **kw)
    for t in tasks:
        cpu.add_task(t)
    cpu.env.run(until=cpu.start(horizon))
    res = cpu.result()
    return {n: s.max_response for n, s in res.tasks.items()}, res


def _pieces(res):
    """(task, start, end) of the execution pieces, in time order."""
    tr = res.trace.sort_values("start")
    return [(r.task, r.start, r.end) for r in tr.itertuples() if r.kind == "compute"]


ABC = (Task("a", 3, 20, priority=1), Task("b", 3, 20, priority=1), Task("c", 2, 20, priority=2))


def test_issue_case_quantum_one() -> None:
    # a, b at level 1 alternate in slices of 1 (a first: file order): a 0-1, b 1-2, a 2-3,
    # b 3-4, a 4-5 (done), b 5-6 (done); c (level 2) 6-8
    got, res = _run(ABC, 1.0)
    assert got == {"a": 5.0, "b": 6.0, "c": 8.0}
    assert _pieces(res) == [
        ("a", 0.0, 1.0),
        ("b", 1.0, 2.0),
        ("a", 2.0, 3.0),
        ("b", 3.0, 4.0),
        ("a", 4.0, 5.0),
        ("b", 5.0, 6.0),
        ("c", 6.0, 8.0),
    ]
    assert res.tasks["a"].preemptions == 2 and res.tasks["b"].preemptions == 2
    assert res.context_switches == 7


def test_quantum_larger_than_the_work() -> None:
    # q = 5 > C: each job finishes inside its first slice: a 0-3, b 3-6, c 6-8
    got, res = _run(ABC, 5.0)
    assert got == {"a": 3.0, "b": 6.0, "c": 8.0}
    assert res.tasks["a"].preemptions == 0 and res.tasks["b"].preemptions == 0


def test_preempted_job_keeps_its_place_and_the_rest_of_its_slice() -> None:
    # h (level 1) arrives at 1.5 inside b's slice [1, 2): b has 0.5 left, keeps the head of
    # level 2 and resumes for that 0.5 (2.5-3); then a 3-4, b 4-5, a 5-6 (done), b 6-7 (done)
    tasks = (
        Task("h", 1, 20, priority=1, offset=1.5),
        Task("a", 3, 20, priority=2),
        Task("b", 3, 20, priority=2),
    )
    got, res = _run(tasks, 1.0)
    assert got == {"h": 1.0, "a": 6.0, "b": 7.0}
    assert _pieces(res)[:4] == [
        ("a", 0.0, 1.0),
        ("b", 1.0, 1.5),
        ("h", 1.5, 2.5),
        ("b", 2.5, 3.0),
    ]


def test_slice_ending_as_a_higher_job_arrives() -> None:
    # a's slice ends at 1 as h arrives: a goes to the tail of level 2 (behind b), h runs
    # 1-2, then b 2-3, a 3-4 (done), b 4-5 (done)
    tasks = (
        Task("h", 1, 20, priority=1, offset=1.0),
        Task("a", 2, 20, priority=2),
        Task("b", 2, 20, priority=2),
    )
    got, _ = _run(tasks, 1.0)
    assert got == {"h": 1.0, "a": 4.0, "b": 5.0}


def test_alone_at_its_level_a_job_is_not_sliced() -> None:
    got, res = _run((Task("a", 3, 20, priority=1), Task("c", 2, 20, priority=2)), 1.0)
    assert got == {"a": 3.0, "c": 5.0}
    assert res.tasks["a"].preemptions == 0 and res.context_switches == 2


def test_overhead_counts_in_the_slice() -> None:
    # o = 0.25 per switch, inside the slice: each slice of a or b does 0.75 of work, so a
    # and b need four slices each: a ends at 7, b at 8; c switches in and runs 8-10.25
    got, res = _run(ABC, 1.0, overhead=0.25)
    assert got == {"a": 7.0, "b": 8.0, "c": 10.25}
    assert res.context_switches == 9


def test_file_order_breaks_ties_of_a_level() -> None:
    tasks = (Task("b", 3, 20, priority=1), Task("a", 3, 20, priority=1), ABC[2])
    got, _ = _run(tasks, 1.0)
    assert got == {"b": 5.0, "a": 6.0, "c": 8.0}


def test_resuming_from_a_suspension_joins_the_tail() -> None:
    # idle suspensions: a computes 0-1, suspends to 2; b runs from 1 and its slice of 1.5
    # ends at 2.5 with a ready: b to the tail; a 2.5-4 (its slice ends, b ready), b 4-5.5
    # (done: 1.5 + 1.5), a 5.5-6 (done)
    a = Task(
        "a",
        4,
        20,
        priority=1,
        segments=(Segment("x", 1), Segment("io", 1, "suspend"), Segment("y", 2)),
    )
    got, _ = _run((a, Task("b", 3, 20, priority=1)), 1.5, suspension="idle")
    assert got == {"a": 6.0, "b": 5.5}


def _brute_rr(tasks: list[tuple[str, int, int, int, int]], q: int, horizon: int) -> dict:
    """Unit steps, written from POSIX: at each instant, releases join the tail of their
    level (in task order); a job whose slice is used up goes to the tail if another job of
    its level waits (a fresh slice either way); the head of the highest non-empty level runs
    one unit. A preempted job keeps its place and the rest of its slice. ``tasks``: (name,
    C, T, priority, offset); a task's jobs run one at a time, a later one joining the tail
    when its predecessor finishes (the sets below have no backlog)."""
    levels: dict[int, list[dict]] = {}
    backlog: dict[str, list[dict]] = {n: [] for n, *_ in tasks}
    out: dict[str, float] = {}
    running = None
    for t in range(20 * horizon):
        for name, c, p, prio, off in tasks:
            if t >= off and (t - off) % p == 0 and t < horizon:
                job = {"name": name, "left": c, "arr": t, "used": 0, "prio": prio}
                backlog[name].append(job)
                if len(backlog[name]) == 1:
                    levels.setdefault(prio, []).append(job)
        if running is not None and running["left"] > 0 and running["used"] == q:
            running["used"] = 0
            queue = levels[running["prio"]]
            if len(queue) > 1:
                queue.remove(running)
                queue.append(running)
        ready = [lv for lv in sorted(levels) if levels[lv]]
        if not ready:
            running = None
            if t >= horizon:
                break
            continue
        running = levels[ready[0]][0]
        running["left"] -= 1
        running["used"] += 1
        if running["left"] == 0:
            name = running["name"]
            out[name] = max(out.get(name, 0), t + 1 - running["arr"])
            levels[running["prio"]].remove(running)
            backlog[name].pop(0)
            if backlog[name]:
                levels[running["prio"]].append(backlog[name][0])
    return out


def test_random_sets_against_the_brute_force() -> None:
    rng = random.Random(4)
    compared = 0
    for _ in range(80):
        n = rng.randint(2, 5)
        tasks = []
        for i in range(n):
            p = rng.choice([10, 12, 15, 20, 30])
            tasks.append((f"t{i}", rng.randint(1, 4), p, rng.randint(1, 3), rng.randint(0, 4)))
        if sum(c / p for _, c, p, _, _ in tasks) > 0.9:
            continue
        tasks.sort(key=lambda t: t[3])  # the CPU's order of equal priorities: as added
        q = rng.randint(1, 3)
        got, res = _run([Task(nm, c, p, priority=pr, offset=o) for nm, c, p, pr, o in tasks], q, 60)
        if any(s.max_backlog > 1 for s in res.tasks.values()):
            continue
        assert got == _brute_rr(tasks, q, 60), (tasks, q)
        compared += 1
    assert compared >= 40


def test_unique_priorities_schedule_as_fp() -> None:
    """With one task per level nothing is sliced: rr's job records are fp's."""
    rng = random.Random(9)
    for _ in range(10):
        tasks = tuple(
            Task(f"t{i}", rng.randint(1, 5), rng.choice([10, 20, 25, 40]), priority=i + 1)
            for i in range(4)
        )
        cols = ["task", "job", "start", "finish", "preemptions"]
        fp = simulate(TaskSet(tasks), 200, record_jobs=True).jobs[cols]
        rr = simulate(TaskSet(tasks, scheduler="rr", quantum=1.0), 200, record_jobs=True)
        assert rr.jobs[cols].equals(fp)


def test_file_keys(tmp_path) -> None:
    f = tmp_path / "rr.toml"
    body = "".join(
        f'[[tasks]]\nname = "{n}"\nwcet = {c}\nperiod = 20\npriority = {p}\n'
        for n, c, p in (("a", 3, 1), ("b", 3, 1), ("c", 2, 2))
    )
    f.write_text('[scheduler]\npolicy = "rr"\nquantum = 1\n' + body)
    ts = load_taskset(f)
    assert ts.scheduler == "rr" and ts.quantum == 1.0
    res = simulate(ts, 20)
    assert {n: s.max_response for n, s in res.tasks.items()} == {"a": 5.0, "b": 6.0, "c": 8.0}
    for head, message in (
        ('[scheduler]\npolicy = "rr"\n', "[scheduler]: quantum: missing (required by"),
        ('[scheduler]\npolicy = "fp"\nquantum = 1\n', "[scheduler]: quantum: only for a"),
        ('[scheduler]\npolicy = "rr"\nquantum = 0\n', "[scheduler]: quantum: must be"),
        ("", "task 'b': priority: 1 is already used by task 'a' (tasks share a priority"),
    ):
        f.write_text(head + body)
        proc = subprocess.run(
            [sys.executable, "-m", "rtsim", "simulate", str(f), "--horizon", "20"],
            capture_output=True,
            text=True,
        )
        assert proc.returncode == 2, proc.stderr
        assert message in proc.stderr and "Traceback" not in proc.stderr
        assert all(line.startswith("rtsim: ") for line in proc.stderr.strip().splitlines())


def test_refusals() -> None:
    with pytest.raises(InputError, match="needs a time slice"):
        CPU(scheduler="rr")
    with pytest.raises(InputError, match="the fp policy is not time-sliced"):
        CPU(scheduler="fp", quantum=1.0)
    with pytest.raises(InputError, match="quantum must be a positive number of ms"):
        CPU(scheduler="rr", quantum=-1.0)
    with pytest.raises(InputError, match="quantum must be a positive number of ms"):
        RoundRobin(True)
    cpu = CPU(scheduler="fp")
    cpu.add_task(Task("a", 1, 10, priority=1))
    with pytest.raises(InputError, match="share a priority only under a time-sliced policy"):
        cpu.add_task(Task("b", 1, 10, priority=1))
    pol = RoundRobin(2.0)
    assert resolve_scheduler(pol) is pol and pol.quantum == 2.0
    assert CPU(scheduler=pol, quantum=1.0).quantum == 1.0 and pol.quantum == 2.0  # a copy
    assert resolve_scheduler("rr").analysis is None
