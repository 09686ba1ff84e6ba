"""Benchmark: one sweep point of Test 2 (one lap), warm, in one process.

    python benchmarks/bench_sweep_point.py [--scenario test2] [--repeat 5] [--json]

What a scenario sweep's worker pays per point once it is running: ``run_scenario(SCENARIO,
record_jobs=False)`` (one lap: the default duration), in CPU time of the process, after one
warm-up lap that pays the imports and any compilation. Prints the best and the median of
``--repeat`` laps. Target: ≤ 20 ms CPU per point.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time

from _machine import print_machine

TARGET_MS = 20.0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="test2")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--json", action="store_true", help="print one JSON line at the end")
    args = ap.parse_args(argv)
    m = print_machine()
    from rtsim.coupling import run_scenario

    res = run_scenario(args.scenario, record_jobs=False)  # warm-up: imports, caches
    times = []
    for _ in range(args.repeat):
        t = time.process_time()
        res = run_scenario(args.scenario, record_jobs=False)
        times.append(time.process_time() - t)
    best, med = min(times), statistics.median(times)
    w = int(res.summary["windows"])
    print(
        f"run_scenario({args.scenario!r}, record_jobs=False): one lap, {w} windows, "
        f"{res.summary['duration_s']:.1f} s simulated"
    )
    print(
        f"CPU per point: best {1e3 * best:.1f} ms, median {1e3 * med:.1f} ms of "
        f"{args.repeat} ({1e6 * best / w:.0f} us/window; target <= {TARGET_MS:g} ms)"
    )
    if args.json:
        print(
            json.dumps(
                {
                    "machine": m,
                    "windows": w,
                    "repeat": args.repeat,
                    "best_ms": 1e3 * best,
                    "median_ms": 1e3 * med,
                }
            )
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
