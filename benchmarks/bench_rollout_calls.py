"""Benchmark: the rollout kernels alone, on a warm lap's calls replayed.

    python benchmarks/bench_rollout_calls.py capture FILE [--scenario test1] [--followers 9]
    python benchmarks/bench_rollout_calls.py replay FILE [--rounds 10] [--chunk 25]

``capture`` runs one warm lap (``run_scenario(..., record_jobs=False)`` after a warm-up
lap) and pickles every call of the compiled rollout's entry (the decisions and the whole
rollouts of the ``_pred`` columns: the compiled functions in
`rtsim.control.compiled_rollout._ENTRIES`, which `call` and `CompiledRollout.decide` both
use), its arguments as they were at the call. ``replay`` calls the entry of this checkout
on copies of them: once to hash the outputs and count the rollouts (the kernels' return
values, as `CompiledRollout` counts them), then ``--rounds`` times over chunks of
``--chunk`` calls, and prints the sum of each chunk's minimum (CPU): compare two checkouts
by replaying the same file with each, alternated; equal hashes mean bit-for-bit equal
outputs. (docs/performance.md, "The rollout kernels, measured inside".)
"""

from __future__ import annotations

import argparse
import copy
import hashlib
import pickle
import time
from typing import Any

from _machine import print_machine


def capture(path: str, scenario: str, followers: int) -> int:
    """Pickle the entry's calls of one warm lap to ``path``; returns how many."""
    import rtsim.control.compiled_rollout as cr
    from rtsim.coupling import run_scenario

    ov = {"formation.followers": followers}
    run_scenario(scenario, record_jobs=False, overrides=ov)  # warm-up: imports, compile
    # (the entries' compiled functions, which `call` and `CompiledRollout.decide` both
    # look up in `_ENTRIES` once the warm-up has filled it, wrapped by a recorder)
    real = dict(cr._ENTRIES)
    got: list[tuple[Any, ...]] = []

    def recorder(f: Any) -> Any:
        def record(*args: Any) -> Any:
            got.append(copy.deepcopy(args))
            return f(*args)

        return record

    cr._ENTRIES.update({fn: recorder(f) for fn, f in real.items()})
    try:
        run_scenario(scenario, record_jobs=False, overrides=ov)
    finally:
        cr._ENTRIES.update(real)
    with open(path, "wb") as f:
        pickle.dump(got, f)
    return len(got)


def replay(path: str, rounds: int, chunk: int) -> dict[str, Any]:
    """The captured calls of ``path`` through this checkout's entry: hash, rollouts, ms."""
    from rtsim.control.compiled_rollout import call
    from rtsim.control.kernels import rollout_kernels

    fn = rollout_kernels().roll_or_decide
    with open(path, "rb") as f:
        calls = pickle.load(f)
    h = hashlib.sha256()
    rollouts = 0
    for a in calls:
        b = copy.deepcopy(a)
        r = call(fn, *b)
        rollouts += 1 if b[0] else r + int(b[13][6])  # (a whole rollout; a decision's)
        h.update(repr(r).encode())
        for x in b[13:15]:  # the float and integer buffers (out first: `_roll_or_decide`)
            h.update(x.tobytes())
    work = [copy.deepcopy(a) for a in calls]
    chunks = [work[i : i + chunk] for i in range(0, len(work), chunk)]
    best = [float("inf")] * len(chunks)
    for _ in range(rounds):
        for i, part in enumerate(chunks):
            t = time.process_time()
            for a in part:
                call(fn, *a)
            best[i] = min(best[i], time.process_time() - t)
    ms = 1e3 * sum(best)
    return {"calls": len(calls), "rollouts": rollouts, "ms": ms, "hash": h.hexdigest()[:16]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mode", choices=("capture", "replay"))
    ap.add_argument("file")
    ap.add_argument("--scenario", default="test1")
    ap.add_argument("--followers", type=int, default=9)
    ap.add_argument("--rounds", type=int, default=10)
    ap.add_argument("--chunk", type=int, default=25)
    args = ap.parse_args(argv)
    print_machine()
    if args.mode == "capture":
        n = capture(args.file, args.scenario, args.followers)
        print(f"{n} calls of the rollout entry captured to {args.file}")
        return 0
    out = replay(args.file, args.rounds, args.chunk)
    print(
        f"{out['calls']} calls, {out['rollouts']:,} rollouts: {out['ms']:.2f} ms "
        f"(sum of chunk minima, {1e3 * out['ms'] / out['rollouts']:.2f} us a rollout), "
        f"outputs {out['hash']}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
