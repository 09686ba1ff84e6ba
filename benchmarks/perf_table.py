"""Regenerate the performance tables of docs/performance.md from the benchmarks beside this
file (run by hand, on a machine as quiet as you can get).

    python benchmarks/perf_table.py [--repeat 3] [--skip-reproduce] [--skip-cold] [--skip-python]
        [--skip-callgrind] [--cli-duration 600] [--write]

Runs ``bench_cli.py`` (the CLI's loop with its outputs, one simulated hour of Test 2),
``bench_scenario.py``'s loop alone (the same hour without output files, per world backend),
``bench_sweep_point.py`` (one lap of Test 2 as a warm sweep point), ``bench_sim.py`` (the
scheduler against a bare heap loop, in CPU time and, unless ``--skip-callgrind``, in
instructions under valgrind's callgrind: about two minutes more), ``bench_followers.py``
(Test 1 and Test 2 per follower count, n = 2, 6, 10 or the largest the layout accepts: a lap
in-process and the CLI with its outputs), ``bench_cold.py`` (the first run after an install,
unless ``--skip-cold``) and times ``rtsim reproduce --out DIR``; every
figure of the rollout planner has its rollouts and its floor beside it (the rollouts' own
CPU plus the rest compiled, `bench_sweep_point.rest_us`). Prints the tables (Markdown), and
with ``--write`` puts them between the markers of docs/performance.md and (the headline
table only) of README.md (the text around them is kept).
Targets: issue 36's, in CPU time.
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


def loop_alone(repeat: int, backends: tuple[str, ...]) -> dict[str, Any]:
    """Best-of-``repeat`` CPU of one simulated hour of Test 2's loop without output files,
    per world backend, each run in a fresh interpreter (``bench_scenario.loop_cpu``), and
    the hour's rollouts."""
    sys.path.insert(0, str(HERE))
    from bench_scenario import TEST2, loop_cpu

    out: dict[str, Any] = {"duration": 3600.0}
    for backend in backends:
        runs = [loop_cpu(str(TEST2), None, 3600.0, backend) for _ in range(repeat)]
        out[backend] = min(c for c, _, _ in runs)
        if backend == backends[0]:  # (the python world's policy rolls out more: in Python)
            out["windows"], out["rollouts"] = runs[0][1], runs[0][2]
    print(f"loop alone: {out}")
    return out


def _floor(windows: int, rollouts: int, per_rollout_s: float, n: int) -> float:
    """The floor of a run (s): its rollouts at ``per_rollout_s`` each (measured on a lap) and
    the rest compiled (`bench_sweep_point.rest_us` per window)."""
    from bench_sweep_point import rest_us

    return rollouts * per_rollout_s + 1e-6 * rest_us(n) * windows


