"""Benchmark: what users run, per follower count — Test 1 and Test 2 with n = 2, 6 and 10
followers (or the largest count the scenario's layout accepts), a lap in-process and a run
through the CLI with its outputs.

    python benchmarks/bench_followers.py [--scenarios test1,test2] [--followers 2,6,10]
        [--repeat 3] [--cli-duration 600] [--json]

Per scenario and count, each in a fresh interpreter: a warm lap as a sweep point
(`bench_sweep_point.laps`: CPU per lap, rollouts per lap, the rollouts' own CPU and the
floor), and ``rtsim scenario S --set formation.followers=N --duration D --no-figures``
(`bench_cli.one_run`: windows.csv and jobs.csv written in the loop; the loop's CPU,
manifest ``timing.simulation_cpu_s``), best of ``--repeat``. Target: Test 1 at its largest
count ≤ 0.35 s CPU per lap (issue 36).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

from _machine import print_machine
from bench_cli import one_run

HERE = Path(__file__).resolve().parent
#: CPU s per lap of Test 1 at its largest follower count (issue 36's target)
TARGET_LAP_S = 0.35


def largest(scenario: str, n: int) -> int:
    """``n``, or the largest count below it that the scenario's layout accepts."""
    from rtsim.config.scenario import load_scenario
    from rtsim.errors import InputError

    for k in range(n, 0, -1):
        try:
            load_scenario(scenario, overrides={"formation.followers": k})
        except InputError:
            continue
        return k
    raise SystemExit(f"{scenario}: no follower count up to {n} fits its layout")


def lap(scenario: str, n: int, repeat: int) -> dict[str, Any]:
    """`bench_sweep_point.laps` in a fresh interpreter."""
    out = subprocess.run(
        [
            sys.executable,
            str(HERE / "bench_sweep_point.py"),
            "--scenario",
            scenario,
            "--followers",
            str(n),
            "--repeat",
            str(repeat),
            "--json",
        ],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    row: dict[str, Any] = json.loads(out.strip().splitlines()[-1])
    row.pop("machine")
    return row


def measure(scenarios: list[str], counts: list[int], repeat: int, duration: float) -> list[Any]:
    """One row per (scenario, count): the lap's figures and the CLI's (``cli_*``)."""
    rows = []
    for sc in scenarios:
        for n in dict.fromkeys(largest(sc, k) for k in counts):
            row = lap(sc, n, repeat)
            extra = ["--set", f"formation.followers={n}"]
            runs = [one_run(sc, duration, extra) for _ in range(repeat)]
            cpu = min(r["loop_cpu_s"] for r in runs)
            row.update(cli_duration_s=duration, cli_windows=runs[0]["windows"], cli_cpu_s=cpu)
            print(
                f"{sc} n={n}: lap {row['windows']} windows, best {row['best_ms']:.0f} ms CPU, "
                f"{row['rollouts']:,} rollouts ({row['rollouts_ms']:.0f} ms), floor "
                f"{row['floor_ms']:.0f} ms; CLI {duration:g} s with outputs: loop CPU "
                f"{cpu:.2f} s = {duration / cpu:,.0f}x real time",
                flush=True,
            )
            rows.append(row)
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", default="test1,test2")
    ap.add_argument("--followers", default="2,6,10")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--cli-duration", type=float, default=600.0, help="simulated s")
    ap.add_argument("--json", action="store_true", help="print one JSON line at the end")
    args = ap.parse_args(argv)
    m = print_machine()
    rows = measure(
        args.scenarios.split(","),
        [int(k) for k in args.followers.split(",")],
        args.repeat,
        args.cli_duration,
    )
    if args.json:
        print(json.dumps({"machine": m, "repeat": args.repeat, "rows": rows}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
