"""Speed and memory of the virtual CPU (run by hand; not a test).

    python benchmarks/bench_sim.py [--hours 1] [--no-memory] [--callgrind [--callgrind-dir D]]

1. One simulated hour of the 3-task set (5, 40), (200, 250), (25, 500) (rate-monotonic) with
   per-task statistics on and per-job records off: jobs per second of ``rtsim.sim.simulate``.
2. In the same run, a bare event loop with a heap and no SimPy simulating the same set (the
   speed of light for Python), and the ratio (target: rtsim within 2x of it).
   The same set under EDF (``scheduler="edf"``; U = 0.975, schedulable) beside FP: EDF has no
   inline top-task path and a float key, target within 1.5x of FP's time.
3. Peak memory (ru_maxrss of a fresh subprocess) for 1 simulated second and 24 simulated hours
   with per-job records off: it must not grow with the horizon.
4. With ``--callgrind``: instructions executed (valgrind's callgrind, Ir) by the bare loop and
   by rtsim fp on the same hours, and their ratio, which does not depend on the machine's
   load. Each side runs in a fresh interpreter under callgrind twice, with and without the
   measured run after the same imports and warm-up: its Ir is the difference.
"""

from __future__ import annotations

import argparse
import heapq
import json
import math
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _machine import print_machine

TASKS = ((5.0, 40.0), (200.0, 250.0), (25.0, 500.0))  # (wcet, period), priority = order


def bare_loop(horizon: float) -> tuple[int, float]:
    """Fixed-priority preemptive scheduling with a release heap; returns (jobs, max response)."""
    releases = [(0.0, i) for i in range(len(TASKS))]
    heapq.heapify(releases)
    ready: list[tuple[int, float, float]] = []  # (priority, release, remaining)
    now = 0.0
    done = 0
    worst = 0.0
    k = [0] * len(TASKS)
    while releases or ready:
        nxt_rel = releases[0][0] if releases else math.inf
        if ready:
            prio, rel, rem = ready[0]
            if now + rem <= nxt_rel:  # the running job completes first
                heapq.heappop(ready)
                now += rem
                done += 1
                worst = max(worst, now - rel)
                continue
            heapq.heapreplace(ready, (prio, rel, rem - (nxt_rel - now)))
        now = nxt_rel
        while releases and releases[0][0] <= now:
            t, i = heapq.heappop(releases)
            heapq.heappush(ready, (i, t, TASKS[i][0]))
            k[i] += 1
            nt = k[i] * TASKS[i][1]
            if nt < horizon:
                heapq.heappush(releases, (nt, i))
    return done, worst


def rtsim_run(horizon: float, scheduler: str = "fp") -> int:
    from rtsim.model.task import Task
    from rtsim.sim import simulate

    tasks = [Task(f"t{i}", e, p, priority=i + 1) for i, (e, p) in enumerate(TASKS)]
    res = simulate(tasks, horizon, scheduler=scheduler)
    assert res.misses == 0
    return sum(s.completed for s in res.tasks.values())


