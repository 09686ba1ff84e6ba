"""Soundness on the deadline boundary, both directions (SPEC §8, tolerances).

Random fixed-priority sets with non-integer WCETs and periods, large periods and release jitter
are pushed onto their deadline boundary (D_i = the analysed R_i) and simulated under
``jitter="worst"`` (the critical instant) and ``"random"``, with simulated times ≤ 1e6 ms:

- analysed schedulable ⇒ no simulated miss (the analysis is never optimistic), and
- the simulated maximum response from arrival equals the analysed R_i (to 1e-9 ms), so a
  deadline just below R_i is missed in simulation as the analysis says: a merely pessimistic
  analysis fails here.
"""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rtsim.analysis.rta import analyze, response_time
from rtsim.model.task import Task
from rtsim.model.taskset import TaskSet
from rtsim.sim import simulate

TOL = 1e-9


@st.composite
def boundary_sets(draw: st.DrawFn) -> list[Task]:
    n = draw(st.integers(2, 4))
    base = draw(st.sampled_from([1.0, 7.3, 250.0, 3_000.0, 30_000.0]))
    periods = sorted(round(base * draw(st.floats(1.0, 8.0)), 3) for _ in range(n))
    share = draw(st.floats(0.3, 0.92))
    weights = [draw(st.floats(0.1, 1.0)) for _ in range(n)]
    tasks = []
    for i, p in enumerate(periods):
        c = round(p * share * weights[i] / sum(weights), 4)
        jit = round(p * draw(st.sampled_from([0.0, 0.0, 0.05, 0.3])), 3)
        tasks.append(Task(f"t{i}", max(c, 1e-3), p, priority=i + 1, jitter=jit))
    # each task's deadline on its boundary: its WCRT when that fits in the period
    out: list[Task] = []
    for t in tasks:
        r = response_time(Task(t.name, t.wcet, t.period, 1e9, t.priority, jitter=t.jitter), out)
        d = r if r is not None and r <= t.period else t.period
        out.append(Task(t.name, t.wcet, t.period, d, t.priority, jitter=t.jitter))
    return out


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(boundary_sets())
def test_boundary_both_directions(tasks):
    ana = analyze(TaskSet(tuple(tasks)))
    longest = max(t.period for t in tasks)
    horizon = max(t.jitter for t in tasks) + 3 * longest
    assert horizon < 1e6
    worst = simulate(tasks, horizon, jitter="worst")
    for t, a in zip(tasks, ana.tasks, strict=True):
        sim = worst.tasks[t.name]
        if a.schedulable:
            assert sim.misses == 0, (t, a.wcrt, sim.max_response)
            assert sim.max_response <= a.wcrt + TOL
        if a.schedulable and a.wcrt == t.deadline:  # on the boundary: reached exactly
            assert abs(sim.max_response - a.wcrt) <= TOL, (t, a.wcrt, sim.max_response)
    if ana.schedulable:
        rnd = simulate(tasks, horizon, jitter="random", seed=1)
        assert rnd.misses == 0
    # just below the boundary the analysis and the simulation both see a miss
    i = max(range(len(tasks)), key=lambda k: ana.tasks[k].wcrt or 0.0)
    a = ana.tasks[i]
    if a.schedulable and a.wcrt == tasks[i].deadline and a.wcrt > 1e-5:
        t = tasks[i]
        tighter = [
            *tasks[:i],
            Task(t.name, t.wcet, t.period, a.wcrt - 1e-6, t.priority, jitter=t.jitter),
        ]
        assert not analyze(TaskSet(tuple(tighter))).schedulable
        assert simulate(tighter, horizon, jitter="worst").tasks[t.name].misses >= 1


def test_release_just_before_the_finish_on_a_large_period():
    # lo's work alone ends δ = 1e-5 ms after hp's second release at T = 2e5 ms: that job
    # preempts lo, so R = T + δ + C_hp. A ceiling tolerance relative to the period
    # (1e-9·T = 2e-4 ms > δ) missed it and reported T + δ: optimistic by C_hp.
    big = 200_000.0
    hp = Task("hp", 1.0, big, priority=1)
    lo = Task("lo", big - 1.0 + 1e-5, 1e6, priority=2)
    r = response_time(lo, [hp])
    assert r is not None and abs(r - (big + 1e-5 + 1.0)) < 1e-9
    sim = simulate([hp, lo], 1e6, jitter="worst")
    assert abs(sim.tasks["lo"].max_response - r) < 1e-9
