"""Exact response-time analysis and the utilization tests, against hand values and brute force."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import rtsim.analysis as analysis
from rtsim.analysis.rta import analyze, response_time
from rtsim.analysis.utilization import (
    hyperbolic,
    hyperbolic_product,
    liu_layland,
    liu_layland_bound,
    rm_implicit,
)
from rtsim.errors import TaskSetError
from rtsim.model.task import Task
from rtsim.model.taskset import TaskSet


def mk(specs: list[tuple[float, ...]]) -> list[Task]:
    """Tasks from (e, p[, d]) in priority order."""
    return [
        Task(f"t{i}", s[0], s[1], s[2] if len(s) > 2 else None, priority=i)
        for i, s in enumerate(specs, start=1)
    ]


def test_worked_example():
    # By hand: R2 = 200 + 5⌈R/40⌉ → 205, 230, 230; R3 = 25 + 5⌈R/40⌉ + 200⌈R/250⌉ →
    # 230, 255, 460, 485, 490, 490.
    tasks = mk([(5, 40), (200, 250), (25, 500)])
    got = [response_time(t, tasks[:i]) for i, t in enumerate(tasks)]
    assert got == [5.0, 230.0, 490.0]
    res = analyze(TaskSet(tuple(tasks)))
    assert [r.wcrt for r in res.tasks] == [5.0, 230.0, 490.0] and res.schedulable
    assert res.w is None


def test_none_once_above_deadline():
    tasks = mk([(5, 40), (200, 250), (25, 500, 489)])
    assert response_time(tasks[2], tasks[:2]) is None
    res = analyze(TaskSet(tuple(tasks)))
    assert not res.schedulable and res.tasks[2].wcrt is None and not res.tasks[2].schedulable


def test_deadline_exactly_met_with_float_sums():
    # R = 0.1 + 0.2 hits a deadline of 0.3 only up to rounding (0.1 + 0.2 = 0.30000000000000004).
    hi, lo = Task("a", 0.1, 10.0, priority=1), Task("b", 0.2, 10.0, 0.3, priority=2)
    assert response_time(lo, [hi]) == pytest.approx(0.3)
    # ⌈R/p⌉ with R/p an integer up to rounding: R = 0.2 + 0.1 = 0.30000000000000004 and
    # R/0.3 = 1.0000000000000002; exactly, R = 0.3 is the fixed point (not 0.4).
    a = Task("a", 0.1, 0.3, priority=1)
    assert response_time(Task("b", 0.2, 1.0, priority=2), [a]) == pytest.approx(0.3)


def brute_wcrt(e: int, hp: list[tuple[int, int]], d: int) -> int | None:
    """First integer t ≤ d at which e + Σ⌈t/p⌉e_j ≤ t (integer parameters)."""
    for t in range(1, d + 1):
        if e + sum(-(-t // p) * ej for ej, p in hp) <= t:
            return t
    return None


def random_sets(seed: int, count: int, constrained: bool = True):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        n = int(rng.integers(1, 6))
        periods = sorted(int(p) for p in rng.integers(2, 60, size=n))
        tasks = []
        for p in periods:
            e = int(rng.integers(1, max(2, p // 2)))
            d = int(rng.integers(e, p + 1)) if constrained else int(rng.integers(e, 3 * p + 1))
            tasks.append((e, p, d))
        yield tasks


def test_exact_equals_brute_force_scan():
    checked = 0
    for specs in random_sets(seed=1, count=300):
        tasks = mk(specs)
        for i, (e, _, d) in enumerate(specs):
            got = response_time(tasks[i], tasks[:i])
            want = brute_wcrt(e, [(s[0], s[1]) for s in specs[:i]], d)
            assert got == want, (specs, i)
            checked += got is not None
    assert checked > 300  # both verdicts occur
    assert checked < sum(len(s) for s in random_sets(seed=1, count=300))


def unit_schedule(specs: list[tuple[int, int, int]]) -> list[int]:
    """Largest response of each task over one hyperperiod of a unit-step fixed-priority schedule
    with synchronous release (jobs of one task served in release order)."""
    hyper = math.lcm(*(p for _, p, _ in specs))
    pending: list[list[list[int]]] = [[] for _ in specs]  # [release, remaining]
    worst = [0] * len(specs)
    for t in range(hyper):
        for i, (e, p, _) in enumerate(specs):
            if t % p == 0:
                pending[i].append([t, e])
        for i, queue in enumerate(pending):
            if queue:
                queue[0][1] -= 1
                if queue[0][1] == 0:
                    worst[i] = max(worst[i], t + 1 - queue[0][0])
                    queue.pop(0)
                break
    assert not any(pending), "work left at the hyperperiod"
    return worst


def test_arbitrary_deadlines_match_unit_schedule():
    """Busy-period analysis (D > p) against a brute-force schedule over the hyperperiod."""
    beyond = 0
    rng = np.random.default_rng(2)
    for _ in range(300):
        n = int(rng.integers(2, 5))
        periods = [int(p) for p in rng.integers(2, 13, size=n)]
        specs = [(int(rng.integers(1, p + 1)), p, int(rng.integers(1, 3 * p + 1))) for p in periods]
        if sum(e / p for e, p, _ in specs) > 1:
            continue
        tasks = mk(specs)
        sim = unit_schedule(specs)
        for i, (_, p, d) in enumerate(specs):
            got = response_time(tasks[i], tasks[:i])
            if sim[i] <= d:
                assert got == sim[i], (specs, i)
                beyond += sim[i] > p
            else:
                assert got is None, (specs, i)
    assert beyond > 5  # responses above the period were exercised


def test_window_set_is_analysed_at_w_sch(paper_ts):
    res = analyze(paper_ts)
    assert res.w == pytest.approx(237.402, abs=1e-3)
    names = [r.name for r in res.tasks]
    assert names == ["dead_reckoning", "window", "command"]
    chain, cmd = res.tasks[1], res.tasks[2]
    g = chain.wcet
    assert chain.period == chain.deadline == res.w
    assert cmd.period == pytest.approx(2 * res.w)
    # By hand: chain R = g + 5⌈R/40⌉ = g + 30; command R = 25 + 2g + 5⌈R/40⌉ = 85 + 2g.
    assert chain.wcrt == pytest.approx(g + 30)
    assert cmd.wcrt == pytest.approx(85 + 2 * g)
    assert res.schedulable


def test_window_set_at_small_w(paper_ts):
    res = analyze(paper_ts, 200.0)
    assert not res.schedulable and res.w == 200.0
    assert res.tasks[1].wcrt is None


def test_w_for_plain_set_is_an_error():
    with pytest.raises(TaskSetError, match="has no \\[window\\]"):
        analyze(TaskSet(tuple(mk([(1, 10)]))), 5.0)


def test_unresolved_period_is_an_error():
    t = Task("c", 1, 2, priority=3, per_window=True)
    with pytest.raises(TaskSetError, match="task 'c': period is a multiple of w"):
        response_time(t, [])


def test_liu_layland_bound_values():
    assert liu_layland_bound(1) == 1.0
    assert liu_layland_bound(2) == pytest.approx(2 * (math.sqrt(2) - 1))
    assert liu_layland_bound(3) == pytest.approx(3 * (2 ** (1 / 3) - 1))
    assert liu_layland_bound(1000) == pytest.approx(math.log(2), abs=1e-3)


@pytest.mark.parametrize(
    "specs,ll,hb",
    [
        ([(5, 10), (3, 10)], True, True),  # U = 0.8 ≤ 0.828; 1.5·1.3 = 1.95
        ([(6, 10), (5, 20)], False, True),  # U = 0.85 > 0.828; 1.6·1.25 = 2.0
        ([(6, 10), (6, 20)], False, False),  # 1.6·1.3 = 2.08
        ([(1, 20), (1, 10)], False, False),  # not rate-monotonic: tests do not apply
        ([(1, 10, 5), (1, 20)], False, False),  # constrained deadline: do not apply
    ],
)
def test_utilization_tests(specs, ll, hb):
    tasks = mk(specs)
    assert liu_layland(tasks) is ll
    assert hyperbolic(tasks) is hb
    assert rm_implicit(tasks) is (len(specs[0]) == 2 and specs[0][1] <= specs[1][1])


def test_analysis_dict_shape(paper_ts):
    d = analyze(paper_ts).as_dict()
    assert {"tasks", "schedulable", "utilization", "liu_layland", "hyperbolic", "w"} <= set(d)
    for t in d["tasks"]:
        assert {"name", "priority", "wcet", "period", "deadline", "wcrt", "schedulable"} <= set(t)
    assert d["hyperbolic_product"] == pytest.approx(
        math.prod(t["utilization"] + 1 for t in d["tasks"])
    )
    assert hyperbolic_product(mk([(1, 2)])) == 1.5


def test_public_api():
    names = {
        "Analysis",
        "TaskResult",
        "analyze",
        "response_time",
        "liu_layland",
        "hyperbolic",
        "WindowBounds",
        "window_bounds",
        "w_rta",
        "e_hough",
        "g_window",
        "w_sch",
    }
    assert names <= set(analysis.__all__)
    for name in analysis.__all__:
        assert hasattr(analysis, name), name


# -- properties -----------------------------------------------------------------------------

task_st = st.tuples(st.integers(1, 30), st.integers(5, 200))
INF = math.inf


def wcrt(e: float, hp: list[tuple[float, float]], d: float = 10_000.0) -> float:
    r = response_time(Task("x", e, 10_000.0, d, priority=99), mk(hp))
    return INF if r is None else r


@settings(max_examples=100, deadline=None)
@given(st.lists(task_st, min_size=1, max_size=5), st.integers(1, 50), st.data())
def test_monotone_in_higher_priority_load(hp, e, data):
    i = data.draw(st.integers(0, len(hp) - 1))
    more_e = data.draw(st.integers(0, 20))
    shorter = data.draw(st.integers(0, hp[i][1] - 1))
    base = wcrt(e, hp)
    heavier = list(hp)
    heavier[i] = (hp[i][0] + more_e, hp[i][1] - shorter)
    assert wcrt(e, heavier) >= base
    assert wcrt(e, hp + [data.draw(task_st)]) >= base


@settings(max_examples=100, deadline=None)
@given(st.lists(task_st, max_size=5), st.integers(1, 50), st.integers(0, 50), st.integers(50, 5000))
def test_monotone_in_own_wcet(hp, e, extra, d):
    assert wcrt(e + extra, hp, d) >= wcrt(e, hp, d)
    r = wcrt(e, hp, d)
    assert r == INF or r >= e + sum(ej for ej, _ in hp)


def _suspending_with_sections(sus: float, l1: float, l2: float, offset: float = 1.0) -> TaskSet:
    """H locks R, suspends, locks R again; two lower tasks hold R long enough to block it in
    each of its compute stretches when Δt leaves the CPU idle."""
    from rtsim.model.task import Segment

    h = Task(
        "H",
        2.0 + sus,
        50,
        priority=1,
        offset=offset,
        segments=(
            Segment("a", 1, resource="R"),
            Segment("s", sus, kind="suspend"),
            Segment("b", 1, resource="R"),
        ),
    )
    lo1 = Task("L1", l1, 100, priority=2, segments=(Segment("x", l1, resource="R"),))
    lo2 = Task("L2", l2, 100, priority=3, segments=(Segment("y", l2, resource="R"),))
    return TaskSet((h, lo1, lo2))


@pytest.mark.parametrize(
    ("sus", "l1", "l2", "protocol"),
    [(0.5, 3, 6, "pcp"), (0.25, 2, 5, "pcp"), (0.5, 3, 6, "npr"), (1.0, 4, 9, "srp")],
)
def test_default_analysis_is_sound_for_suspensions_with_sections(sus, l1, l2, protocol):
    """Issue 35 (5): ``analyze(ts)`` counted suspensions as CPU time by default, which charges
    the blocking once; with Δt idle H is blocked by L1 before its first stretch and by L2
    (which locks R while H suspends) before its second. By hand (pcp, first numbers): L1 holds
    R over [0, 3), H runs [3, 4), suspends [4, 4.5), L2 holds R over [4, 10), H ends at 11:
    response 10 > the Δt-as-CPU bound 2.5 + 6 = 8.5. The default takes each task's larger
    bound of both models, which holds in both simulations."""
    from dataclasses import replace

    from rtsim.sim import simulate

    ts = replace(_suspending_with_sections(sus, l1, l2), resources=protocol)
    if protocol == "pcp":
        cpu_bound = 2.0 + sus + l2  # C + B, nothing above H
        assert analyze(ts, suspension="cpu").tasks[0].wcrt == pytest.approx(cpu_bound)
        assert simulate(ts, 200, suspension="idle").tasks["H"].max_response > cpu_bound
    default = analyze(ts)
    assert default.suspension == "either"
    for mode in ("cpu", "idle"):
        one = analyze(ts, suspension=mode)
        sim = simulate(ts, 400, suspension=mode)
        for d, o in zip(default.tasks, one.tasks, strict=True):
            assert d.wcrt is not None and d.wcrt >= o.wcrt
            assert sim.tasks[d.name].max_response <= d.wcrt + 1e-9


def test_default_analysis_is_unchanged_without_sections_or_suspensions():
    """A set without critical sections, or with them but no suspension: the default is the
    Δt-as-CPU analysis (sound under both models there), result for result."""
    from dataclasses import replace

    from rtsim.config.taskset import load_taskset
    from rtsim.model.task import Segment

    paper = load_taskset()
    assert analyze(paper) == analyze(paper, suspension="cpu")
    ts = _suspending_with_sections(0.5, 3, 6)
    plain = TaskSet(
        tuple(
            replace(t, segments=tuple(Segment(s.name, s.wcet) for s in t.segments))
            for t in ts.tasks
        )
    )
    assert analyze(plain) == analyze(plain, suspension="cpu")
    flat = TaskSet(
        (replace(ts.tasks[0], segments=(Segment("a", 2.5, resource="R"),)), *ts.tasks[1:])
    )
    assert analyze(flat) == analyze(flat, suspension="cpu")
