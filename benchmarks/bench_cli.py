"""Benchmark: the CLI's own loop, with its outputs, as a user runs it.

    python benchmarks/bench_cli.py [--scenario test2] [--duration 3600] [--repeat 3] [--json]

Runs ``rtsim scenario SCENARIO --duration D --no-figures --out DIR`` ``--repeat`` times, each
in a fresh interpreter (as a user's command), and prints the best of the runs: the loop's wall
time (``timing.simulation_s`` of manifest.json: windows.csv and jobs.csv are written during
the loop), its process CPU time (``timing.simulation_cpu_s``: robust on a shared machine), µs
per window, simulated time over each, and the command's end-to-end time. Target: the loop at
≥ 1,500× real time in CPU time (issue 36).
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _machine import print_machine

TARGET = 1500.0


def one_run(scenario: str, duration: float, extra: list[str] | None = None) -> dict[str, Any]:
    """Timing of one ``rtsim scenario`` command in a fresh interpreter."""
    out = Path(tempfile.mkdtemp(prefix="bench_cli_"))
    try:
        t0 = time.perf_counter()
        subprocess.run(
            [
                sys.executable,
                "-m",
                "rtsim",
                "scenario",
                scenario,
                "--duration",
                str(duration),
                "--no-figures",
                "--out",
                str(out / "run"),
                *(extra or []),
            ],
            check=True,
            capture_output=True,
        )
        wall = time.perf_counter() - t0
        timing = json.loads((out / "run" / "manifest.json").read_text())["timing"]
        windows = json.loads((out / "run" / "summary.json").read_text())["windows"]
    finally:
        shutil.rmtree(out, ignore_errors=True)
    return {
        "loop_s": timing["simulation_s"],
        "loop_cpu_s": timing["simulation_cpu_s"],
        "total_s": timing["total_s"],
        "process_s": wall,
        "windows": int(windows),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="test2")
    ap.add_argument("--duration", type=float, default=3600.0, help="simulated seconds")
    ap.add_argument("--repeat", type=int, default=3, help="best of this many runs")
    ap.add_argument("--json", action="store_true", help="print one JSON line at the end")
    args = ap.parse_args(argv)
    m = print_machine()
    runs = [one_run(args.scenario, args.duration) for _ in range(args.repeat)]
    best = {k: min(r[k] for r in runs) for k in ("loop_s", "loop_cpu_s", "total_s", "process_s")}
    windows = runs[0]["windows"]
    d = args.duration
    print(
        f"rtsim scenario {args.scenario} --duration {d:g} --no-figures: {windows} windows, "
        f"best of {args.repeat}"
    )
    print(
        f"loop wall  {best['loop_s']:7.2f} s  {d / best['loop_s']:7.0f}x real time  "
        f"{1e6 * best['loop_s'] / windows:6.0f} us/window"
    )
    print(
        f"loop CPU   {best['loop_cpu_s']:7.2f} s  {d / best['loop_cpu_s']:7.0f}x real time  "
        f"{1e6 * best['loop_cpu_s'] / windows:6.0f} us/window   (target >= {TARGET:g}x)"
    )
    print(f"command    {best['total_s']:7.2f} s  (process {best['process_s']:.2f} s)")
    if args.json:
        print(
            json.dumps(
                {
                    "machine": m,
                    "duration_s": d,
                    "windows": windows,
                    "repeat": args.repeat,
                    **best,
                    "x_real_time": d / best["loop_s"],
                    "x_real_time_cpu": d / best["loop_cpu_s"],
                }
            )
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
