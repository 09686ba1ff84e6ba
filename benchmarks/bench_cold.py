"""Benchmark: the first run after an install (an empty kernel cache), as a user runs it.

    python benchmarks/bench_cold.py [--repeat 3] [--kernels] [--json]

Runs ``rtsim scenario test2 --duration 10 --no-figures --out DIR --force`` in a fresh
interpreter with a fresh, empty ``NUMBA_CACHE_DIR`` (every kernel compiles: the first run
after an install), then the same command again on that cache (the kernels load), and
``rtsim --version`` (the CLI's start-up); CPU time of the whole process (user + system, of
the child: robust on a shared machine), best of ``--repeat``. ``--kernels`` adds one cold
run in this process that reports each kernel's compile CPU (numba's ``numba:compile``
events, nested compiles subtracted). Target: the cold run ≤ 15 s CPU (issue 36).
"""

from __future__ import annotations

import argparse
import json
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

TARGET = 15.0
COMMAND = ["scenario", "test2", "--duration", "10", "--no-figures", "--force"]


def _child_cpu(args: list[str], env: dict[str, str]) -> float:
    """CPU seconds (user + system) of ``python -m rtsim ARGS`` in a fresh interpreter."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([sys.executable, "-m", "rtsim", *args], check=True, env=env, capture_output=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def one_round() -> dict[str, float]:
    """One cold run (fresh cache), one warm run (that cache) and one ``--version``."""
    tmp = Path(tempfile.mkdtemp(prefix="bench_cold_"))
    try:
        env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp / "cache"), "RTSIM_PROGRESS": "0"}
        args = [*COMMAND, "--out", str(tmp / "out")]
        cold = _child_cpu(args, env)
        warm = _child_cpu(args, env)
        version = _child_cpu(["--version"], env)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return {"cold_cpu_s": cold, "warm_cpu_s": warm, "version_cpu_s": version}


def kernel_times() -> dict[str, float]:
    """Each kernel's compile CPU (s, nested compiles subtracted) in one cold run: a child
    process with a fresh NUMBA_CACHE_DIR (numba reads it when it is imported)."""
    tmp = Path(tempfile.mkdtemp(prefix="bench_cold_k_"))
    try:
        env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp / "cache"), "RTSIM_PROGRESS": "0"}
        out = subprocess.run(
            [sys.executable, __file__, "--kernels-child"],
            check=True,
            env=env,
            capture_output=True,
            text=True,
        ).stdout
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return json.loads(out.strip().splitlines()[-1])  # type: ignore[no-any-return]


def _kernels_child() -> None:
    """`kernel_times`' child: one Test 2 run of 10 s, the compiles timed; a JSON line."""
    from numba.core import event

    from rtsim.coupling.scenario_run import run_scenario

    stack: list[list[Any]] = []
    own: dict[str, float] = {}

    class Listener(event.Listener):  # type: ignore[misc]
        def on_start(self, ev: Any) -> None:
            stack.append([ev.data["dispatcher"].py_func.__qualname__, time.process_time(), 0.0])

        def on_end(self, ev: Any) -> None:
            name, t0, nested = stack.pop()
            d = time.process_time() - t0
            own[name] = own.get(name, 0.0) + d - nested
            if stack:
                stack[-1][2] += d

    event.register("numba:compile", Listener())
    run_scenario("test2", duration_s=10.0, record_jobs=False)
    print(json.dumps(dict(sorted(own.items(), key=lambda kv: -kv[1]))))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--kernels", action="store_true", help="per-kernel compile CPU too")
    ap.add_argument("--json", action="store_true", help="a JSON line last")
    ap.add_argument("--kernels-child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.kernels_child:
        _kernels_child()
        return 0
    print_machine()
    runs = [one_round() for _ in range(args.repeat)]
    best = {k: min(r[k] for r in runs) for k in runs[0]}
    for r in runs:
        print(
            f"cold {r['cold_cpu_s']:6.2f} s   warm {r['warm_cpu_s']:5.2f} s   "
            f"--version {1000 * r['version_cpu_s']:4.0f} ms   (CPU)"
        )
    verdict = "met" if best["cold_cpu_s"] <= TARGET else "NOT met"
    print(
        f"best: first run {best['cold_cpu_s']:.2f} s CPU (target <= {TARGET:.0f} s: {verdict}), "
        f"cached {best['warm_cpu_s']:.2f} s, start-up {1000 * best['version_cpu_s']:.0f} ms"
    )
    out: dict[str, Any] = {**best, "target_s": TARGET, "runs": runs}
    if args.kernels:
        own = kernel_times()
        for name, s in own.items():
            if s >= 0.05:
                print(f"  {s:6.2f} s  {name}")
        print(f"  {sum(own.values()):6.2f} s  compiling, all kernels ({len(own)})")
        out["kernels_s"] = {k: round(v, 3) for k, v in own.items()}
    if args.json:
        print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
