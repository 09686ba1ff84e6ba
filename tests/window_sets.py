"""Window task sets for the analysis tests: a hand-made set and a stream of random ones."""

from __future__ import annotations

import numpy as np

from rtsim.analysis.rta import analyze
from rtsim.model.task import Task
from rtsim.model.taskset import TaskSet
from rtsim.model.window import WindowSpec


def window_set(
    hp: list[tuple[float, float]], lp: list[tuple[float, float | str]], n: int = 2, **win
) -> TaskSet:
    """hp: (e, p ms); lp: (e, p) with p a number (ms) or 'c' for c·w."""
    spec = dict(
        n=n,
        r_H=25,
        e_cal=0.001,
        e_trans=0.1,
        k=34,
        e_scan=106,
        e_estimate=1,
        e_send=2,
        e_recv=1,
        delta_t=67,
        e_sched=1,
        priority=100,
    )
    spec.update(win)
    tasks = [Task(f"hp{i}", e, p, priority=i) for i, (e, p) in enumerate(hp)]
    for i, (e, p) in enumerate(lp):
        pw = isinstance(p, str)
        tasks.append(Task(f"lp{i}", e, float(p), priority=101 + i, per_window=pw))
    return TaskSet(tuple(tasks), window=WindowSpec(**spec))


def random_window_sets(seed: int, count: int):
    rng = np.random.default_rng(seed)
    made = 0
    while made < count:
        hp = [
            (float(rng.integers(1, 15)), float(rng.integers(20, 120)))
            for _ in range(int(rng.integers(0, 3)))
        ]
        lp: list[tuple[float, float | str]] = []
        for _ in range(int(rng.integers(0, 4))):
            e = float(rng.integers(1, 40))
            if rng.random() < 0.7:
                lp.append((e, str(float(rng.choice([1.0, 1.5, 2.0, 3.0, 4.0])))))
            else:
                lp.append((e, float(rng.integers(300, 3000))))
        ts = window_set(hp, lp, n=int(rng.integers(1, 6)), delta_t=float(rng.integers(0, 80)))
        if (not hp or analyze(TaskSet(ts.hp)).schedulable) and sum(e / p for e, p in hp) < 0.6:
            made += 1
            yield ts
