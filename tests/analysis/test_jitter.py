"""Release jitter: the analysis (level-i busy window with jitter) against hand-worked values and
a brute-force reference, and the simulator's ``jitter`` modes (SPEC §8)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from rtsim.analysis.rta import analyze, busy_window, response_time
from rtsim.config.taskset import parse_taskset, taskset_to_dict
from rtsim.errors import TaskSetError
from rtsim.model.task import Task
from rtsim.model.taskset import TaskSet
from rtsim.sim import simulate


def test_hand_worked_constrained():
    # hp (C=1, T=4, J=2); task (C=2, T=10, J=1): w = 2 + ⌈(w+2)/4⌉ → 3, 4, 4; R = 1 + 4 = 5.
    hp = Task("h", 1, 4, priority=1, jitter=2)
    lo = Task("l", 2, 10, priority=2, jitter=1)
    assert response_time(lo, [hp]) == 5.0
    assert response_time(Task("l", 2, 10, priority=2), [Task("h", 1, 4, priority=1)]) == 3.0
    assert response_time(hp, []) == 3.0  # its own jitter counts: J + C


def test_hand_worked_arbitrary_deadline():
    # hp (2, 5, J=1); task (4, 7, J=2, D=30). By hand, w(q) = 8, 14, 22, 28, 34, 42, 48, 54;
    # R(q) = 2 + w(q) − 7q = 10, 9, 10, 9, 8, 9, 8, 7; the window closes at q = 7
    # (54 ≤ 8·7 − 2). R = 10.
    hp = Task("h", 2, 5, priority=1, jitter=1)
    lo = Task("l", 4, 7, 30, priority=2, jitter=2)
    assert response_time(lo, [hp]) == 10.0
    assert busy_window(4, 7, 2, 9.999, [(2, 5, 1)]) is None  # D just below R
    res = simulate([hp, lo], 200, jitter="worst")
    assert res.tasks["l"].max_response == 10.0 and res.misses == 0


# -- brute force --------------------------------------------------------------------------
def brute_max_response(
    tasks: list[tuple[int, int, int]], phases: list[int], delays: list[list[int]], horizon: int
) -> int:
    """Largest response (from arrival) of the last task, unit-step FP scheduler.

    tasks: (C, T, J) in priority order; job k of task i arrives at phases[i] + k·T_i and is
    released delays[i][k] later (the last value repeats). Jobs of a task run in arrival order.
    """
    jobs: list[list[list[int]]] = []  # per task: [arrival, release, remaining]
    for (c, t, _), ph, dl in zip(tasks, phases, delays, strict=True):
        mine = []
        k = 0
        while ph + k * t < horizon:
            mine.append([ph + k * t, ph + k * t + dl[min(k, len(dl) - 1)], c])
            k += 1
        jobs.append(mine)
    worst, now = 0, 0
    heads = [0] * len(tasks)
    while any(h < len(j) for h, j in zip(heads, jobs, strict=True)):
        for i, mine in enumerate(jobs):
            h = heads[i]
            if h < len(mine) and mine[h][1] <= now:
                mine[h][2] -= 1
                if mine[h][2] == 0:
                    heads[i] += 1
                    if i == len(tasks) - 1:
                        worst = max(worst, now + 1 - mine[h][0])
                break
        now += 1
    return worst


def random_integer_sets(seed: int, count: int):
    rng = np.random.default_rng(seed)
    made = 0
    while made < count:
        ts = [
            (int(rng.integers(1, 3)), int(rng.integers(3, 7)), int(rng.integers(0, 3)))
            for _ in range(3)
        ]
        if sum(c / t for c, t, _ in ts) <= 0.95:
            made += 1
            yield ts


@pytest.mark.parametrize("seed", [1, 2])
def test_against_brute_force(seed):
    # Every task set: the analysed R (D = ∞ so the busy window is analysed to its end) is
    # never exceeded over integer phases of the higher tasks × first delays × later delays
    # (0 or J) of every task, and is reached (the family contains the critical instant:
    # arrivals at t0 − J_k, first delays J_k, later delays 0).
    for tasks in random_integer_sets(seed, 3):
        (c1, t1, j1), (c2, t2, j2), (c, t, j) = tasks
        r = busy_window(c, t, j, 1e6, [(c1, t1, j1), (c2, t2, j2)])
        assert r is not None
        worst, t0 = 0, max(j1, j2, j)  # the critical instant: t0 − J_k < T_k for every k
        for ph1, ph2 in itertools.product(range(t1), range(t2)):
            for d1, d2, d0 in itertools.product(range(j1 + 1), range(j2 + 1), range(j + 1)):
                for l1, l2, l0 in itertools.product({0, j1}, {0, j2}, {0, j}):
                    got = brute_max_response(
                        tasks, [ph1, ph2, t0 - j], [[d1, l1], [d2, l2], [d0, l0]], 40
                    )
                    worst = max(worst, got)
                    assert got <= r + 1e-9, (tasks, ph1, ph2, d1, d2, d0, got, r)
        assert worst == r, (tasks, worst, r)


# -- the simulator ------------------------------------------------------------------------
def test_worst_reaches_analysis_and_random_stays_below():
    tasks = [
        Task("a", 1.5, 6.0, priority=1, jitter=2.0),
        Task("b", 2.25, 9.0, priority=2, jitter=1.0),
        Task("c", 3.0, 20.0, 18.0, priority=3, jitter=4.0),
    ]
    ana = analyze(TaskSet(tuple(tasks)))
    assert ana.schedulable
    worst = simulate(tasks, 400.0, jitter="worst")
    for t in ana.tasks:
        assert worst.tasks[t.name].max_response == pytest.approx(t.wcrt, abs=1e-9)
    for seed in range(3):
        res = simulate(tasks, 2000.0, jitter="random", seed=seed, record_jobs=True)
        jobs = res.jobs
        delay = jobs["release"] - jobs["arrival"]
        jit = jobs["task"].map({t.name: t.jitter for t in tasks})
        assert (delay >= 0).all() and (delay <= jit).all() and (delay > 0).any()
        assert np.allclose(jobs["response"], jobs["finish"] - jobs["arrival"])
        assert res.misses == 0
        for t in ana.tasks:
            assert res.tasks[t.name].max_response <= t.wcrt + 1e-9


def test_zero_jitter_is_bit_identical_in_every_mode():
    tasks = [
        Task("a", 1.5, 6.0, priority=1),
        Task("b", 2.25, 9.0, priority=2, bcet=1.0),
        Task("c", 3.0, 20.0, priority=3, offset=1.0, bcet=0.5),
    ]
    runs = [
        simulate(tasks, 500.0, jitter=m, exec_model="uniform", seed=4, record_jobs=True)
        for m in ("random", "worst", "none")
    ]
    for r in runs[1:]:
        assert r.jobs.equals(runs[0].jobs)
    assert (runs[0].jobs["arrival"] == runs[0].jobs["release"]).all()


def test_jitter_keeps_execution_draws_and_is_seeded():
    base = [Task("a", 2.0, 6.0, priority=1, bcet=0.5), Task("b", 2.0, 9.0, priority=2, bcet=1.0)]
    jit = [
        Task("a", 2.0, 6.0, priority=1, bcet=0.5, jitter=1.5),
        Task("b", 2.0, 9.0, priority=2, bcet=1.0),
    ]
    a = simulate(base, 300.0, exec_model="uniform", seed=7, record_jobs=True).jobs
    b = simulate(jit, 300.0, exec_model="uniform", seed=7, record_jobs=True).jobs
    c = simulate(jit, 300.0, exec_model="uniform", seed=7, record_jobs=True).jobs
    assert b.equals(c)
    key = ["task", "job"]
    ea = a.sort_values(key)["exec_time"].to_numpy()
    eb = b.sort_values(key)["exec_time"].to_numpy()
    assert np.allclose(ea, eb, rtol=0, atol=1e-9)  # delays come from their own stream
    assert not a.equals(b)


def test_jobs_run_in_arrival_order_when_jitter_exceeds_period():
    t = Task("a", 1.0, 2.0, 10.0, priority=1, jitter=5.0)
    res = simulate([t], 200.0, seed=3, record_jobs=True)
    jobs = res.jobs.sort_values("job")
    assert (np.diff(jobs["finish"].to_numpy()) > 0).all()
    assert (jobs["start"] >= jobs["release"] - 1e-12).all()
    r = response_time(t, [])
    assert r is not None and res.tasks["a"].max_response <= r + 1e-9


def test_jitter_key_in_files():
    data = {"tasks": [{"name": "a", "wcet": 1, "period": 5, "jitter": 2}]}
    ts = parse_taskset(data, "f.toml")
    assert ts.tasks[0].jitter == 2.0
    assert parse_taskset(taskset_to_dict(ts), "g").tasks[0].jitter == 2.0
    for bad, msg in [(-1, "non-negative"), ("x", "number"), (math.inf, "finite")]:
        data["tasks"][0]["jitter"] = bad
        with pytest.raises(TaskSetError, match=f"f.toml: task 'a': jitter: must be .*{msg}"):
            parse_taskset(data, "f.toml")


def test_cli_simulate_jitter_worst(tmp_path, capsys):
    import json

    from rtsim.cli import main

    f = tmp_path / "j.toml"
    f.write_text(
        '[[tasks]]\nname = "h"\nwcet = 2\nperiod = 5\njitter = 1\n'
        '[[tasks]]\nname = "l"\nwcet = 4\nperiod = 7\ndeadline = 30\njitter = 2\n'
    )
    assert main(["simulate", str(f), "--horizon", "200", "--jitter", "worst", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    got = {t["name"]: (t["max_response"], t["wcrt_analysis"]) for t in out["tasks"]}
    assert got == {"h": (3.0, 3.0), "l": (10.0, 10.0)} and out["jitter"] == "worst"
    with pytest.raises(SystemExit) as exc:  # argparse: a usage error
        main(["simulate", str(f), "--horizon", "200", "--jitter", "bad"])
    assert exc.value.code == 2
