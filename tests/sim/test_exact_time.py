"""Exact time (docs/time.md): releases computed from each stream's start, compensated segment
ends, and a coincidence window that grows with the clock's own resolution."""

from __future__ import annotations

import itertools
import json
import math

import pytest
import simpy

from rtsim.cli import main
from rtsim.config.taskset import load_taskset
from rtsim.model.task import Task
from rtsim.sim import CPU, simulate
from rtsim.sim.cpu import coincidence
from rtsim.sim.records import EPS

W_RTA = 235.22699081698724  # w_rta of tasksets/barrel_robots.toml (the command's R = D)
W_EDF = 234.54513236227112  # w_edf of the same set (U = 1 under EDF)


def _releases(periods: list[float], horizon: float) -> tuple[list[float], list[float]]:
    """Arrivals of a window task with a period provider and of a 2w per-window task."""
    env = simpy.Environment()
    cpu = CPU(env)
    cyc = iter(periods)
    last = [periods[-1]]

    def provider() -> float:
        last[0] = next(cyc, last[0])
        return last[0]

    cpu.add_task(Task("win", 1.0, 1.0, priority=1), period_provider=provider, window=True)
    cpu.add_task(Task("cmd", 1.0, 2.0, priority=2, per_window=True))
    seen: dict[str, list[float]] = {"win": [], "cmd": []}
    cpu.on("release", lambda job: seen[job.name].append(job.arrival))
    env.run(until=cpu.start(horizon))
    return seen["win"], seen["cmd"]


def test_a_constant_window_releases_at_exactly_k_times_w():
    # a running sum of w drifts from k·w by many ulps within 1e5 releases; k·w does not
    w = 235.22699081698724
    win, cmd = _releases([w], 2e7)
    assert len(win) > 80_000
    assert all(r == k * w for k, r in enumerate(win))
    # the 2w task's arrivals are the window's even arrivals, bit for bit
    assert all(r == win[2 * j] for j, r in enumerate(cmd))
    summed = itertools.accumulate([0.0] + [w] * (len(win) - 1))
    drift = max(abs(r - s) for r, s in zip(win, summed, strict=True))
    assert drift > 1e-7  # what adding up periods would have given


def test_a_window_stream_restarts_its_count_when_w_changes():
    win, _ = _releases([240.0, 240.0, 237.1, 237.1, 237.1, 251.3], 5000.0)
    # 0, 240, 480 at 240; from 480, 237.1 each; from 480 + 3·237.1, 251.3 each
    a = 480.0
    assert win[:3] == [0.0, 240.0, 480.0]
    assert win[3:6] == [a + k * 237.1 for k in (1, 2, 3)]
    b = a + 3 * 237.1
    assert win[6:] == [b + k * 251.3 for k in range(1, len(win) - 5)]


def test_coincidence_window_is_absolute_then_sixteen_ulps():
    assert coincidence(0.0)[0] == coincidence(5e5)[0] == EPS  # runs up to 8.7 min: 1e-9 ms
    for t in (6e5, 3.6e6, 1e8, 1e9):
        tol, until = coincidence(t)
        assert tol == 16 * math.ulp(t) > EPS and until > t and coincidence(until)[0] == 2 * tol
    assert coincidence(1e8)[0] < 3e-7  # far below anything physical


def test_reproducer_of_release_drift_runs_clean_for_ten_hours(capsys: pytest.CaptureFixture[str]):
    # before exact time: 2 misses of the command task within 36e6 ms at w_rta (R = D)
    assert (
        main(
            [
                "simulate",
                "tasksets/barrel_robots.toml",
                "--window",
                repr(W_RTA),
                "--horizon",
                "36000000",
                "--json",
            ]
        )
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    assert out["misses"] == 0
    cmd = next(t for t in out["tasks"] if t["name"] == "command")
    assert cmd["max_response"] == pytest.approx(cmd["wcrt_analysis"], abs=1e-6)


@pytest.mark.slow
@pytest.mark.parametrize("scheduler,w", [("fp", W_RTA), ("edf", W_EDF)])
def test_1e8_ms_at_the_least_window_has_no_miss(scheduler: str, w: float):
    # 1e8 ms is about 12 s of CPU per run. Under EDF at U = 1 the CPU is never idle: without
    # compensated segment ends the window job's rounding pushed later jobs 3e-4 ms past
    # their deadlines; under FP at w_rta the command's R = D needed a coincidence window
    # wider than 1e-9 ms beyond 2^25 ms
    res = simulate(load_taskset("tasksets/barrel_robots.toml"), 1e8, window=w, scheduler=scheduler)
    assert res.misses == 0
    assert res.busy_time == pytest.approx(res.end_time, rel=1e-2)  # a busy run indeed