def table(
    cli: dict[str, Any],
    alone: dict[str, Any],
    point: dict[str, Any],
    sim: dict[str, Any],
    fol: dict[str, Any],
    repro: float | None,
    m: dict[str, Any],
    cold: dict[str, Any] | None = None,
) -> str:
    """The Markdown tables (and the line naming machine and date)."""
    yes = {True: "met", False: "**not met**"}
    hour = alone["duration"]
    per_rollout = 1e-3 * point["rollouts_ms"] / point["rollouts"]
    floor_h = _floor(alone["windows"], alone["rollouts"], per_rollout, 2)
    beside = f"{alone['rollouts']:,} rollouts; floor ≈ {floor_h:.2f} s = {hour / floor_h:,.0f}×"
    cli_x = cli["duration_s"] / cli["loop_cpu_s"]
    t1 = max((r for r in fol["rows"] if r["scenario"] == "test1"), key=lambda r: r["followers"])
    rows = [
        "| measure | measured (CPU) | rollouts; floor | target | |",
        "|---|---|---|---|---|",
        f"| one simulated hour of Test 2, the CLI's loop with windows.csv and jobs.csv "
        f"(`rtsim scenario test2 --duration 3600 --no-figures`, manifest "
        f"`timing.simulation_cpu_s`; `bench_cli.py`) | {cli['windows']:,} windows: "
        f"{cli['loop_cpu_s']:.2f} s = **{cli_x:,.0f}×** real time "
        f"({1e6 * cli['loop_cpu_s'] / cli['windows']:.0f} µs/window; wall "
        f"{cli['loop_s']:.2f} s) | {beside} | ≥ 1,500× | {yes[cli_x >= 1500]} |",
    ]
    x = {b: hour / alone[b] for b in ("compiled", "python") if b in alone}
    rows.append(
        f"| the same hour, the loop alone without output files (`run_scenario`, job records "
        f"kept in memory; `bench_scenario.py`) | compiled world {alone['compiled']:.2f} s = "
        f"**{x['compiled']:,.0f}×** ({1e6 * alone['compiled'] / alone['windows']:.0f} "
        f"µs/window)"
        + (f"; python world {alone['python']:.2f} s = {x['python']:,.0f}×" if "python" in x else "")
        + f" | {beside} | ≥ 2,000× | {yes[x['compiled'] >= 2000]} |"
    )
    rows += [
        f"| one lap of Test 2 as a warm sweep point (`run_scenario('test2', "
        f"record_jobs=False)`, set-up included; `bench_sweep_point.py`) | {point['windows']} "
        f"windows: best **{point['best_ms']:.0f} ms**, median {point['median_ms']:.0f} ms | "
        f"{point['rollouts']:,} rollouts ({point['rollouts_ms']:.0f} ms); floor "
        f"{point['floor_ms']:.0f} ms | ≤ 60 ms | {yes[point['best_ms'] <= 60]} |",
        f"| one lap of Test 1 with {t1['followers']} followers (the most its layout accepts; "
        f"`bench_followers.py`) | {t1['windows']} windows: **{t1['best_ms'] / 1e3:.2f} s** | "
        f"{t1['rollouts']:,} rollouts ({t1['rollouts_ms']:.0f} ms); floor "
        f"{t1['floor_ms'] / 1e3:.2f} s | ≤ 0.35 s | {yes[t1['best_ms'] <= 350]} |",
        f"| the scheduler against a bare heap loop (one simulated hour of (5, 40), (200, 250), "
        f"(25, 500); `bench_sim.py`) | {sim['rtsim_jobs_per_s']:,.0f} jobs/s against "
        f"{sim['bare_jobs_per_s']:,.0f}: **{sim['ratio']:.2f}×** slower"
        + (
            f"; instructions (callgrind Ir) {sim['rtsim_ir'] / 1e6:,.0f} M against "
            f"{sim['bare_ir'] / 1e6:,.0f} M: **{sim['ir_ratio']:.2f}×**"
            if "ir_ratio" in sim
            else ""
        )
        + f"; EDF {sim['edf_over_fp']:.2f}× FP's time | – | ≤ 2× | "
        f"{yes[sim['ratio'] <= 2 and sim.get('ir_ratio', 0) <= 2]} |",
    ]
    if cold is not None:
        rows.append(
            f"| the first run after an install: `rtsim scenario test2 --duration 10 "
            f"--no-figures` with an empty `NUMBA_CACHE_DIR`, the whole process, every kernel "
            f"compiled (`bench_cold.py`) | **{cold['cold_cpu_s']:.1f} s** (the same with the "
            f"kernels cached {cold['warm_cpu_s']:.1f} s; `rtsim --version` "
            f"{1000 * cold['version_cpu_s']:.0f} ms) | – | ≤ 15 s | "
            f"{yes[cold['cold_cpu_s'] <= 15]} |"
        )
    if repro is not None:
        rows.append(
            f"| `rtsim reproduce --out DIR` (wall, one run, the kernels already in numba's "
            f"cache; the first run after an install compiles them too: {FIRST_RUN}) | "
            f"{repro:.1f} s | – | ≤ 15 s | {yes[repro <= 15]} |"
        )
    head = (
        f"Measured {m['date']} on {m['cpu']} ({m['cores']} cores, load {m['load']}), "
        f"Python {m['python']}, numpy {m['numpy']}, pandas {m['pandas']}, numba "
        f"{m['numba']}; CPU time, best of {cli['repeat']} (sweep point: of "
        f"{point['repeat']}). Floor: the rollouts' own CPU (their compiled kernels, measured "
        f"in the run; for the hour at a lap's µs per rollout) plus the rest of a window "
        f"compiled as one step (prototypes: 2.7 µs/window at n = 2, 11.6 at "
        f"n = 10)."
    )
    return head + "\n\n" + "\n".join(rows)


