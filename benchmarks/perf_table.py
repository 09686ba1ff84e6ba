"""Regenerate the performance table of docs/performance.md from the benchmarks beside this
file (run by hand, on a machine as quiet as you can get).

    python benchmarks/perf_table.py [--repeat 3] [--skip-reproduce] [--write]

Runs ``bench_cli.py`` (the CLI's loop with its outputs, one simulated hour of Test 2),
``bench_scenario.py``'s loop alone (the same hour without output files, per world backend),
``bench_sweep_point.py`` (one lap of Test 2 as a warm sweep point), ``bench_sim.py`` (the
scheduler against a bare heap loop) and times ``rtsim reproduce --out DIR``; prints the
table, and with ``--write`` puts it between the markers of docs/performance.md and of
README.md (the text around them is kept).
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _machine import print_machine

HERE = Path(__file__).resolve().parent
DOC = HERE.parent / "docs" / "performance.md"
README = HERE.parent / "README.md"
START, END = "<!-- perf-table:start -->", "<!-- perf-table:end -->"
#: the first `rtsim reproduce` after an install, compile included (measured by hand in a
#: fresh clone: the README's first command)
FIRST_RUN = "22.3 s in a fresh clone on 2026-11-26"


def _bench(script: str, *args: str) -> dict[str, Any]:
    out = subprocess.run(
        [sys.executable, str(HERE / script), *args], check=True, capture_output=True, text=True
    ).stdout
    print(out, end="")
    return json.loads(out.strip().splitlines()[-1])


def reproduce_s() -> float:
    """Wall time of ``rtsim reproduce --out DIR`` (one run, fresh interpreter)."""
    out = Path(tempfile.mkdtemp(prefix="perf_reproduce_"))
    try:
        t = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "rtsim", "reproduce", "--out", str(out / "r")],
            check=True,
            capture_output=True,
        )
        return time.perf_counter() - t
    finally:
        shutil.rmtree(out, ignore_errors=True)


def loop_alone(repeat: int) -> dict[str, Any]:
    """Best-of-``repeat`` CPU of one simulated hour of Test 2's loop without output files,
    per world backend, each run in a fresh interpreter (``bench_scenario.loop_cpu``)."""
    sys.path.insert(0, str(HERE))
    from bench_scenario import TEST2, loop_cpu

    out: dict[str, Any] = {"duration": 3600.0}
    for backend in ("compiled", "python"):
        runs = [loop_cpu(str(TEST2), None, 3600.0, backend) for _ in range(repeat)]
        out[backend] = min(c for c, _ in runs)
        out["windows"] = runs[0][1]
    print(f"loop alone: {out}")
    return out


def table(
    cli: dict[str, Any],
    alone: dict[str, Any],
    point: dict[str, Any],
    sim: dict[str, Any],
    repro: float | None,
    m: dict[str, Any],
) -> str:
    """The Markdown table (and the line naming machine and date)."""
    yes = {True: "met", False: "**not met**"}
    rows = [
        "| measure | measured | target | |",
        "|---|---|---|---|",
        f"| one simulated hour of Test 2, the CLI's loop with windows.csv and jobs.csv "
        f"(`rtsim scenario test2 --duration 3600 --no-figures`, manifest "
        f"`timing.simulation_s`; `bench_cli.py`) | {cli['windows']:,} windows: "
        f"wall {cli['loop_s']:.2f} s = **{cli['x_real_time']:,.0f}×** real time; "
        f"CPU {cli['loop_cpu_s']:.2f} s = {cli['x_real_time_cpu']:,.0f}× "
        f"({1e6 * cli['loop_cpu_s'] / cli['windows']:.0f} µs/window) | ≥ 3,000× | "
        f"{yes[cli['x_real_time'] >= 3000]} |",
        f"| the same hour, the loop alone without output files (`run_scenario`, job records "
        f"kept in memory; `bench_scenario.py`), CPU | {alone['windows']:,} windows: compiled "
        f"world {alone['compiled']:.2f} s = **{alone['duration'] / alone['compiled']:,.0f}×** "
        f"({1e6 * alone['compiled'] / alone['windows']:.0f} µs/window); python world "
        f"{alone['python']:.2f} s = {alone['duration'] / alone['python']:,.0f}× | ≥ 1,000× "
        f"(the standing floor) | {yes[alone['duration'] / alone['compiled'] >= 1000]} |",
        f"| one lap of Test 2 as a warm sweep point (`run_scenario('test2', "
        f"record_jobs=False)`, CPU; `bench_sweep_point.py`) | {point['windows']} windows: "
        f"best **{point['best_ms']:.0f} ms**, median {point['median_ms']:.0f} ms | ≤ 20 ms | "
        f"{yes[point['best_ms'] <= 20]} |",
        f"| the scheduler against a bare heap loop (one simulated hour of (5, 40), (200, 250), "
        f"(25, 500); `bench_sim.py`) | {sim['rtsim_jobs_per_s']:,.0f} jobs/s against "
        f"{sim['bare_jobs_per_s']:,.0f}: **{sim['ratio']:.2f}×** slower; EDF "
        f"{sim['edf_over_fp']:.2f}× FP's time | ≤ 2× | {yes[sim['ratio'] <= 2]} |",
    ]
    if repro is not None:
        rows.append(
            f"| `rtsim reproduce --out DIR` (wall, one run, the kernels already in numba's "
            f"cache; the first run after an install compiles them too: {FIRST_RUN}) | "
            f"{repro:.1f} s | ≤ 15 s | "
            f"{yes[repro <= 15]} |"
        )
    head = (
        f"Measured {m['date']} on {m['cpu']} ({m['cores']} cores, load {m['load']}), "
        f"Python {m['python']}, numpy {m['numpy']}, pandas {m['pandas']}, numba "
        f"{m['numba']}; best of {cli['repeat']} (sweep point: of {point['repeat']})."
    )
    return head + "\n\n" + "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--skip-reproduce", action="store_true")
    ap.add_argument("--write", action="store_true", help="update docs/performance.md")
    args = ap.parse_args(argv)
    m = print_machine()
    cli = _bench("bench_cli.py", "--repeat", str(args.repeat), "--json")
    alone = loop_alone(args.repeat)
    point = _bench("bench_sweep_point.py", "--repeat", str(max(5, args.repeat)), "--json")
    sim = _bench("bench_sim.py", "--repeat", str(args.repeat), "--no-memory")
    repro = None if args.skip_reproduce else reproduce_s()
    text = table(cli, alone, point, sim, repro, m)
    print(text)
    if args.write:
        for path in (DOC, README):
            doc = path.read_text(encoding="utf-8")
            new, count = re.subn(
                re.escape(START) + ".*?" + re.escape(END),
                lambda _: f"{START}\n{text}\n{END}",
                doc,
                flags=re.S,
            )
            if count != 1:
                print(f"{path}: the markers {START} ... {END} were not found", file=sys.stderr)
                return 2
            path.write_text(new, encoding="utf-8")
            print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
