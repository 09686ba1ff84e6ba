"""Benchmark: one simulated hour of the paper's Test 2 (issue 5, "Speed").

``python benchmarks/bench_scenario.py [--duration 3600] [--mode adjust] [--profile] [--out DIR]
[--backends fast,filterpy] [--repeat 3]``

Runs ``rtsim scenario experiments/scenarios/test2.toml --duration D --out DIR`` end to end
(tables and figures included) and prints the wall time of the simulation loop alone
(``timing.simulation_s`` of the manifest), the ratio simulated/wall (target ≥ 1000×), and the
end-to-end time (``timing.total_s``). ``--profile`` runs the loop under cProfile instead and
prints the 25 most expensive functions (no output files).

Then, for each EKF backend of ``--backends`` (``fast``: plain floats, the scenarios' default;
``filterpy``: one filterpy ExtendedKalmanFilter per follower, SPEC's reference), it runs the
loop ``--repeat`` times with job records on (as the CLI does) and prints a table of the best
CPU time of the loop (``timing.simulation_cpu_s``: robust on a shared machine), µs per
window and the ratio simulated/CPU time. ``--backends ""`` skips the table.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import sys
import tempfile
import time
from pathlib import Path

from rtsim.cli import main as rtsim_main

TEST2 = Path(__file__).resolve().parent.parent / "experiments" / "scenarios" / "test2.toml"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=3600.0, help="simulated seconds")
    ap.add_argument("--mode", default="adjust")
    ap.add_argument("--scenario", default=str(TEST2))
    ap.add_argument("--profile", action="store_true")
    ap.add_argument("--out", default=None, help="output directory (default: a temp dir)")
    ap.add_argument("--backends", default="fast,filterpy",
                    help="EKF backends to time in the table (comma-separated; '' = none)")
    ap.add_argument("--repeat", type=int, default=3, help="best of this many loop runs")
    args = ap.parse_args(argv)
    if args.profile:
        from rtsim.coupling import run_scenario

        prof = cProfile.Profile()
        prof.enable()
        res = run_scenario(args.scenario, mode=args.mode, duration_s=args.duration,
                           record_jobs=False)
        prof.disable()
        pstats.Stats(prof).sort_stats("tottime").print_stats(25)
        print(res.timing)
        return 0
    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="bench_scenario_"))
    t0 = time.perf_counter()
    rc = rtsim_main(["scenario", args.scenario, "--mode", args.mode,
                     "--duration", str(args.duration), "--out", str(out)])
    wall = time.perf_counter() - t0
    if rc != 0:
        return rc
    m = json.loads((out / "manifest.json").read_text())
    s = json.loads((out / "summary.json").read_text())
    t = m["timing"]
    print(f"scenario {Path(args.scenario).name}, mode {args.mode}: {args.duration:g} s "
          f"simulated, {s['windows']} windows")
    print(f"simulation loop   {t['simulation_s']:8.2f} s  "
          f"({args.duration / t['simulation_s']:7.0f}x real time)")
    print(f"  (CPU time {t['simulation_cpu_s']:8.2f} s  "
          f"({args.duration / t['simulation_cpu_s']:7.0f}x real time))")
    print(f"setup + tables    {t['setup_s'] + t['tables_s']:8.2f} s")
    print(f"end to end        {t['total_s']:8.2f} s  (process wall {wall:.2f} s, out {out})")
    backends = [b for b in args.backends.split(",") if b]
    if backends:
        print()
        print(backend_table(args.scenario, args.mode, args.duration, backends, args.repeat))
    return 0


def backend_table(scenario: str, mode: str, duration: float, backends: list[str],
                  repeat: int) -> str:
    """Best-of-``repeat`` CPU time of the loop per EKF backend, as a text table."""
    from dataclasses import replace

    from rtsim.coupling import run_scenario
    from rtsim.io.scenario import load_scenario

    base = load_scenario(scenario)
    lines = [f"{'EKF backend':12s} {'windows':>8s} {'loop CPU s':>11s} {'us/window':>10s} "
             f"{'x real time':>12s}  (best of {repeat}, job records on)"]
    for backend in backends:
        world = replace(base.world, ekf=replace(base.world.ekf, backend=backend))
        sc = replace(base, world=world)
        best, windows = float("inf"), 0
        for _ in range(repeat):
            res = run_scenario(sc, mode=mode, duration_s=duration, record_jobs=True)
            best = min(best, res.timing["simulation_cpu_s"])
            windows = int(res.summary["windows"])
        lines.append(f"{backend:12s} {windows:8d} {best:11.2f} {1e6 * best / windows:10.0f} "
                     f"{duration / best:12.0f}")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
