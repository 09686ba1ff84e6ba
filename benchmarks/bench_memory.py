"""Peak memory of long runs against short ones (run by hand, not a test).

    python benchmarks/bench_memory.py [--sim-hours 24] [--scenario-hours 6] [--short-min 10]
                                      [--trace-hours 3] [--only simulate|scenario|traces]
                                      [--followers N] [--no-figures] [--json]
    python benchmarks/bench_memory.py --matrix [--scenario-hours 1 6] [--short-min 10]

Each run is a fresh interpreter (``rtsim.cli.main`` in a child process) whose peak resident
set size (``ru_maxrss``) is reported:

1. ``rtsim simulate tasksets/example.toml --jobs FILE.csv`` for ``--short-min`` minutes and
   for ``--sim-hours`` hours of simulated time (every job record written to the file);
2. ``rtsim scenario experiments/scenarios/test2.toml --parquet --out DIR`` — every output:
   windows.csv, windows.parquet, jobs.csv, the five figures, report.html — for
   ``--short-min`` minutes and each of ``--scenario-hours`` hours (``--followers N``: with
   ``--set formation.followers=N``; the summary's and the figures' read-backs grew with N;
   ``--no-figures``: the run without its figures, what the run itself costs);
3. the traces, for ``--short-min`` minutes and ``--trace-hours`` hours: ``rtsim simulate
   tasksets/example.toml --trace FILE.csv``, the same with ``--perfetto FILE.json``, and
   ``rtsim scenario experiments/scenarios/test2.toml --no-figures --perfetto FILE.json``.

Target: the long run's peak within 100 MB of the short run's (records are kept as column
chunks and flushed to the output as they come; summaries and figures read columns back;
the Perfetto trace is written from records spooled to disk; the figures draw a table of
bounded length, read back in chunks, and each figure is freed before the next).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TARGET_MB = 100.0

_CHILD = """
import resource, sys, time
from rtsim.cli import main
t0 = time.perf_counter()
rc = main(sys.argv[1:])
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
print("BENCH", rc, peak, time.perf_counter() - t0)
"""


def peak_mb(argv: list[str]) -> tuple[float, float]:
    """(peak RSS in MB, wall seconds) of ``rtsim <argv>`` in a fresh interpreter."""
    proc = subprocess.run(
        [sys.executable, "-c", _CHILD, *argv], cwd=ROOT, text=True, capture_output=True, check=False
    )
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("BENCH ")]
    if proc.returncode != 0 or not lines:
        raise SystemExit(f"rtsim {' '.join(argv)} failed:\n{proc.stderr[-2000:]}")
    _, rc, peak, wall = lines[-1].split()
    if rc != "0":
        raise SystemExit(f"rtsim {' '.join(argv)} exited {rc}:\n{proc.stderr[-2000:]}")
    return float(peak), float(wall)


#: The ``--matrix`` runs: label -> (scenario file, ``--set`` overrides).
MATRIX: dict[str, tuple[str, list[str]]] = {
    "n=2 (test2)": ("experiments/scenarios/test2.toml", []),
    "n=10 (test1, clearance 5)": (
        "experiments/scenarios/test1.toml",
        ["formation.followers=10", "formation.clearance=5"],
    ),
}


def scenario_run(
    out: Path, scenario: str, sets: list[str], seconds: float, *extra: str
) -> dict[str, float]:
    """Peak MB, wall s, windows and the loop's CPU s (the manifest's) of one
    ``rtsim scenario`` run with every output into ``out``."""
    argv = ["scenario", scenario, "--duration", repr(seconds), "--out", str(out), *extra]
    for kv in sets:
        argv += ["--set", kv]
    peak, wall = peak_mb(argv)
    rows = sum(1 for _ in open(out / "windows.csv", "rb")) - 1
    timing = json.loads((out / "manifest.json").read_text(encoding="utf-8"))["timing"]
    return {"mb": peak, "s": wall, "rows": rows, "loop_cpu_s": timing["simulation_cpu_s"]}


def matrix(hours: list[float], short_min: float, as_json: bool, keep: str | None) -> int:
    """The ``--matrix`` table (module docstring): peak MB per follower count and length;
    ``keep``: a directory that keeps the runs' outputs (to compare them byte for byte)."""
    lengths = {f"{short_min:g} min": short_min * 60.0}
    lengths.update({f"{h:g} h": h * 3600.0 for h in hours})
    results: dict[str, dict[str, dict[str, float]]] = {}
    with tempfile.TemporaryDirectory(prefix="bench_memory_") as tmp:
        d = Path(keep or tmp)
        for who, (scenario, sets) in MATRIX.items():
            scenario_run(d / "warm", scenario, sets, 10.0, "--no-figures")  # numba's cache
            row = results[who] = {}
            for label, s in lengths.items():
                run_dir = d / f"n{len(results)}_{label.replace(' ', '')}"
                row[label] = scenario_run(run_dir, scenario, sets, s)
                r = row[label]
                print(
                    f"{who:28s} {label:>7s}: peak {r['mb']:7.1f} MB, loop {r['loop_cpu_s']:7.2f}"
                    f" s CPU = {1e6 * r['loop_cpu_s'] / max(r['rows'], 1):6.1f} us/window "
                    f"({r['rows']:.0f} windows, {r['s']:.0f} s wall)",
                    flush=True,
                )
    print(f"\n{'every output, peak MB':28s} " + " ".join(f"{k:>9s}" for k in lengths) + "  growth")
    ok = True
    for who, row in results.items():
        peaks = [row[k]["mb"] for k in lengths]
        growth = max(peaks) - peaks[0]
        ok &= growth <= TARGET_MB
        print(f"{who:28s} " + " ".join(f"{p:9.1f}" for p in peaks) + f"  {growth:+.1f}")
    if as_json:
        print(
            json.dumps(
                {"when": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "matrix": results}
            )
        )
    return 0 if ok else 1


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sim-hours", type=float, default=24.0)
    ap.add_argument(
        "--scenario-hours",
        type=float,
        nargs="+",
        default=[6.0],
        help="scenario: one or more long runs, each against the short one",
    )
    ap.add_argument(
        "--no-figures",
        action="store_true",
        help="scenario: without the figures (what the run itself costs)",
    )
    ap.add_argument("--short-min", type=float, default=10.0)
    ap.add_argument("--trace-hours", type=float, default=3.0)
    ap.add_argument("--only", choices=("simulate", "scenario", "traces"), default=None)
    ap.add_argument("--followers", type=int, default=None, help="scenario: followers")
    ap.add_argument("--json", action="store_true", help="also print one JSON line")
    ap.add_argument(
        "--matrix",
        action="store_true",
        help="every output at 2 and 10 followers, short and --scenario-hours, with loop CPU",
    )
    ap.add_argument("--keep", default=None, help="--matrix: keep the outputs in this directory")
    args = ap.parse_args()
    if args.matrix:
        return matrix(args.scenario_hours, args.short_min, args.json, args.keep)
    results: dict[str, dict[str, float]] = {}
    with tempfile.TemporaryDirectory(prefix="bench_memory_") as tmp:
        d = Path(tmp)
        if args.only in (None, "simulate"):
            row = {}
            for label, ms in (
                ("short", args.short_min * 60_000),
                ("long", args.sim_hours * 3_600_000),
            ):
                peak, wall = peak_mb(
                    [
                        "simulate",
                        "tasksets/example.toml",
                        "--horizon",
                        repr(ms),
                        "--jobs",
                        str(d / f"jobs_{label}.csv"),
                    ]
                )
                rows = sum(1 for _ in open(d / f"jobs_{label}.csv", "rb")) - 1
                row.update({f"{label}_mb": peak, f"{label}_s": wall, f"{label}_rows": rows})
            results[f"simulate --jobs {args.sim_hours:g} h vs {args.short_min:g} min"] = row
        if args.only in (None, "scenario"):
            runs = {"short": args.short_min * 60}
            runs.update({f"{h:g} h": h * 3600 for h in args.scenario_hours})
            measured = {}
            for label, s in runs.items():
                out = d / f"scen_{label.replace(' ', '')}"
                peak, wall = peak_mb(
                    [
                        "scenario",
                        "experiments/scenarios/test2.toml",
                        "--duration",
                        repr(s),
                        "--parquet",
                        "--out",
                        str(out),
                        *(["--no-figures"] if args.no_figures else []),
                        *(
                            ["--set", f"formation.followers={args.followers}"]
                            if args.followers
                            else []
                        ),
                    ]
                )
                rows = sum(1 for _ in open(out / "windows.csv", "rb")) - 1
                measured[label] = (peak, wall, rows)
            who = f", {args.followers} followers" if args.followers else ""
            what = "no figures" if args.no_figures else "every output"
            short = measured.pop("short")
            for label, (peak, wall, rows) in measured.items():
                results[f"scenario test2{who}, {what}, {label} vs {args.short_min:g} min"] = {
                    "short_mb": short[0],
                    "short_s": short[1],
                    "short_rows": short[2],
                    "long_mb": peak,
                    "long_s": wall,
                    "long_rows": rows,
                }
        if args.only in (None, "traces"):
            runs = {
                "simulate --trace": (
                    [
                        "simulate",
                        "tasksets/example.toml",
                        "--horizon",
                        "{ms}",
                        "--trace",
                        "{o}.csv",
                    ],
                    "{o}.csv",
                ),
                "simulate --perfetto": (
                    [
                        "simulate",
                        "tasksets/example.toml",
                        "--horizon",
                        "{ms}",
                        "--perfetto",
                        "{o}.json",
                    ],
                    "{o}.json",
                ),
                "scenario test2 --perfetto": (
                    [
                        "scenario",
                        "experiments/scenarios/test2.toml",
                        "--no-figures",
                        "--duration",
                        "{s}",
                        "--out",
                        "{o}",
                        "--perfetto",
                        "{o}.json",
                    ],
                    "{o}.json",
                ),
            }
            for what, (argv, sized) in runs.items():
                row = {}
                for label, s in (("short", args.short_min * 60), ("long", args.trace_hours * 3600)):
                    o = str(d / f"{what.split()[-1][2:]}_{what.split()[0]}_{label}")
                    peak, wall = peak_mb(
                        [a.format(ms=repr(s * 1000.0), s=repr(s), o=o) for a in argv]
                    )
                    size = Path(sized.format(o=o)).stat().st_size / 1e6
                    row.update({f"{label}_mb": peak, f"{label}_s": wall, f"{label}_rows": size})
                results[f"{what}, {args.trace_hours:g} h vs {args.short_min:g} min (file MB)"] = row
    print(f"{'run':58s} {'short MB':>9s} {'long MB':>9s} {'delta':>8s}  rows or MB (long) verdict")
    ok = True
    for name, r in results.items():
        delta = r["long_mb"] - r["short_mb"]
        good = delta <= TARGET_MB
        ok &= good
        print(
            f"{name:58s} {r['short_mb']:9.1f} {r['long_mb']:9.1f} {delta:+8.1f}  "
            f"{r['long_rows']:>11.0f}   {'ok' if good else 'MISSED'} "
            f"(target +{TARGET_MB:g} MB; long run {r['long_s']:.0f} s)"
        )
        r["delta_mb"] = delta
    if args.json:
        print(
            json.dumps(
                {"when": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "results": results}
            )
        )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
