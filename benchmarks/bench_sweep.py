"""Sweep engine speed: one sweep with 1 and with 2 local workers (run by hand).

    python benchmarks/bench_sweep.py [--kind simulate|scenario] [--horizon MS]
        [--duration S] [--workers 1 2] [--repeat 1]

``--kind simulate`` (the default): 40 points simulating the paper's task set (n = 1..10 x
r_H = 10, 20, 30, 40 cm) for ``--horizon`` ms with uniform execution times. ``--kind
scenario``: 12 points of Test 2 over its followers and Hough radii (``formation.followers``
= 1..3 x ``sensing.r_H`` = 20, 25, 30, 35 cm), each ``--duration`` simulated seconds (a few:
what a point costs outside its loop shows — parsing, set-up, summary). Reports wall time,
time per point (wall, and CPU inside the workers from timings.csv, with the loop's share of
it for the in-process run), the speed-up over one worker (target >= 1.7x on 2 cores), and
checks the tables are equal. ``--repeat``: that many sweeps per worker count, the best
kept (each into a fresh directory, in a process whose caches are cleared first: what a new
sweep costs).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import pandas as pd

from rtsim.sweep import run_sweep

ROOT = Path(__file__).resolve().parent.parent

SIMULATE = """
[sweep]
kind = "simulate"
base = "{base}"
seed = 1
[sweep.options]
horizon = {horizon}
exec = "uniform"
suspension = "idle"
[sweep.set]
"tasks.dead_reckoning.bcet" = 2
"tasks.command.bcet" = 10
[grid]
n = "1..10"
r_H = [10, 20, 30, 40]
"""

SCENARIO = """
[sweep]
kind = "scenario"
base = "test2"
seed = 1
[sweep.options]
duration = {duration}
[grid]
"formation.followers" = "1..3"
"sensing.r_H" = [20, 25, 30, 35]
"""


def clear_caches() -> None:
    """Forget what this process prepared for earlier sweeps (each measured sweep starts as a
    new one would; compiled kernels stay loaded)."""
    from rtsim.sweep.kinds import forget_prepared

    forget_prepared()


def loop_cpu() -> list[float]:
    """Sum the CPU time of coupled runs' loops (`_Coupling.run`) in this process into the
    returned one-element list from now on."""
    from rtsim.coupling import scenario_run

    spent = [0.0]
    run = scenario_run._Coupling.run

    def timed(self: object) -> None:
        t = time.process_time()
        try:
            run(self)  # type: ignore[arg-type]
        finally:
            spent[0] += time.process_time() - t

    scenario_run._Coupling.run = timed  # type: ignore[method-assign]
    return spent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kind", choices=("simulate", "scenario"), default="simulate")
    ap.add_argument(
        "--horizon",
        type=float,
        default=1_500_000.0,
        help="simulate: ms simulated per point (default 25 min: ~0.8 s of work a point)",
    )
    ap.add_argument("--duration", type=float, default=5.0, help="scenario: simulated s per point")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args()
    if args.kind == "simulate":
        text = SIMULATE.format(base=ROOT / "tasksets" / "barrel_robots.toml", horizon=args.horizon)
    else:
        text = SCENARIO.format(duration=args.duration)
    loop = loop_cpu()
    with tempfile.TemporaryDirectory() as tmp:
        spec = Path(tmp) / "bench.toml"
        spec.write_text(text)
        if args.kind == "scenario":  # imports and compiled kernels, outside the timing
            run_sweep(spec, Path(tmp) / "warm", workers=1)
        tables: dict[int, pd.DataFrame] = {}
        times: dict[int, float] = {}
        for w in args.workers:
            best: tuple[float, ...] | None = None
            for r in range(args.repeat):
                clear_caches()
                loop[0] = 0.0
                out = Path(tmp) / f"w{w}-{r}"
                t0 = time.perf_counter()
                tables[w] = run_sweep(spec, out, workers=w)
                wall = time.perf_counter() - t0
                tim = pd.read_csv(out / "timings.csv")
                got = (wall, tim["wall_s"].mean(), tim["cpu_s"].mean(), tim["cpu_s"].sum())
                got += (tim["wall_s"].sum(), loop[0])
                if best is None or got[0] < best[0]:
                    best = got
            assert best is not None
            wall, w_mean, c_mean, c_sum, w_sum, in_loop = best
            times[w] = wall
            n = len(tables[w])
            outside = (
                f"; outside the loop {(c_sum - in_loop) / n * 1000:.1f} ms CPU per point"
                if w == 1 and in_loop > 0
                else ""
            )
            print(
                f"workers={w}: {wall:.2f} s for {n} points, "
                f"{wall / n * 1000:.0f} ms/point overall; inside a worker "
                f"{w_mean * 1000:.0f} ms wall, {c_mean * 1000:.1f} ms CPU per point{outside}; "
                f"CPU/wall inside workers {c_sum / w_sum:.2f} (below 1: the cores are shared)"
            )
        first = args.workers[0]
        for w in args.workers[1:]:
            pd.testing.assert_frame_equal(tables[first], tables[w])
            print(
                f"speed-up {first} -> {w} workers: {times[first] / times[w]:.2f}x "
                f"(cpu_count={os.cpu_count()}, load average {os.getloadavg()[0]:.2f})"
            )


if __name__ == "__main__":
    main()
