"""EDF analysis (rtsim.analysis.edf) against independent references.

- the demand bound and QPA by hand, and QPA against checking every deadline point up to L;
- Spuri's bound against a brute-force search over the analysed job's arrival, each case
  scheduled in unit steps by a scheduler written here (EDF, ties against the analysed task);
- the simulator under EDF against the demand criterion on random integer sets: schedulable
  iff no job misses in a synchronous release (implicit, constrained and arbitrary deadlines),
  and with release jitter in the common-instant pattern (``jitter="worst"``);
- hand-worked sets, the L limits, and the verdict's agreement with Spuri's bounds.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtsim.analysis.edf import (
    analyze_edf,
    busy_period,
    deadline_points,
    demand,
    limit_la,
    qpa,
    spuri_wcrt,
)
from rtsim.config.taskset import load_taskset
from rtsim.model.task import Task
from rtsim.model.taskset import TaskSet
from rtsim.sim import simulate


def test_demand_and_limits_by_hand():
    ts = [(2.0, 5.0, 4.0, 0.0), (4.0, 7.0, 6.0, 0.0)]
    # h(4) = 2; h(6) = 2 + 4; h(9) = 4 + 4; h(13) = 4 + 8; h(14) = 6 + 8
    assert [demand(t, ts) for t in (3.9, 4, 6, 9, 13, 14)] == [0, 2, 6, 8, 12, 14]
    u = 2 / 5 + 4 / 7
    assert limit_la(ts) == pytest.approx(max(6, (1 * 0.4 + 1 * 4 / 7) / (1 - u)))
    assert busy_period(ts) == 14.0  # 6 -> 2*2+4 = 8 -> 2*2+2*4 = 12 -> 3*2+2*4 = 14 -> 14
    r = qpa(ts)
    assert r.schedulable and r.limit == 14.0 and r.limit_kind == "L_b"
    # one more ms of b: h(6) = 2 + 5 > 6
    bad = [(2.0, 5.0, 4.0, 0.0), (5.0, 7.0, 6.0, 0.0)]
    assert not qpa(bad).schedulable
    # jitter moves every deadline point J earlier: J = 1 on a: h(3) = 2, h(8) = 4 + 4 = 8 ok
    jit = [(2.0, 5.0, 4.0, 1.0), (4.0, 7.0, 6.0, 0.0)]
    assert demand(3, jit) == 2 and demand(6, jit) == 6 and demand(8, jit) == 8
    assert qpa([(2.0, 5.0, 4.0, 2.0), (4.0, 7.0, 6.0, 0.0)]).schedulable is False
    # U > 1 at once; D - J <= 0; D >= T with U <= 1 needs no point
    assert qpa([(3.0, 5.0, 5.0, 0.0), (3.0, 7.0, 9.0, 0.0)]).limit_kind == "U > 1"
    assert not qpa([(1.0, 5.0, 2.0, 2.0)]).schedulable
    r = qpa([(2.0, 5.0, 5.0, 0.0), (4.0, 7.0, 9.0, 0.0)])
    assert r.schedulable and r.limit is None


def _random_sets(
    seed: int, count: int, *, jitter: bool, kind: str, umin: float = 0.5, umax: float = 1.0
):
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count:
        n = int(rng.integers(2, 5))
        periods = rng.choice([4, 5, 6, 8, 10, 12, 15, 20], size=n)
        tasks = []
        for p in periods:
            c = int(rng.integers(1, max(2, p // 2 + 1)))
            if kind == "implicit":
                d = int(p)
            elif kind == "constrained":
                d = int(rng.integers(c, p + 1))
            else:
                d = int(rng.integers(c, 2 * p + 1))
            j = int(rng.integers(0, max(1, d - c + 1))) if jitter and rng.random() < 0.6 else 0
            tasks.append((float(c), float(p), float(d), float(j)))
        u = sum(c / p for c, p, _, _ in tasks)
        if umin <= u <= umax:
            out.append(tasks)
    return out


def _all_points(tasks):
    """The demand criterion checked at every deadline point up to L (no QPA)."""
    if sum(c / p for c, p, _, _ in tasks) > 1.0:
        return False
    la, lb = limit_la(tasks), busy_period(tasks)
    lims = [x for x in (la, lb) if x is not None and math.isfinite(x)]
    # U = 1 with jitter: h(t + H) = h(t) + H beyond max(D − J)
    limit = (
        min(lims)
        if lims
        else max(d - j for _, _, d, j in tasks) + math.lcm(*(int(p) for _, p, _, _ in tasks))
    )
    return all(demand(t, tasks) <= t + 1e-9 for t in deadline_points(tasks, limit))


@pytest.mark.parametrize("kind", ["implicit", "constrained", "arbitrary"])
def test_qpa_equals_checking_every_deadline_point(kind):
    sets = _random_sets(1, 150, jitter=True, kind=kind) + _random_sets(
        2, 150, jitter=False, kind=kind
    )
    verdicts = [qpa(ts).schedulable for ts in sets]
    assert verdicts == [_all_points(ts) for ts in sets]
    if kind != "implicit":
        assert 10 < sum(verdicts) < len(sets) - 10  # both verdicts occur


def brute_force_response(tasks, i: int) -> int:
    """Largest response of task i's job arriving at a, over every integer a, with the other
    tasks released at 0 and every period after, task i's earlier jobs at a − k·T_i ≥ 0, all
    scheduled in unit steps by EDF with ties against task i (integer parameters, J = 0)."""
    ci, ti, di, _ = (int(x) for x in tasks[i])
    hyper = math.lcm(*(int(p) for _, p, _, _ in tasks))
    worst = 0
    for a in range(0, 2 * hyper):
        jobs = []  # [release, deadline, remaining, is_i, is_target]
        for k, (c, p, d, _) in enumerate(tasks):
            c, p, d = int(c), int(p), int(d)
            first = (a % p) if k == i else 0
            r = first
            while r <= a + di + 2 * hyper:
                jobs.append([r, r + d, c, k == i, k == i and r == a])
                r += p
        t = 0
        target = next(j for j in jobs if j[4])
        while target[2] > 0:
            ready = [j for j in jobs if j[0] <= t and j[2] > 0]
            if ready:
                job = min(ready, key=lambda j: (j[1], j[3]))  # ties: task i last
                job[2] -= 1
            t += 1
        worst = max(worst, t - a)
    return worst


@pytest.mark.parametrize("seed", range(6))
def test_spuri_equals_brute_force_on_small_integer_sets(seed):
    rng = np.random.default_rng(100 + seed)
    checked = 0
    while checked < 6:
        n = int(rng.integers(2, 4))
        tasks = []
        for _ in range(n):
            p = int(rng.choice([3, 4, 5, 6, 8]))
            c = int(rng.integers(1, p))
            d = int(rng.integers(c, 2 * p))
            tasks.append((float(c), float(p), float(d), 0.0))
        if not 0.5 <= sum(c / p for c, p, _, _ in tasks) <= 1.0:
            continue
        if math.lcm(*(int(p) for _, p, _, _ in tasks)) > 60:
            continue
        for i in range(n):
            assert spuri_wcrt(i, tasks) == brute_force_response(tasks, i), (tasks, i)
        checked += 1


def test_spuri_by_hand():
    # a = (2, 5), b = (4, 7): the EDF schedule of tests/test_sim_policy gives a 4 (a arriving
    # at 15 waits for... ) and b 6; Spuri's bound is the worst over all arrivals
    ts = [(2.0, 5.0, 5.0, 0.0), (4.0, 7.0, 7.0, 0.0)]
    assert [spuri_wcrt(i, ts) for i in range(2)] == [4.0, 6.0]
    # a single task: C (+ J)
    assert spuri_wcrt(0, [(3.0, 10.0, 8.0, 2.0)]) == 5.0
    # U > 1: no bound
    assert spuri_wcrt(0, [(3.0, 5.0, 5.0, 0.0), (3.0, 5.0, 5.0, 0.0)]) is None


@pytest.mark.parametrize("kind", ["implicit", "constrained", "arbitrary"])
def test_spuri_agrees_with_the_demand_verdict(kind):
    # without jitter both are exact: every bound within its deadline iff the set passes
    for ts in _random_sets(7, 80, jitter=False, kind=kind):
        ok = all(
            (r := spuri_wcrt(i, ts)) is not None and r <= ts[i][2] + 1e-9 for i in range(len(ts))
        )
        assert ok == qpa(ts).schedulable, ts


def _sim_tasks(ts):
    return [Task(f"t{k}", c, p, d, priority=k + 1, jitter=j) for k, (c, p, d, j) in enumerate(ts)]


@pytest.mark.parametrize(
    "kind,jitter",
    [
        ("implicit", False),
        ("constrained", False),
        ("arbitrary", False),
        ("constrained", True),
        ("arbitrary", True),
    ],
)
def test_simulation_under_edf_matches_the_demand_criterion(kind, jitter):
    """Schedulable iff no miss from a synchronous release (with jitter: the common-instant
    pattern, each first job released J_i after arriving at t0 − J_i), over the hyperperiod
    and the busy period."""
    sets = _random_sets(11 if jitter else 12, 60, jitter=jitter, kind=kind, umin=0.8)
    agree = {True: 0, False: 0}
    for ts in sets:
        hyper = math.lcm(*(int(p) for _, p, _, _ in ts))
        lb = busy_period(ts) or 0.0
        horizon = max(hyper, lb) + max(d for _, _, d, _ in ts) + max(p for _, p, _, _ in ts)
        res = simulate(
            _sim_tasks(ts), horizon, scheduler="edf", jitter="worst" if jitter else "none"
        )
        verdict = qpa(ts).schedulable
        assert (res.misses == 0) == verdict, (ts, res.misses)
        agree[verdict] += 1
        if verdict:  # and Spuri's bound covers every simulated response
            for k in range(len(ts)):
                r = spuri_wcrt(k, ts)
                if r is None:  # U = 1 with jitter: no busy period to bound the search
                    assert busy_period(ts) is None
                    continue
                assert res.tasks[f"t{k}"].max_response <= r + 1e-9
    if kind != "implicit":
        assert agree[True] > 5 and agree[False] >= 3


def test_analyze_edf_on_task_sets():
    ts = TaskSet((Task("a", 2, 5, priority=2), Task("b", 4, 7, priority=1)), name="x")
    res = analyze_edf(ts)
    assert res.schedulable and [t.wcrt for t in res.tasks] == [6.0, 4.0]  # priority order
    d = res.as_dict()
    assert d["scheduler"] == "edf" and d["tasks"][0]["name"] == "b"
    # overhead: 2·o per job stretch: C = 2.2, 4.2: U = 0.44 + 0.6 = 1.04 > 1
    assert not analyze_edf(ts, overhead=0.1).schedulable
    # the paper's set at w: the chain counted with Δt (suspension-oblivious) either way
    paper = load_taskset()
    a, b = analyze_edf(paper, 240.0), analyze_edf(paper, 240.0, suspension="idle")
    assert a.schedulable and a.tasks == b.tasks
    chain = next(t for t in a.tasks if t.name == "window")
    assert chain.wcet == paper.window.g()
    with pytest.raises(Exception, match="has no \\[window\\]"):
        analyze_edf(ts, 100.0)


def test_per_task_bounds_agree_with_the_set_verdict_at_u_equal_1():
    """Where Spuri's search does not close and the demand criterion accepts the set, the
    deadline is the bound (``bound = "deadline"``); the simulator agrees."""
    paper = load_taskset("tasksets/barrel_robots.toml")
    w_edf = 234.54513236227112  # U = 1: the synchronous busy period never closes
    res = analyze_edf(paper, w_edf)
    assert res.schedulable
    assert all(t.bound == "deadline" and t.wcrt == t.deadline and t.schedulable for t in res.tasks)
    sim = simulate(paper, 200 * w_edf, window=w_edf, scheduler="edf")
    assert sim.misses == 0
    for t in res.tasks:
        assert sim.tasks[t.name].max_response <= t.wcrt + 1e-9
    # an integer set at U = 1 with jitter: the demand check over one hyperperiod passes,
    # Spuri's search has no end; the worst-case jitter pattern stays within D
    ts = TaskSet((Task("a", 2, 4, priority=1, jitter=1.0), Task("b", 2, 4, priority=2)))
    res = analyze_edf(ts)
    assert res.schedulable and busy_period([(2, 4, 4, 1.0), (2, 4, 4, 0.0)]) is None
    assert [t.bound for t in res.tasks] == ["deadline", "deadline"]
    for mode in ("worst", "random", "none"):
        sim = simulate(list(ts.tasks), 400.0, scheduler="edf", jitter=mode, seed=1)
        assert sim.misses == 0
    # below U = 1 Spuri's bound stays; an unschedulable set with no bound says so
    below = analyze_edf(TaskSet((Task("a", 2, 5, priority=2), Task("b", 4, 7, priority=1))))
    assert {t.bound for t in below.tasks} == {"spuri"}
    over = analyze_edf(TaskSet((Task("a", 3, 5, priority=1), Task("b", 3, 5, priority=2))))
    assert not over.schedulable
    assert [(t.wcrt, t.bound, t.schedulable) for t in over.tasks] == [(None, "none", False)] * 2
