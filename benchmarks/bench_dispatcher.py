"""Benchmark: the virtual CPU's dispatcher alone on Test 2's task set (not a test).

    python benchmarks/bench_dispatcher.py [--repeat 15] [--without dead_reckoning,command]
        [--no-hooks] [--opcodes]

What `benchmarks/profile_window.py` cannot separate from the run's set-up and tables: the
dispatcher's own cost per window. Builds the CPU of a sweep point's task set
(`barrel_robots`: dead reckoning above the window chain, the per-window command below it;
idle-mode suspension) with the hooks a scenario run registers, as no-op functions (release,
the scan's start, each send's end, the job's end) and its execution-time calls (the Hough
step, a drawn radio round trip), and a window provider drawn from a seeded generator
(180-230 ms). Runs about 514 windows (105 s simulated) ``--repeat`` times and prints the best
lap in CPU time, µs per window, and a digest of the statistics and of the job records (equal
digests across two checkouts: the same schedule, bit for bit). ``--without`` drops tasks and
``--no-hooks`` the segment and job-end hooks: the share of each in the cost. ``--opcodes``
also counts the bytecodes the interpreter runs per window, by function (a trace of one lap:
a count that does not depend on the machine's load, to compare two checkouts with).
"""

from __future__ import annotations

import argparse
import collections
import hashlib
import sys
import time
from dataclasses import replace
from typing import Any

import numpy as np
import simpy
from _machine import print_machine

from rtsim.config.scenario import taskset_file
from rtsim.config.taskset import load_taskset
from rtsim.sim.run import build_cpu

HORIZON_MS = 105_000.0


def lap(ts: Any, horizon: float, hooks: bool, record: bool = False) -> tuple[Any, int]:
    """One run of the dispatcher: (the CPU, windows released)."""
    env = simpy.Environment()
    ws = iter(np.random.default_rng(1).uniform(180.0, 230.0, 1000).tolist())
    cpu, _ = build_cpu(
        ts, env=env, window=lambda: next(ws), suspension="idle", seed=3, record_jobs=record
    )
    win = ts.window.name
    released = [0]

    def on_release(job: Any) -> None:
        released[0] += 1

    def on_segment(job: Any, seg: Any) -> None:
        pass

    def on_done(job: Any) -> None:
        pass

    cpu.on("release", on_release, task=win)
    if hooks:
        cpu.on("segment_start", on_segment, task=win, role="scan")
        cpu.on("segment_end", on_segment, task=win, role="send")
        cpu.on("job_end", on_done, task=win)
    cpu.set_exec_time(win, "hough", lambda job, seg, rng: 2.5)
    u = np.random.default_rng(2)
    cpu.set_exec_time(win, "radio", lambda job, seg, rng: float(u.uniform(33.5, 67.0)))
    env.run(until=cpu.start(horizon))
    return cpu, released[0]


def digest(cpu: Any) -> str:
    """A short hash of the run's statistics and totals (and job records, if kept)."""
    res = cpu.result()
    text = repr(
        (
            sorted((k, repr(v)) for k, v in res.tasks.items()),
            res.busy_time,
            res.context_switches,
            res.end_time,
        )
    )
    if res.jobs is not None:
        text += res.jobs.to_csv()
    return hashlib.sha1(text.encode()).hexdigest()[:12]


def opcodes(ts: Any, hooks: bool) -> tuple[collections.Counter[str], int]:
    """Bytecodes run per function (``file:name``) in one lap, traced; and the windows."""
    counts: collections.Counter[str] = collections.Counter()

    def tracer(frame: Any, event: str, arg: Any) -> Any:
        frame.f_trace_opcodes = True
        frame.f_trace_lines = False
        code = frame.f_code
        key = f"{code.co_filename.rsplit('/', 1)[-1]}:{code.co_name}"

        def count(frame: Any, event: str, arg: Any) -> Any:
            if event == "opcode":
                counts[key] += 1
            return count

        return count

    sys.settrace(tracer)
    try:
        _, windows = lap(ts, HORIZON_MS, hooks)
    finally:
        sys.settrace(None)
    return counts, windows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=15)
    ap.add_argument("--without", default="", help="comma-separated task names to drop")
    ap.add_argument("--no-hooks", action="store_true", help="no segment or job-end hooks")
    ap.add_argument("--opcodes", action="store_true", help="count bytecodes per window")
    args = ap.parse_args(argv)
    print_machine()
    ts = load_taskset(taskset_file("barrel_robots"))
    drop = {x for x in args.without.split(",") if x}
    if drop:
        ts = replace(ts, tasks=tuple(t for t in ts.tasks if t.name not in drop))
    hooks = not args.no_hooks
    lap(ts, 5_000.0, hooks)  # warm-up
    best, windows, cpu = float("inf"), 0, None
    for _ in range(args.repeat):
        t = time.process_time()
        cpu, windows = lap(ts, HORIZON_MS, hooks)
        best = min(best, time.process_time() - t)
    jobs, _ = lap(ts, HORIZON_MS, hooks, record=True)
    print(
        f"dispatcher: {1e6 * best / windows:.2f} us/window ({windows} windows, best lap "
        f"{1e3 * best:.2f} ms CPU of {args.repeat}); digest {digest(cpu)}, jobs {digest(jobs)}"
    )
    if args.opcodes:
        counts, windows = opcodes(ts, hooks)
        total = sum(counts.values())
        print(f"bytecodes: {total / windows:.0f} per window; by function (per window):")
        for key, n in counts.most_common(15):
            print(f"  {n / windows:8.1f}  {key}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