def followers_table(fol: dict[str, Any]) -> str:
    """Per scenario and follower count: a lap in-process, and the CLI with its outputs."""
    d = fol["rows"][0]["cli_duration_s"]
    rows = [
        f"Per follower count (`bench_followers.py`; best of {fol['repeat']}): a lap as a warm "
        f"sweep point, and `rtsim scenario S --set formation.followers=N --duration {d:g} "
        f"--no-figures` (windows.csv and jobs.csv), its loop's CPU.",
        "",
        "| scenario | n | lap: windows | lap CPU | rollouts per lap (their CPU) | floor per lap "
        f"| CLI, {d:g} s with outputs |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in fol["rows"]:
        w = r["windows"]
        rows.append(
            f"| {r['scenario']} | {r['followers']} | {w} ({r['duration_s']:.0f} s) | "
            f"**{r['best_ms']:.0f} ms** ({1e3 * r['best_ms'] / w:.0f} µs/window) | "
            f"{r['rollouts']:,} ({r['rollouts_ms']:.0f} ms, "
            f"{1e3 * r['rollouts_ms'] / max(r['rollouts'], 1):.1f} µs each) | "
            f"{r['floor_ms']:.0f} ms | {r['cli_cpu_s']:.2f} s = "
            f"{r['cli_duration_s'] / r['cli_cpu_s']:,.0f}× real time |"
        )
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--skip-reproduce", action="store_true")
    ap.add_argument("--skip-cold", action="store_true", help="no first-run (bench_cold) row")
    ap.add_argument(
        "--skip-python", action="store_true", help="no loop-alone hour on the python world"
    )
    ap.add_argument(
        "--skip-callgrind", action="store_true", help="bench_sim without instruction counts"
    )
    ap.add_argument("--cli-duration", type=float, default=600.0, help="per follower count, s")
    ap.add_argument("--write", action="store_true", help="update docs/performance.md")
    args = ap.parse_args(argv)
    m = print_machine()
    rep = str(args.repeat)
    cli = _bench("bench_cli.py", "--repeat", rep, "--json")
    alone = loop_alone(args.repeat, ("compiled",) if args.skip_python else ("compiled", "python"))
    point = _bench("bench_sweep_point.py", "--repeat", str(max(5, args.repeat)), "--json")
    sim = _bench(
        "bench_sim.py",
        "--repeat",
        rep,
        "--no-memory",
        *(() if args.skip_callgrind else ("--callgrind",)),
    )
    fol = _bench(
        "bench_followers.py", "--repeat", rep, "--cli-duration", str(args.cli_duration), "--json"
    )
    repro = None if args.skip_reproduce else reproduce_s()
    cold = None if args.skip_cold else _bench("bench_cold.py", "--repeat", rep, "--json")
    text = table(cli, alone, point, sim, fol, repro, m, cold)
    full = text + "\n\n" + followers_table(fol)
    print(full)
    # the README keeps the headline table (it stays under 200 lines); the docs have both
    brief = text
    if args.write:
        for path, block in ((DOC, full), (README, brief)):
            doc = path.read_text(encoding="utf-8")
            new, count = re.subn(
                re.escape(START) + ".*?" + re.escape(END),
                lambda _, b=block: f"{START}\n{b}\n{END}",
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
