"""Sweep engine speed: one 40-point sweep with 1 and with 2 local workers (run by hand).

    python benchmarks/bench_sweep.py [--horizon MS] [--workers 1 2]

Each point simulates the paper's task set (n = 1..10 x r_H = 10, 20, 30, 40 cm) for
``--horizon`` ms with uniform execution times. Reports wall time, time per point and the
speed-up over one worker (target >= 1.7x on 2 cores), and checks the tables are equal.
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

SPEC = """
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--horizon",
        type=float,
        default=1_500_000.0,
        help="ms simulated per point (default 25 min: ~0.8 s of work a point)",
    )
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        spec = Path(tmp) / "bench.toml"
        spec.write_text(
            SPEC.format(base=ROOT / "tasksets" / "barrel_robots.toml", horizon=args.horizon)
        )
        tables: dict[int, pd.DataFrame] = {}
        times: dict[int, float] = {}
        for w in args.workers:
            t0 = time.perf_counter()
            tables[w] = run_sweep(spec, Path(tmp) / f"w{w}", workers=w)
            times[w] = time.perf_counter() - t0
            tim = pd.read_csv(Path(tmp) / f"w{w}" / "timings.csv")
            print(
                f"workers={w}: {times[w]:.2f} s for {len(tables[w])} points, "
                f"{times[w] / len(tables[w]) * 1000:.0f} ms/point overall; inside a worker "
                f"{tim['wall_s'].mean() * 1000:.0f} ms wall, "
                f"{tim['cpu_s'].mean() * 1000:.0f} ms CPU per point; "
                f"CPU/wall inside workers {tim['cpu_s'].sum() / tim['wall_s'].sum():.2f} "
                "(below 1: the cores are shared)"
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
