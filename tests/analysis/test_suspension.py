"""Suspension-aware bounds (SPEC §8; Chen, Nelissen, Huang et al. 2019) and w_susp."""

from __future__ import annotations

import itertools
import json
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rtsim.analysis.bounds import w_rta, w_susp, window_bounds
from rtsim.analysis.rta import analyze
from rtsim.analysis.suspension import suspension_aware
from rtsim.cli import main
from rtsim.config.taskset import load_taskset
from rtsim.model.task import Segment, Task
from rtsim.model.taskset import TaskSet
from rtsim.sim import build_cpu, simulate

sys.path.insert(0, str(Path(__file__).parents[1]))
from window_sets import random_window_sets  # noqa: E402

SUSP = (Segment("a", 4.0), Segment("r", 20.0, "suspend"), Segment("b", 3.0))


def test_hand_worked_segmented_and_jitter():
    # hp (1, 10); s: 4 → 20 suspended → 3, period 100; lo (10, 200).
    # Oblivious: R_s = 27 + ⌈R/10⌉ → 30. Segmented: (4 + 1) + 20 + (3 + 1) = 29.
    # lo, oblivious: 10 + 27⌈R/100⌉ + ⌈R/10⌉ → 41, 42, 42. Jitter (C = 7, J = 29 − 7 = 22):
    # 10 + 7⌈(R + 22)/100⌉ + ⌈R/10⌉ → 19.
    tasks = [
        Task("hp", 1, 10, priority=1),
        Task("s", 27, 100, priority=2, segments=SUSP),
        Task("lo", 10, 200, priority=3),
    ]
    b = suspension_aware(tasks)
    assert [(x.oblivious, x.other, x.kind, x.wcrt) for x in b] == [
        (1.0, None, "", 1.0),
        (30.0, 29.0, "segmented", 29.0),
        (42.0, 19.0, "jitter", 19.0),
    ]
    idle = analyze(TaskSet(tuple(tasks)), suspension="idle")
    assert [t.wcrt for t in idle.tasks] == [1.0, 29.0, 19.0]
    assert [t.wcrt for t in analyze(TaskSet(tuple(tasks))).tasks] == [1.0, 30.0, 42.0]


def test_jitter_form_can_lose_to_the_oblivious_one():
    # hp (3, 10); s: 10 → 1 suspended → 10, period 100 (R_s = 30 oblivious, 33 segmented);
    # lo (44, 400). Oblivious: 44 + 21⌈R/100⌉ + 3⌈R/10⌉ → 86, 92, 95, 95. Jitter (C = 20,
    # J = 30 − 20 = 10): 44 + 20⌈(R + 10)/100⌉ + 3⌈R/10⌉ → 85, 91, 114, 120, 120: it pulls in
    # a second job of s. A short suspension makes the jitter form the worse one.
    segs = (Segment("a", 10.0), Segment("r", 1.0, "suspend"), Segment("b", 10.0))
    tasks = [
        Task("hp", 3, 10, priority=1),
        Task("s", 21, 100, priority=2, segments=segs),
        Task("lo", 44, 400, priority=3),
    ]
    b = suspension_aware(tasks)
    assert (b[1].oblivious, b[1].other, b[1].wcrt) == (30.0, 33.0, 30.0)
    # The unified bound (Chen, Nelissen & Huang 2016), both higher tasks' suspension as
    # computation (x = 1, 1): Q = 1 for both, 44 + 3⌈(R + 1)/10⌉ + 20⌈(R + 1)/100⌉ → 67, 85,
    # 91, 94, 94 — s's 1 ms suspension is not paid as the oblivious form's C + S = 21.
    assert (b[2].oblivious, b[2].other, b[2].unified, b[2].wcrt) == (95.0, 120.0, 94.0, 94.0)


