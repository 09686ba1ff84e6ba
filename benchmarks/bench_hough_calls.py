"""Benchmark: the Hough accumulator alone, on a warm lap's calls replayed.

    python benchmarks/bench_hough_calls.py capture FILE [--scenario test1] [--followers 9]
    python benchmarks/bench_hough_calls.py replay FILE [--rounds 10] [--chunk 25]

``capture`` runs one warm lap (``run_scenario(..., record_jobs=False)`` after a warm-up
lap) on the python world backend, and pickles every call of
`rtsim.world.hough.Accumulator.locate` and ``.search`` (the scan, the window centres and
radius, and the accumulator's r_F, cell, followers and r_max): the compiled backend votes
inside its fused scan (`rtsim.world.scanstep`; `bench_world.py` times that) and makes none
of these calls.
``replay`` builds a compiled `Accumulator` of this checkout for them and calls it: once to
hash the `WINDOW_ROW` records, then ``--rounds`` times over chunks of ``--chunk`` calls,
and prints the sum of each chunk's minimum (CPU) and the time per window: compare two
checkouts by replaying the same file with each, alternated; equal hashes mean bit-for-bit
equal records (docs/performance.md, "Where the time goes").
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
    """Pickle the accumulator's calls of one warm lap to ``path``; returns how many."""
    import numpy as np

    from rtsim.coupling import run_scenario
    from rtsim.world.hough import Accumulator

    # (the python backend: the compiled one's fused scan makes no accumulator calls)
    ov = {"formation.followers": followers, "world.backend": "python"}
    run_scenario(scenario, record_jobs=False, overrides=ov)  # warm-up: imports, compile
    got: list[tuple[Any, ...]] = []
    real = Accumulator.locate, Accumulator.search

    def shape(acc: Any) -> tuple[Any, ...]:
        cells = getattr(acc, "word", None)  # (before hough36: acc and stamp)
        size = (acc.acc if cells is None else cells).size
        r_max = (int(np.sqrt(size)) - 1) // 2 * acc.cell
        return acc.r_F, acc.cell, acc.out.shape[0], r_max

    def locate(acc: Any, *args: Any) -> Any:
        got.append(("locate", shape(acc), copy.deepcopy(args)))
        return real[0](acc, *args)

    def search(acc: Any, *args: Any) -> Any:
        got.append(("search", shape(acc), copy.deepcopy(args)))
        return real[1](acc, *args)

    Accumulator.locate, Accumulator.search = locate, search  # type: ignore[method-assign]
    try:
        run_scenario(scenario, record_jobs=False, overrides=ov)
    finally:
        Accumulator.locate, Accumulator.search = real  # type: ignore[method-assign]
    if not got:
        raise SystemExit(f"bench_hough_calls: no accumulator call in a lap of {scenario}")
    with open(path, "wb") as f:
        pickle.dump(got, f)
    return len(got)


def replay(path: str, rounds: int, chunk: int) -> dict[str, Any]:
    """The captured calls of ``path`` through this checkout's accumulator: hash, windows, ms."""
    from rtsim.world.hough import Accumulator

    with open(path, "rb") as f:
        calls = pickle.load(f)
    accs: dict[tuple[Any, ...], Any] = {}
    work = []
    for kind, key, args in calls:
        if key not in accs:
            r_F, cell, n, r_max = key
            accs[key] = Accumulator(n, r_F, r_max, True, cell)
        acc = accs[key]
        work.append((getattr(acc, kind), args))
    h = hashlib.sha256()
    windows = 0
    for fn, args in work:
        out = fn(*args)
        windows += 1 if out.shape == () else out.shape[0]
        h.update(out.tobytes())
    chunks = [work[i : i + chunk] for i in range(0, len(work), chunk)]
    best = [float("inf")] * len(chunks)
    for _ in range(rounds):
        for i, part in enumerate(chunks):
            t = time.process_time()
            for fn, args in part:
                fn(*args)
            best[i] = min(best[i], time.process_time() - t)
    ms = 1e3 * sum(best)
    return {"calls": len(calls), "windows": windows, "ms": ms, "hash": h.hexdigest()[:16]}


#: the command line's options past the mode and the file: name → default
OPTIONS: dict[str, Any] = {"scenario": "test1", "followers": 9, "rounds": 10, "chunk": 25}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mode", choices=("capture", "replay"))
    ap.add_argument("file")
    for name, default in OPTIONS.items():
        ap.add_argument(f"--{name}", type=type(default), default=default)
    a = ap.parse_args(argv)
    print_machine()
    if a.mode == "capture":
        print(f"{capture(a.file, a.scenario, a.followers)} calls captured to {a.file}")
        return 0
    r = replay(a.file, a.rounds, a.chunk)
    us = 1e3 * r["ms"] / r["windows"]
    print(f"{r['calls']} calls, {r['windows']:,} windows: {r['ms']:.2f} ms (sum of chunk")
    print(f"minima, {us:.2f} us a window), records {r['hash']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