def peak_rss_mb(horizon: float) -> float:
    """ru_maxrss (MB) of a fresh interpreter that simulates ``horizon`` ms."""
    code = (
        f"import resource, sys; sys.path.insert(0, {sys.path[0]!r}); "
        f"import bench_sim; bench_sim.rtsim_run({horizon!r}); "
        "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return int(out.stdout.strip()) / 1024.0


def _ir_child(side: str, horizon: float, measure: bool) -> None:
    """What runs under callgrind: imports and warm-up, then (if ``measure``) one side."""
    rtsim_run(1000.0)
    bare_loop(1000.0)
    if measure:
        if side == "bare":
            bare_loop(horizon)
        else:
            rtsim_run(horizon, side)


def _callgrind_ir(valgrind: str, side: str, hours: float, out: Path, measure: bool) -> int:
    """Total Ir of one `_ir_child` run under callgrind (its output file kept in ``out``)."""
    name = out / f"callgrind.{side}.{'run' if measure else 'setup'}.out"
    cmd = [
        valgrind,
        "--tool=callgrind",
        f"--callgrind-out-file={name}",
        sys.executable,
        __file__,
        "--ir-child",
        side,
        "--hours",
        repr(hours),
    ]
    if not measure:
        cmd.append("--ir-setup")
    # a fixed hash seed, and no BLAS threads spinning beside the loop (their Ir would count)
    env = dict(os.environ, PYTHONHASHSEED="0", OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    subprocess.run(cmd, check=True, capture_output=True, env=env)
    for line in name.read_text(encoding="utf-8", errors="replace").splitlines():
        if line.startswith(("totals:", "summary:")):
            return int(line.split()[1])
    raise RuntimeError(f"{name}: no totals line")


def callgrind(hours: float, keep: str | None) -> dict[str, Any]:
    """Ir of the bare loop and of rtsim fp on ``hours`` simulated hours, and their ratio."""
    valgrind = shutil.which("valgrind")
    if valgrind is None:
        print("bench_sim: --callgrind needs valgrind on the PATH", file=sys.stderr)
        raise SystemExit(2)
    out = Path(keep) if keep else Path(tempfile.mkdtemp(prefix="bench_sim_cg_"))
    out.mkdir(parents=True, exist_ok=True)
    try:
        ir = {
            side: _callgrind_ir(valgrind, side, hours, out, True)
            - _callgrind_ir(valgrind, side, hours, out, False)
            for side in ("bare", "fp")
        }
    finally:
        if not keep:
            shutil.rmtree(out, ignore_errors=True)
    ratio = ir["fp"] / ir["bare"]
    print(f"{'instructions (callgrind Ir)':32s} {'bare':>14s} {'rtsim fp':>14s}")
    print(f"{'':32s} {ir['bare']:14,d} {ir['fp']:14,d}")
    print(f"rtsim executes {ratio:.2f}x the instructions of the bare loop (target: within 2x)")
    if keep:
        print(f"callgrind files in {out} (callgrind_annotate FILE)")
    return {"bare_ir": ir["bare"], "rtsim_ir": ir["fp"], "ir_ratio": ratio}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=1.0)
    ap.add_argument("--repeat", type=int, default=3, help="best of this many runs")
    ap.add_argument("--no-memory", action="store_true")
    ap.add_argument(
        "--callgrind", action="store_true", help="also count instructions under valgrind"
    )
    ap.add_argument("--callgrind-dir", help="keep callgrind's output files in this folder")
    ap.add_argument("--ir-child", choices=("bare", "fp", "edf"), help=argparse.SUPPRESS)
    ap.add_argument("--ir-setup", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    horizon = args.hours * 3_600_000.0
    if args.ir_child:
        _ir_child(args.ir_child, horizon, not args.ir_setup)
        return 0
    machine = print_machine()
    rtsim_run(1000.0)  # imports and warm-up outside the timing

    # best of --repeat runs each, interleaved, in CPU time (the machine may be shared)
    t_bare = t_sim = t_edf = math.inf
    n_bare = n_sim = n_edf = 0
    for _ in range(args.repeat):
        t = time.process_time()
        n_bare, _ = bare_loop(horizon)
        t_bare = min(t_bare, time.process_time() - t)
        t = time.process_time()
        n_sim = rtsim_run(horizon)
        t_sim = min(t_sim, time.process_time() - t)
        t = time.process_time()
        n_edf = rtsim_run(horizon, "edf")
        t_edf = min(t_edf, time.process_time() - t)
    assert n_bare == n_sim == n_edf, (n_bare, n_sim, n_edf)

    rows = [
        ("bare heap loop", n_bare, t_bare),
        ("rtsim fp (SimPy CPU, stats on)", n_sim, t_sim),
        ("rtsim edf (SimPy CPU, stats on)", n_edf, t_edf),
    ]
    print(
        f"{args.hours:g} simulated hour(s) of (5,40),(200,250),(25,500); "
        f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB RSS so far"
    )
    print(f"{'simulator':32s} {'jobs':>9s} {'CPU s':>8s} {'jobs/s':>10s}  (best of {args.repeat})")
    for name, n, secs in rows:
        print(f"{name:32s} {n:9d} {secs:8.2f} {n / secs:10.0f}")
    ratio = (n_bare / t_bare) / (n_sim / t_sim)
    print(f"rtsim is {ratio:.2f}x slower than the bare loop (target: within 2x)")
    edf_ratio = t_edf / t_sim
    print(f"edf takes {edf_ratio:.2f}x the time of fp (target: within 1.5x)")
    result: dict[str, Any] = {
        "bare_jobs_per_s": n_bare / t_bare,
        "rtsim_jobs_per_s": n_sim / t_sim,
        "ratio": ratio,
        "edf_jobs_per_s": n_edf / t_edf,
        "edf_over_fp": edf_ratio,
        "repeat": args.repeat,
        "machine": machine,
    }
    if args.callgrind:
        result.update(callgrind(args.hours, args.callgrind_dir))
    if not args.no_memory:
        one_s = peak_rss_mb(1000.0)
        day = peak_rss_mb(24 * 3_600_000.0)
        print(f"{'peak RSS, 1 simulated second':32s} {one_s:9.1f} MB")
        print(
            f"{'peak RSS, 24 simulated hours':32s} {day:9.1f} MB  "
            f"(+{day - one_s:.1f} MB; target < 100 MB)"
        )
        result.update(peak_mb_1s=one_s, peak_mb_24h=day)
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
