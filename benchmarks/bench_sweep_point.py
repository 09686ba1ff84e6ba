"""Benchmark: one sweep point of Test 2 (one lap), warm, in one process.

    python benchmarks/bench_sweep_point.py [--scenario test2] [--followers N] [--repeat 5]
        [--json]

What a scenario sweep's worker pays per point once it is running: ``run_scenario(SCENARIO,
record_jobs=False)`` (one lap: the default duration), in CPU time of the process, after one
warm-up lap that pays the imports and any compilation. Prints the best and the median of
``--repeat`` laps with nothing inside them timed, then the rollouts per lap
(`rtsim.control.rollout.rollouts_run`), their kernels' CPU and the floor beside them
(`floor_ms`) from ``--repeat`` laps more whose kernel calls are timed (the timers' clock
reads cost 2–3 ms a lap, so those laps do not give the point's CPU). Target: ≤ 60 ms CPU
per point (issue 36).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from typing import Any

from _machine import print_machine

TARGET_MS = 60.0

#: µs per window of everything but the rollouts, compiled as one step: issue 36's
#: prototypes at n = 2 and n = 10 followers (the floor without the rollouts; linear in n
#: between them, `rest_us`)
REST_US = {2: 2.7, 10: 11.6}


def rest_us(n: int) -> float:
    """The prototypes' µs per window without the rollouts at ``n`` followers (`REST_US`,
    linear in n)."""
    (n0, a), (n1, b) = sorted(REST_US.items())
    return a + (b - a) * (n - n0) / (n1 - n0)


def time_rollouts() -> list[float]:
    """Sum the CPU time of the compiled rollout's kernel calls (the plan decision's and a
    single rollout's) into the returned one-element list, from now on in this process."""
    from rtsim.control.compiled_rollout import _ENTRIES, call
    from rtsim.control.kernels import rollout_kernels

    ns = rollout_kernels()
    spent = [0.0]
    for name in ("roll_or_decide",):  # (the decision and a whole rollout: one entry)
        fn = getattr(ns, name)

        def timed(*a: Any, _fn: Any = fn) -> Any:
            t = time.process_time()
            try:
                return call(_fn, *a)  # (its compiled function, as the run calls it)
            finally:
                spent[0] += time.process_time() - t

        setattr(ns, name, timed)
        _ENTRIES[timed] = timed  # (called directly, as the run calls the kernel's entry)
    return spent


def laps(scenario: str, repeat: int, followers: int | None = None) -> dict[str, Any]:
    """``repeat`` warm laps of ``run_scenario(scenario, record_jobs=False)`` (``followers``:
    ``formation.followers``) after one warm-up lap: CPU per lap (best, median), windows,
    simulated seconds; then ``repeat`` laps more with the rollouts' kernel calls timed
    (`time_rollouts`: two clock reads a call, ≈ 600 calls a Test 2 lap, which would add
    2–3 ms to the laps they time): the rollouts per lap, their own CPU (best lap's), the floor
    = that + `rest_us` per window, and those laps' best CPU (``timed_best_ms``), ms."""
    from rtsim.control.rollout import rollouts_run
    from rtsim.coupling import run_scenario

    ov = {} if followers is None else {"formation.followers": followers}
    res = run_scenario(scenario, record_jobs=False, overrides=ov)  # warm-up: imports, caches
    plain = []
    for _ in range(repeat):
        t = time.process_time()
        res = run_scenario(scenario, record_jobs=False, overrides=ov)
        plain.append(time.process_time() - t)
    spent = time_rollouts()
    runs = []
    for _ in range(repeat):
        r0, s0 = rollouts_run(), spent[0]
        t = time.process_time()
        res = run_scenario(scenario, record_jobs=False, overrides=ov)
        runs.append((spent[0] - s0, rollouts_run() - r0, time.process_time() - t))
    best = min(runs)
    w, n = int(res.summary["windows"]), len(res.summary["per_follower"])
    return {
        "scenario": scenario,
        "followers": n,
        "windows": w,
        "duration_s": float(res.summary["duration_s"]),
        "repeat": repeat,
        "best_ms": 1e3 * min(plain),
        "median_ms": 1e3 * statistics.median(plain),
        "rollouts": best[1],
        "rollouts_ms": 1e3 * best[0],
        "floor_ms": 1e3 * best[0] + 1e-3 * rest_us(n) * w,
        "timed_best_ms": 1e3 * min(r[2] for r in runs),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="test2")
    ap.add_argument("--followers", type=int, default=None, help="formation.followers")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--json", action="store_true", help="print one JSON line at the end")
    args = ap.parse_args(argv)
    m = print_machine()
    out = laps(args.scenario, args.repeat, args.followers)
    w = out["windows"]
    print(
        f"run_scenario({args.scenario!r}, record_jobs=False), {out['followers']} followers: "
        f"one lap, {w} windows, {out['duration_s']:.1f} s simulated"
    )
    print(
        f"CPU per point: best {out['best_ms']:.1f} ms, median {out['median_ms']:.1f} ms of "
        f"{args.repeat} ({1e3 * out['best_ms'] / w:.0f} us/window; target <= {TARGET_MS:g} ms)"
    )
    print(
        f"rollouts per lap {out['rollouts']:,} ({out['rollouts_ms']:.1f} ms CPU in their "
        f"kernels, in {args.repeat} laps more with those calls timed: best "
        f"{out['timed_best_ms']:.1f} ms); floor {out['floor_ms']:.1f} ms"
    )
    if args.json:
        print(json.dumps({"machine": m, **out}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
