"""Benchmark: one simulated hour of the paper's Test 2 (the project's speed target).

``python benchmarks/bench_scenario.py [--duration 3600] [--mode POLICY] [--profile] [--out DIR]
[--backends compiled,python] [--repeat 3]``

Runs ``rtsim scenario experiments/scenarios/test2.toml --duration D --out DIR`` end to end
(tables and figures included) and prints the wall time of the simulation loop alone
(``timing.simulation_s`` of the manifest), the ratio simulated/wall (target ≥ 1000×), and the
end-to-end time (``timing.total_s``). ``--profile`` runs the loop under cProfile instead and
prints the 25 most expensive functions (no output files).

``--mode``: the adjustment policy, any registered one (passed as ``--policy``; default: the
scenario file's own, ``plan`` for Test 2 — what a user runs; ``adjust`` is the paper's
algorithm, this benchmark's default before 2026-11-26).

Then, for each world backend of ``--backends`` (``[world] backend``: ``compiled``, the default
where numba is installed; ``python``, the reference; ``filterpy``), it runs the
loop ``--repeat`` times with job records on (as the CLI does), each run in a fresh
interpreter, and prints a table of the best CPU time of the loop
(``timing.simulation_cpu_s``: robust on a shared machine), µs per window and the ratio
simulated/CPU time. ``--backends ""`` skips the table.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rtsim.cli import main as rtsim_main

TEST2 = Path(__file__).resolve().parent.parent / "experiments" / "scenarios" / "test2.toml"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=3600.0, help="simulated seconds")
    ap.add_argument("--mode", default=None, help="policy (default: the scenario's own)")
    ap.add_argument("--scenario", default=str(TEST2))
    ap.add_argument("--profile", action="store_true")
    ap.add_argument("--out", default=None, help="output directory (default: a temp dir)")
    ap.add_argument(
        "--backends",
        default="compiled,python",
        help="world backends to time in the table (comma-separated; '' = none)",
    )
    ap.add_argument("--repeat", type=int, default=3, help="best of this many loop runs")
    args = ap.parse_args(argv)
    if args.profile:
        from rtsim.coupling import run_scenario

        prof = cProfile.Profile()
        prof.enable()
        res = run_scenario(
            args.scenario, policy=args.mode, duration_s=args.duration, record_jobs=False
        )
        prof.disable()
        pstats.Stats(prof).sort_stats("tottime").print_stats(25)
        print(res.timing)
        return 0
    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="bench_scenario_"))
    t0 = time.perf_counter()
    mode = [] if args.mode is None else ["--policy", args.mode]
    rc = rtsim_main(
        [
            "scenario",
            args.scenario,
            *mode,
            "--duration",
            str(args.duration),
            "--out",
            str(out),
        ]
    )
    wall = time.perf_counter() - t0
    if rc != 0:
        return rc
    m = json.loads((out / "manifest.json").read_text())
    s = json.loads((out / "summary.json").read_text())
    t = m["timing"]
    print(
        f"scenario {Path(args.scenario).name}, policy {s.get('policy')}: {args.duration:g} s "
        f"simulated, {s['windows']} windows"
    )
    print(
        f"simulation loop   {t['simulation_s']:8.2f} s  "
        f"({args.duration / t['simulation_s']:7.0f}x real time)"
    )
    print(
        f"  (CPU time {t['simulation_cpu_s']:8.2f} s  "
        f"({args.duration / t['simulation_cpu_s']:7.0f}x real time))"
    )
    print(f"setup + tables    {t['setup_s'] + t['tables_s']:8.2f} s")
    print(f"end to end        {t['total_s']:8.2f} s  (process wall {wall:.2f} s, out {out})")
    backends = [b for b in args.backends.split(",") if b]
    if backends:
        print()
        print(backend_table(args.scenario, args.mode, args.duration, backends, args.repeat))
    return 0


_LOOP_CODE = """
import json, sys
from rtsim.control.rollout import rollouts_run
from rtsim.coupling import run_scenario
scenario, mode, duration, backend = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4]
res = run_scenario(
    scenario,
    policy=mode or None,
    duration_s=duration,
    record_jobs=True,
    overrides={"world.backend": backend},
)
print(json.dumps([res.timing["simulation_cpu_s"], int(res.summary["windows"]), rollouts_run()]))
"""


def loop_cpu(
    scenario: str, mode: str | None, duration: float, backend: str
) -> tuple[float, int, int]:
    """(CPU s of the loop, windows, rollouts) of one run in a fresh interpreter, as the CLI
    runs it
    (an interpreter that has already made figures holds ~10x more objects, and the garbage
    collector's full passes over them slow the loop by up to ~25 %)."""
    out = subprocess.run(
        [sys.executable, "-c", _LOOP_CODE, scenario, mode or "", str(duration), backend],
        capture_output=True,
        text=True,
        check=True,
    )
    cpu_s, windows, rollouts = json.loads(out.stdout.strip().splitlines()[-1])
    return float(cpu_s), int(windows), int(rollouts)


def backend_table(
    scenario: str, mode: str | None, duration: float, backends: list[str], repeat: int
) -> str:
    """Best-of-``repeat`` CPU time of the loop per world backend (fresh interpreter per run,
    backends alternated), as a text table."""
    best = {b: float("inf") for b in backends}
    windows = {b: 0 for b in backends}
    for _ in range(repeat):
        for backend in backends:
            cpu_s, windows[backend], _ = loop_cpu(scenario, mode, duration, backend)
            best[backend] = min(best[backend], cpu_s)
    lines = [
        f"{'backend':12s} {'windows':>8s} {'loop CPU s':>11s} {'us/window':>10s} "
        f"{'x real time':>12s}  (best of {repeat}, job records on)"
    ]
    for backend in backends:
        b, w = best[backend], windows[backend]
        lines.append(f"{backend:12s} {w:8d} {b:11.2f} {1e6 * b / w:10.0f} {duration / b:12.0f}")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
