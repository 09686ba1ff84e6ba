"""The virtual CPU: tie-breaks, hooks, suspensions, overload policies, overhead, windows.

Every expected value here is worked out by hand from the schedule described in the comment.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import simpy

from rtsim.errors import InputError, RtsimError
from rtsim.model.task import Segment, Task
from rtsim.model.taskset import TaskSet
from rtsim.model.window import WindowSpec
from rtsim.sim import CPU, JOB_COLUMNS, TRACE_COLUMNS, simulate


def _rows(df, task):
    return df[df["task"] == task].sort_values("job").reset_index(drop=True)


def test_two_tasks_hand_schedule():
    # hi (2, 5), lo (4, 10): hi 0-2, lo 2-5, hi 5-7, lo 7-8 -> lo R = 8 (one preemption)
    res = simulate(
        [Task("hi", 2, 5, priority=1), Task("lo", 4, 10, priority=2)],
        10,
        record_jobs=True,
        record_trace=True,
    )
    lo = _rows(res.jobs, "lo")
    assert list(lo["finish"]) == [8.0]
    assert list(lo["preemptions"]) == [1]
    tr = res.trace
    assert [(r.task, r.start, r.end) for r in tr.itertuples()] == [
        ("hi", 0, 2),
        ("lo", 2, 5),
        ("hi", 5, 7),
        ("lo", 7, 8),
    ]
    assert res.tasks["lo"].max_response == 8.0
    assert res.tasks["hi"].completed == 2
    assert tuple(res.jobs.columns) == JOB_COLUMNS
    assert tuple(res.trace.columns) == TRACE_COLUMNS
    assert res.busy_time == pytest.approx(8.0)


def test_completion_before_release_at_same_instant():
    # lo runs 0-5 and completes exactly when hi is released at 5: no preemption of lo.
    res = simulate(
        [Task("hi", 1, 10, priority=1, offset=5), Task("lo", 5, 100, priority=2)],
        10,
        record_jobs=True,
        record_trace=True,
    )
    lo = _rows(res.jobs, "lo")
    assert lo.loc[0, "finish"] == 5.0 and lo.loc[0, "preemptions"] == 0
    assert [(r.task, r.start, r.end) for r in res.trace.itertuples()] == [
        ("lo", 0, 5),
        ("hi", 5, 6),
    ]


def test_completion_within_eps_of_release_is_simultaneous():
    # lo's work ends 1e-12 ms after hi's release: treated as the same instant, no preemption
    res = simulate(
        [Task("hi", 1, 10, priority=1, offset=0.3), Task("lo", 0.1 + 0.2, 100, priority=2)],
        5,
        record_jobs=True,
        record_trace=True,
    )
    lo = _rows(res.jobs, "lo")
    assert lo.loc[0, "preemptions"] == 0
    assert len(res.trace[res.trace["task"] == "lo"]) == 1


def test_simultaneous_releases_run_in_priority_order_and_hooks_in_that_order():
    tasks = [
        Task("c", 1, 10, priority=3),
        Task("a", 1, 10, priority=1),
        Task("b", 1, 10, priority=2),
    ]
    cpu = CPU()
    log = []
    for t in tasks:
        cpu.add_task(t)
    cpu.on("release", lambda job: log.append(("rel", job.name, cpu.env.now)))
    cpu.on("segment_start", lambda job, seg: log.append(("start", job.name, cpu.env.now)))
    cpu.env.run(until=cpu.start(5))
    assert log == [
        ("rel", "a", 0),
        ("rel", "b", 0),
        ("rel", "c", 0),
        ("start", "a", 0),
        ("start", "b", 1),
        ("start", "c", 2),
    ]


def test_hook_order_at_a_segment_boundary_with_a_release():
    # lo = chain A(2) B(2); hi (1) released at 2, exactly when A ends.
    # At t=2: A's end hook, then hi's release, then hi starts (lo preempted between segments).
    lo = Task("lo", 4, 100, priority=2, segments=(Segment("A", 2), Segment("B", 2)))
    hi = Task("hi", 1, 100, priority=1, offset=2)
    cpu = CPU(record_jobs=True)
    cpu.add_task(lo)
    cpu.add_task(hi)
    log = []
    now = lambda: cpu.env.now  # noqa: E731
    cpu.on("release", lambda j: log.append((now(), "release", j.name)))
    cpu.on("segment_start", lambda j, s: log.append((now(), "start", j.name, s.name)))
    cpu.on("segment_end", lambda j, s: log.append((now(), "end", j.name, s.name)))
    cpu.on("job_end", lambda j: log.append((now(), "job_end", j.name)))
    cpu.env.run(until=cpu.start(10))
    assert log == [
        (0, "release", "lo"),
        (0, "start", "lo", "A"),
        (2, "end", "lo", "A"),
        (2, "release", "hi"),
        (2, "start", "hi", "hi"),
        (3, "end", "hi", "hi"),
        (3, "job_end", "hi"),
        (3, "start", "lo", "B"),
        (5, "end", "lo", "B"),
        (5, "job_end", "lo"),
    ]
    jobs = cpu.result().jobs
    assert _rows(jobs, "lo").loc[0, "preemptions"] == 1


def test_hook_filters_and_exec_time_callable_after_start_hooks():
    # The "hough" time is computed from what the "scan" start hook saw (the coupling case).
    segs = (
        Segment("scan", 3, role="scan"),
        Segment("hough", 10, role="hough"),
        Segment("send[1]", 1, role="send", follower=1),
    )
    chain = Task("window", 14, 50, priority=1, segments=segs)
    cpu = CPU(record_jobs=True, record_trace=True)
    cpu.add_task(chain)
    seen = {}
    sends = []
    cpu.on("segment_start", lambda j, s: seen.__setitem__(j.index, cpu.env.now), role="scan")
    cpu.on(
        "segment_end",
        lambda j, s: sends.append((j.index, s.follower, cpu.env.now)),
        task="window",
        segment="send[1]",
    )
    cpu.set_exec_time("window", "hough", lambda job, seg, rng: 2.0 + seen[job.index] / 50.0)
    cpu.env.run(until=cpu.start(100))
    tr = cpu.result().trace
    hough = tr[tr["segment"] == "hough"].sort_values("job")
    # job 0: scan at 0 -> hough 2.0 ms (3..5); job 1: scan at 50 -> hough 3.0 ms (53..56)
    assert list(hough["end"] - hough["start"]) == [2.0, 3.0]
    assert sends == [(0, 1, 6.0), (1, 1, 57.0)]


def test_idle_suspension_frees_the_cpu_cpu_mode_holds_it():
    chain = Task(
        "chain",
        8,
        100,
        priority=1,
        segments=(Segment("a", 2), Segment("radio", 5, "suspend"), Segment("b", 1)),
    )
    low = Task("low", 4, 100, priority=2)
    idle = simulate([chain, low], 50, suspension="idle", record_jobs=True, record_trace=True)
    # idle: chain 0-2, radio 2-7 (CPU free: low 2-6), chain b 7-8
    assert _rows(idle.jobs, "chain").loc[0, "finish"] == 8.0
    assert _rows(idle.jobs, "low").loc[0, "finish"] == 6.0
    radio = idle.trace[idle.trace["segment"] == "radio"]
    assert list(radio["on_cpu"]) == [False] and list(radio["start"]) == [2.0]
    cpu = simulate([chain, low], 50, suspension="cpu", record_jobs=True)
    # cpu: chain holds the CPU 0-8, low 8-12
    assert _rows(cpu.jobs, "chain").loc[0, "finish"] == 8.0
    assert _rows(cpu.jobs, "low").loc[0, "finish"] == 12.0


def test_cpu_mode_suspension_is_preemptible():
    # chain (priority 2): a 1, radio 4 (as CPU time); hi (1, every 3) preempts it.
    chain = Task(
        "chain", 5, 100, priority=2, segments=(Segment("a", 1), Segment("radio", 4, "suspend"))
    )
    hi = Task("hi", 1, 3, priority=1, offset=2)
    res = simulate([chain, hi], 9, suspension="cpu", record_jobs=True, record_trace=True)
    # chain 0-1 a, 1-2 radio, hi 2-3, radio 3-5, hi 5-6, radio 6-7 -> finish 7
    assert _rows(res.jobs, "chain").loc[0, "finish"] == 7.0
    radio = res.trace[res.trace["segment"] == "radio"]
    assert list(zip(radio["start"], radio["end"], strict=True)) == [(1, 2), (3, 5), (6, 7)]


def test_first_segment_idle_suspension_and_fifo_successor():
    # a job that starts with a suspension is not eligible until it ends
    t = Task("t", 3, 4, priority=1, segments=(Segment("wait", 2, "suspend"), Segment("x", 1)))
    res = simulate([t], 8, suspension="idle", record_jobs=True)
    assert list(_rows(res.jobs, "t")["finish"]) == [3.0, 7.0]


def test_finish_late_backlog_is_fifo():
    # e=3, p=2 alone: jobs 0,1,2 released 0,2,4 run back to back 0-3, 3-6, 6-9
    res = simulate([Task("t", 3, 2, priority=1)], 6, record_jobs=True)
    j = _rows(res.jobs, "t")
    assert list(j["start"]) == [0, 3, 6] and list(j["finish"]) == [3, 6, 9]
    assert list(j["missed"]) == [True, True, True]
    s = res.tasks["t"]
    assert (s.released, s.completed, s.misses, s.max_backlog) == (3, 3, 3, 2)
    assert s.max_response == 5.0 and s.mean_response == pytest.approx((3 + 4 + 5) / 3)


def test_abort_at_deadline_before_release_at_same_instant():
    # e=3, p=d=2, abort: every job runs 2 ms and is aborted at its deadline, where the next
    # release comes after the abort (backlog never above 1).
    res = simulate(
        [Task("t", 3, 2, priority=1, overload="abort")], 8, record_jobs=True, record_trace=True
    )
    s = res.tasks["t"]
    assert (s.released, s.completed, s.aborted, s.misses, s.max_backlog) == (4, 0, 4, 4, 1)
    assert list(res.jobs["exec_time"]) == [2.0] * 4
    assert res.end_time == 8.0


def test_abort_policy_overload_runs_in_bounded_memory():
    hi = Task("hi", 3, 4, priority=1)
    lo = Task("lo", 2, 5, priority=2, overload="abort")  # U = 1.15
    res = simulate([hi, lo], 20_000)
    s = res.tasks["lo"]
    assert s.max_backlog == 1 and s.aborted > 0
    assert s.released == 4000 and s.completed + s.aborted == s.released
    # a completed lo job met its deadline (otherwise it would have been aborted)
    assert s.completed > 0 and s.misses == s.aborted and s.max_response <= 5.0


def test_skip_releases_while_pending():
    # e=3, p=2, skip: job 0 runs 0-3 (late); release 1 at 2 skipped; job 2 at 4 runs 4-7;
    # release 3 at 6 skipped; job 4 at 8 runs 8-11; release 5 at 10 skipped (horizon 12).
    res = simulate([Task("t", 3, 2, priority=1, overload="skip")], 12, record_jobs=True)
    j = _rows(res.jobs, "t")
    assert list(j["skipped"]) == [False, True, False, True, False, True]
    assert list(j.loc[~j["skipped"], "finish"]) == [3, 7, 11]
    s = res.tasks["t"]
    assert (s.released, s.skipped, s.completed, s.misses) == (3, 3, 3, 6)


def test_overhead_charged_on_every_switch():
    # overhead 0.5: hi (1, 10), lo (3, 10); at 0 hi runs 0-1.5 (0.5 switch + 1),
    # lo 1.5-5 (0.5 + 3). Two switches per period.
    res = simulate(
        [Task("hi", 1, 10, priority=1), Task("lo", 3, 10, priority=2)],
        20,
        overhead=0.5,
        record_jobs=True,
        record_trace=True,
    )
    assert list(_rows(res.jobs, "lo")["finish"]) == [5.0, 15.0]
    assert res.context_switches == 4
    ovh = res.trace[res.trace["kind"] == "overhead"]
    assert len(ovh) == 4 and (ovh["end"] - ovh["start"]).sum() == pytest.approx(2.0)
    assert res.busy_time == pytest.approx(10.0)


def test_dynamic_window_period_provider_and_per_window_task():
    # window chain with w = 100, 120, 130, ...; command (per window, 2w) at its releases
    spec = WindowSpec(
        n=1,
        r_H=10,
        e_cal=0.0,
        e_trans=0.0,
        k=1,
        e_scan=5,
        e_estimate=1,
        e_send=1,
        e_recv=1,
        delta_t=2,
        e_sched=0,
        priority=2,
    )
    ts = TaskSet(
        (Task("dr", 1, 40, priority=1), Task("command", 3, 2, per_window=True, priority=3)),
        window=spec,
    )
    ws = iter([100.0, 120.0, 130.0, 140.0, 150.0, 160.0])
    res = simulate(ts, 400, window=lambda: next(ws), record_jobs=True)
    win = _rows(res.jobs, "window")
    assert list(win["release"]) == [0, 100, 220, 350]
    assert list(win["deadline"]) == [100, 220, 350, 490]
    cmd = _rows(res.jobs, "command")
    # command at 0 sees w=100 -> p 200; at 200 the w in force is 120 -> p 240 (next at 440)
    assert list(cmd["release"]) == [0, 200]
    assert list(cmd["period"]) == [200, 240]
    assert list(cmd["deadline"]) == [200, 440]
    assert res.window == {"mode": "dynamic"}


def test_fixed_window_and_w_sch_default():
    from rtsim.analysis.bounds import w_sch_of
    from rtsim.config.taskset import load_taskset

    ts = load_taskset()
    res = simulate(ts, 2000, record_jobs=True)
    w = w_sch_of(ts)
    assert res.window == {"mode": "w_sch", "w": w}
    win = _rows(res.jobs, "window")
    assert np.allclose(np.diff(win["release"]), w)
    res2 = simulate(ts, 2000, window=300.0, record_jobs=True)
    assert list(_rows(res2.jobs, "command")["period"])[:2] == [600.0, 600.0]


def test_shared_environment_with_a_world_process():
    env = simpy.Environment()
    ticks = []

    def world(env):
        while True:
            ticks.append(env.now)
            yield env.timeout(10)

    env.process(world(env))
    res = simulate([Task("t", 1, 20, priority=1)], 100, env=env)
    assert res.tasks["t"].completed == 5
    assert ticks[:3] == [0, 10, 20]
    assert env.now == pytest.approx(81.0)  # stopped when the last job completed


def test_stats_without_job_records_match_the_job_table():
    ts = [
        Task("a", 1, 4, priority=1, bcet=0.2),
        Task("b", 3, 7, priority=2, bcet=1),
        Task("c", 2, 13, priority=3, bcet=0.5),
    ]
    with_jobs = simulate(ts, 500, exec_model="uniform", seed=3, record_jobs=True)
    without = simulate(ts, 500, exec_model="uniform", seed=3)
    assert without.jobs is None
    for name in ("a", "b", "c"):
        rows = _rows(with_jobs.jobs, name)
        s = without.tasks[name]
        assert s.completed == len(rows)
        assert s.max_response == pytest.approx(rows["response"].max(), abs=0)
        assert s.mean_response == pytest.approx(rows["response"].mean(), rel=1e-12)
        assert s.misses == int(rows["missed"].sum())
        assert s.histogram is not None and s.histogram.total == len(rows)
        edges, counts = s.histogram.arrays()
        ref, _ = np.histogram(rows["response"], bins=edges)
        assert list(counts) == list(ref)


def test_response_within_eps_of_deadline_is_not_a_miss():
    # lo's response 2 + 2 = 4 == deadline 4 exactly: met
    res = simulate(
        [Task("hi", 2, 5, priority=1), Task("lo", 2, 10, deadline=4, priority=2)],
        10,
        record_jobs=True,
    )
    assert res.tasks["lo"].misses == 0
    res = simulate(
        [Task("hi", 2, 5, priority=1), Task("lo", 2, 10, deadline=4 - 1e-6, priority=2)], 10
    )
    assert res.tasks["lo"].misses == 1


def test_to_json_has_the_cli_keys():
    res = simulate([Task("a", 1, 4, priority=1)], 40)
    out = res.to_json()
    entry = out["tasks"][0]
    for key in (
        "name",
        "released",
        "jobs",
        "aborted",
        "skipped",
        "max_response",
        "mean_response",
        "misses",
    ):
        assert key in entry
    assert entry["jobs"] == 10 and entry["released"] == 10


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"suspension": "nap"}, "suspension must be"),
        ({"overhead": -1.0}, "overhead must be"),
        ({"exec_model": "gauss"}, "exec model: must be one of"),
        ({"seed": -3}, "seed must be"),
    ],
)
def test_bad_arguments(kwargs, match):
    with pytest.raises(InputError, match=match):
        simulate([Task("a", 1, 4)], 10, **kwargs)


def test_bad_exec_time_and_provider_are_reported():
    with pytest.raises(RtsimError, match="segment 'a': execution time must be"):
        simulate([Task("a", 1, 4)], 10, exec_model=lambda job, seg, rng: -1.0)
    spec = WindowSpec(
        n=1,
        r_H=10,
        e_cal=0.0,
        e_trans=0.0,
        k=1,
        e_scan=5,
        e_estimate=1,
        e_send=1,
        e_recv=1,
        delta_t=2,
        e_sched=0,
        priority=1,
    )
    with pytest.raises(RtsimError, match="period provider returned 0"):
        simulate(TaskSet((), window=spec), 100, window=lambda: 0)
    with pytest.raises(InputError, match="horizon must be"):
        simulate([Task("a", 1, 4)], math.inf)
    with pytest.raises(InputError, match="has no \\[window\\]"):
        simulate([Task("a", 1, 4)], 10, window=5.0)


def test_cpu_rejects_duplicate_priorities_and_names():
    cpu = CPU()
    cpu.add_task(Task("a", 1, 4, priority=1))
    with pytest.raises(InputError, match="priority 1 is already used"):
        cpu.add_task(Task("b", 1, 4, priority=1))
    with pytest.raises(InputError, match="duplicate task name"):
        cpu.add_task(Task("a", 1, 4, priority=2))
    with pytest.raises(InputError, match="hook event must be"):
        cpu.on("finish", lambda j: None)


def test_window_in_force_and_constrained_per_window_deadline():
    # cmd: period 2w, deadline 1.5w; the CPU exposes the w in force to hooks
    spec = WindowSpec(
        n=1,
        r_H=10,
        e_cal=0.0,
        e_trans=0.0,
        k=1,
        e_scan=5,
        e_estimate=1,
        e_send=1,
        e_recv=1,
        delta_t=2,
        e_sched=0,
        priority=1,
    )
    cmd = Task("cmd", 3, 2, deadline=1.5, per_window=True, priority=2)
    from rtsim.sim import build_cpu

    ws = iter([50.0, 60.0, 70.0, 80.0, 90.0])
    cpu, info = build_cpu(TaskSet((cmd,), window=spec), window=lambda: next(ws), record_jobs=True)
    seen = []
    cpu.on("release", lambda j: seen.append((j.name, cpu.env.now, cpu.window)))
    cpu.env.run(until=cpu.start(200))
    assert info == {"mode": "dynamic"}
    assert seen[:4] == [
        ("window", 0, 50.0),
        ("cmd", 0, 50.0),
        ("window", 50, 60.0),
        ("cmd", 100, 60.0),
    ]
    c = _rows(cpu.result().jobs, "cmd")
    assert list(c["deadline"] - c["release"]) == [75.0, 90.0]
    assert cpu.stats("cmd").released == 2


def test_events_scheduled_by_hooks_run_at_their_instant():
    # the dispatcher moves the clock itself only while nothing else is due: an event a hook
    # triggers at t must still be processed at t, before the CPU's next instant
    env = simpy.Environment()
    cpu = CPU(env)
    cpu.add_task(Task("t", 1, 20, priority=1))
    seen = []

    def on_end(job):
        ev = env.event()
        ev.callbacks.append(lambda _: seen.append((env.now, cpu.stats("t").completed)))
        ev.succeed()

    cpu.on("job_end", on_end)
    env.run(until=cpu.start(100))
    assert seen == [(1.0 + 20 * k, k + 1) for k in range(5)]
