"""The reference test: the simulated schedule agrees exactly with the response-time analysis.

Critical instant (Liu & Layland 1973; SPEC §3): independent tasks, one CPU, preemptive fixed
priorities, constrained deadlines, every job at its WCET, all released at 0 -> the first job
of each task has exactly the analysed WCRT and no later job has more; a task the analysis
calls unschedulable misses with its first job.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtsim.analysis.bounds import window_bounds
from rtsim.analysis.rta import response_time
from rtsim.config.taskset import load_taskset
from rtsim.model.generate import uunifast
from rtsim.model.task import Task
from rtsim.sim import simulate

#: Periods whose hyperperiod is 200 ms: one hyperperiod holds at most 50 jobs per task.
PERIODS = (4, 5, 8, 10, 20, 25, 40, 50, 100, 200)
N_SETS = 240


def _random_set(rng: np.random.Generator) -> list[Task]:
    """2-10 tasks, integer parameters, U <= 0.95, constrained deadlines, some random priorities."""
    while True:
        n = int(rng.integers(2, 11))
        us = uunifast(n, float(rng.uniform(0.4, 0.95)), rng)
        ps = [int(p) for p in rng.choice(PERIODS, size=n)]
        es = [max(1, round(u * p)) for u, p in zip(us, ps, strict=True)]
        if sum(e / p for e, p in zip(es, ps, strict=True)) > 0.95:
            continue
        ds = [
            int(rng.integers(max(e, math.ceil(p / 2)), p + 1)) for e, p in zip(es, ps, strict=True)
        ]
        if rng.random() < 0.5:  # deadline-monotonic
            order = sorted(range(n), key=lambda i: (ds[i], ps[i], i))
        else:  # an arbitrary fixed-priority order: the analysis is exact for any
            order = [int(i) for i in rng.permutation(n)]
        prio = {i: k + 1 for k, i in enumerate(order)}
        return [Task(f"t{i}", es[i], ps[i], deadline=ds[i], priority=prio[i]) for i in range(n)]


def test_random_sets_match_the_exact_analysis():
    rng = np.random.default_rng(20240611)
    unschedulable = schedulable = 0
    for _ in range(N_SETS):
        tasks = sorted(_random_set(rng), key=lambda t: t.priority)
        hyper = math.lcm(*(int(t.period) for t in tasks))
        res = simulate(tasks, hyper)
        for i, task in enumerate(tasks):
            r = response_time(task, tasks[:i])
            stats = res.tasks[task.name]
            assert stats.released == hyper // task.period
            if r is None:
                unschedulable += 1
                assert stats.misses >= 1, (tasks, task.name)
            else:
                schedulable += 1
                assert stats.max_response == pytest.approx(r, abs=1e-9), (tasks, task.name)
                assert stats.misses == 0
    assert unschedulable >= 20
    assert schedulable >= 500


@pytest.mark.parametrize("n", range(1, 11))
@pytest.mark.parametrize("r_H", [15.0, 25.0, 40.0])
def test_paper_set_at_w_sch_w_rta_and_below(n, r_H):
    ts = load_taskset().with_window(n=n, r_H=r_H)
    b = window_bounds(ts)
    assert b.w_rta <= b.w_sch
    windows = 30
    at_sch = simulate(ts, windows * b.w_sch, window=b.w_sch, suspension="cpu")
    assert at_sch.misses == 0
    at_rta = simulate(ts, windows * b.w_rta, window=b.w_rta, suspension="cpu")
    assert at_rta.misses == 0
    chain = ts.window_task(b.w_rta)
    r_chain = response_time(chain, ts.hp)
    assert r_chain is not None
    assert at_rta.tasks["window"].max_response == pytest.approx(r_chain, abs=1e-9)
    assert at_rta.tasks["window"].released == math.ceil(windows - 1e-9)
    below = simulate(ts, windows * (b.w_rta - 1), window=b.w_rta - 1, suspension="cpu")
    assert below.misses > 0


def test_idle_suspension_is_at_or_below_the_analysis():
    # with the radio leaving the CPU free the chain can only be faster (SPEC §3)
    ts = load_taskset().with_window(n=4)
    b = window_bounds(ts)
    cpu = simulate(ts, 20 * b.w_rta, window=b.w_rta, suspension="cpu")
    idle = simulate(ts, 20 * b.w_rta, window=b.w_rta, suspension="idle")
    assert idle.misses == 0
    assert idle.tasks["window"].max_response <= cpu.tasks["window"].max_response + 1e-9
    assert idle.tasks["command"].max_response < cpu.tasks["command"].max_response