@st.composite
def suspending_sets(draw: st.DrawFn) -> list[Task]:
    n = draw(st.integers(2, 4))
    out = []
    for k in range(n):
        segs = tuple(
            Segment(
                f"s{i}",
                draw(st.sampled_from([0.5, 1.0, 2.0, 4.0, 7.5])),
                draw(st.sampled_from(["compute", "compute", "suspend"])),
            )
            for i in range(draw(st.integers(1, 3)))
        )
        period = float(draw(st.integers(10, 80)))
        out.append(
            Task(
                f"t{k}",
                sum(s.wcet for s in segs),
                period,
                priority=k + 1,
                offset=draw(st.sampled_from([0.0, 0.0, period / 4])),
                jitter=draw(st.sampled_from([0.0, 0.0, 1.5])),
                segments=segs,
            )
        )
    return out


def _shorter_suspensions(rng_seed: int):
    def fn(job, seg, rng):
        return float(rng.uniform(0.0, seg.wcet)) if seg.kind == "suspend" else seg.wcet

    return fn


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    suspending_sets(),
    st.sampled_from(["worst", "random"]),
    st.booleans(),
    st.sampled_from([0.0, 0.1]),
)
def test_idle_simulation_within_suspension_aware_bounds(tasks, jitter, vary, o):
    ana = analyze(TaskSet(tuple(tasks)), suspension="idle", overhead=o)
    obl = analyze(TaskSet(tuple(tasks)), overhead=o)
    exec_model = _shorter_suspensions(0) if vary else "wcet"
    res = simulate(
        tasks, 800.0, suspension="idle", jitter=jitter, exec_model=exec_model, seed=5, overhead=o
    )
    for a, b in zip(ana.tasks, obl.tasks, strict=True):
        if b.wcrt is not None:  # the aware bound is never above the oblivious one
            assert a.wcrt is not None and a.wcrt <= b.wcrt
        if a.schedulable:
            sim = res.tasks[a.name]
            assert sim.misses == 0
            assert sim.max_response is None or sim.max_response <= a.wcrt + 1e-9, (a, sim)


def test_w_susp_is_checked_and_below_w_rta():
    finite = 0
    for ts in random_window_sets(seed=5, count=15):
        ws, wr = w_susp(ts), w_rta(ts)
        assert ws <= wr
        if not math.isfinite(ws):
            continue
        finite += 1
        assert analyze(ts, ws, suspension="idle").schedulable
        assert not analyze(ts, ws - 1e-6, suspension="idle").schedulable
        assert analyze(ts, ws + 3.0, suspension="idle").schedulable
    assert finite >= 10


def test_paper_set_w_susp_values_and_json(capsys):
    ts = load_taskset()
    b = window_bounds(ts)
    # n = 2: the window's segmented bound (scan..send with 4 dead-reckoning jobs, Δt, recv+sched
    # with 1) sets w_susp: one dead-reckoning job fewer than the oblivious 222.727 ms.
    oblivious = analyze(ts, 400.0).tasks[1].wcrt  # the window's R does not depend on w
    assert b.w_susp == analyze(ts, b.w_susp, suspension="idle").tasks[1].wcrt
    assert oblivious is not None and abs(b.w_susp - (oblivious - 5.0)) < 1e-9
    assert main(["bounds", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["w_susp"] == b.w_susp and out["w_susp"] < out["w_rta"] < out["w_sch"]
    assert (
        main(
            [
                "analyze",
                "--suspension",
                "idle",
                "--window",
                str(b.w_susp),
                "--check",
                str(Path(ts.source)),
            ]
        )
        == 0
    )
    assert main(["analyze", "--window", str(b.w_susp), "--check", str(Path(ts.source))]) == 1


def _paper_run(ts: TaskSet, w: float, vary: bool, seed: int) -> int:
    cpu, _ = build_cpu(ts, window=w, suspension="idle", seed=seed)
    if vary:
        cpu.set_exec_time("window", "radio", lambda job, seg, rng: float(rng.uniform(0, 67.0)))
    cpu.env.run(until=cpu.start(400 * w))
    res = cpu.result()
    assert res.tasks["window"].completed == 400
    return res.misses


def test_paper_set_at_w_susp_misses_nothing_over_400_windows():
    ts = load_taskset()
    w = window_bounds(ts).w_susp
    assert _paper_run(ts, w, vary=False, seed=0) == 0
    rng = np.random.default_rng(11)
    for seed in range(3):  # Δt in [0, 67] ms and random offsets of the other tasks
        moved = TaskSet(
            tuple(replace(t, offset=float(rng.uniform(0, 40.0))) for t in ts.tasks),
            name=ts.name,
            window=ts.window,
            source=ts.source,
        )
        assert _paper_run(moved, w, vary=True, seed=seed) == 0
    # and just below w_susp the idle analysis no longer accepts the set (it is tight)
    assert not analyze(ts, w - 1e-6, suspension="idle").schedulable


def test_suspending_task_below_a_suspending_task_by_hand():
    # s1: 2 → 4 suspended → 1, period 10 (R = 7); s2: 3 → 2 suspended → 2, period 30.
    # Oblivious: 7 + 7⌈R/10⌉ → 14, 21, 28, 28. Unified, s1 as jitter R − C = 4 (or as
    # computation with Q = 4, the same here): 7 + 3⌈(R + 4)/10⌉ → 10, 13, 13.
    s1 = Task(
        "s1",
        7,
        10,
        priority=1,
        segments=(Segment("a", 2.0), Segment("r", 4.0, "suspend"), Segment("b", 1.0)),
    )
    s2 = Task(
        "s2",
        7,
        30,
        priority=2,
        segments=(Segment("a", 3.0), Segment("r", 2.0, "suspend"), Segment("b", 2.0)),
    )
    b = suspension_aware([s1, s2])
    assert (b[1].oblivious, b[1].other, b[1].unified, b[1].wcrt) == (28.0, None, 13.0, 13.0)
    worst = max(
        brute_suspending([s1, s2], phases, full)["s2"]
        for phases in itertools.product(range(10), [0])
        for full in (True, False)
    )
    assert 10 <= worst <= 13


def brute_suspending(tasks: list[Task], phases, full: bool) -> dict[str, int]:
    """The exact discrete schedule of integer ``tasks`` (tests/analysis/test_transaction.py's brute
    force) at the given first releases, suspensions at their WCET (``full``) or alternating
    between 0 and it; the largest response per task over three hyperperiods."""
    from exact_schedule import brute

    from rtsim.analysis.transaction import Job, Transaction

    txs = [
        Transaction(t.period, (Job(t.name, t.priority, 0, 0, t.period, t.period, t.chain()),))
        for t in tasks
    ]
    hyper = math.lcm(*(int(t.period) for t in tasks))

    def choose(i, n, job):
        return 0, [int(s.wcet) if s.kind == "compute" or full or n % 2 else 0 for s in job.segments]

    return brute(txs, list(phases), choose, 3 * hyper)


@st.composite
def small_suspending_sets(draw: st.DrawFn) -> list[Task]:
    out = []
    for k in range(draw(st.integers(2, 3))):
        segs = [Segment("a", float(draw(st.integers(1, 3))))]
        if draw(st.booleans()) or k == 0:
            segs += [
                Segment("r", float(draw(st.integers(1, 4))), "suspend"),
                Segment("b", float(draw(st.integers(1, 2)))),
            ]
        period = float(draw(st.sampled_from([6, 8, 12, 24])))
        out.append(
            Task(f"t{k}", sum(s.wcet for s in segs), period, priority=k + 1, segments=tuple(segs))
        )
    return out


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(small_suspending_sets())
def test_suspension_aware_bounds_against_the_exact_brute_force(tasks):
    bounds = suspension_aware(tasks)
    worst: dict[str, int] = {}
    for phases in itertools.product(*(range(int(t.period)) for t in tasks[:-1])):
        for full in (True, False):
            got = brute_suspending(tasks, (*phases, 0), full)
            for k, v in got.items():
                worst[k] = max(worst.get(k, 0), v)
    for b in bounds:
        for r in (b.wcrt, b.unified):
            if r is not None:
                assert worst[b.name] <= r + 1e-9, (tasks, bounds, worst)
