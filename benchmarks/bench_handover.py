"""The CLI's output work inside its loop, by stage: what windows.csv and jobs.csv cost a window.

    python benchmarks/bench_handover.py [--duration 1800] [--chunk 2] [--repeat 9]

Runs Test 2 as ``rtsim scenario`` does (windows.csv and jobs.csv written in chunks during
the loop, `rtsim.io.columns.ChunkWriter`), timing each hand-over inside the loop with the
process CPU clock: the window records' columns (`records_columns`), their changes
(`changes_array`), their CSV text (`write_columns`) and each chunk of job rows
(`write_rows`), in µs per window handed over (job rows: per window of the hour, ≈ 7.6 rows).
Then the ``--chunk``-th windows chunk and the first jobs chunk, kept, are timed again after
the loop (best and median of ``--repeat``, the cyclic collector off as in the loop): the
same calls on the same objects, outside the loop's surroundings. Not a test.
"""

from __future__ import annotations

import argparse
import gc
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from _machine import print_machine


def _timed(f: Callable[[], Any], repeat: int, per: float) -> str:
    ts = []
    for _ in range(repeat):
        c = time.process_time()
        f()
        ts.append(time.process_time() - c)
    ts.sort()
    return f"best {ts[0] * 1e6 / per:6.2f}  median {ts[len(ts) // 2] * 1e6 / per:6.2f} µs"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=1800.0)
    ap.add_argument("--chunk", type=int, default=2, help="the windows chunk timed again (1-based)")
    ap.add_argument("--repeat", type=int, default=9)
    args = ap.parse_args()
    print_machine()
    import rtsim.coupling.recorder as rc
    import rtsim.coupling.scenario_run as sr
    from rtsim.io.columns import ChunkWriter
    from rtsim.sim.records import jobs_frame

    seen: dict[str, Any] = {"win": [], "jobs": []}
    hand_over, write_rows, columns = (
        sr._Coupling.hand_over,
        ChunkWriter.write_rows,
        sr.records_columns,
    )

    def timed_hand_over(self: Any, records: list[Any], sink: Any) -> None:
        if len(seen["win"]) + 1 == args.chunk:
            seen["recs"], seen["run"] = list(records), self
        c = time.process_time()
        hand_over(self, records, sink)
        seen["win"].append((len(records), time.process_time() - c, seen.pop("cols", 0.0)))

    def timed_columns(*a: Any, **k: Any) -> Any:
        c = time.process_time()
        out = columns(*a, **k)
        seen["cols"] = time.process_time() - c
        return out

    def timed_write_rows(self: Any, rows: Any) -> None:
        if not seen["jobs"]:
            seen["rows"] = list(rows)
        c = time.process_time()
        write_rows(self, rows)
        seen["jobs"].append((len(rows), time.process_time() - c))

    sr._Coupling.hand_over = timed_hand_over  # type: ignore[method-assign]
    sr.records_columns = timed_columns
    ChunkWriter.write_rows = timed_write_rows  # type: ignore[method-assign]
    out = Path(tempfile.mkdtemp(prefix="bench_handover_"))
    windows = ChunkWriter([out / "windows.csv"], None)
    jobs = ChunkWriter([out / "jobs.csv"], jobs_frame([]))
    res = sr.run_scenario(
        "test2", duration_s=args.duration, window_sink=windows, job_sink=jobs, scratch_dir=out
    )
    nw = res.summary["windows"]
    cpu = res.timing["simulation_cpu_s"]
    print(
        f"test2 {args.duration:g} s: {nw} windows, loop {cpu:.3f} s CPU",
        f"({args.duration / cpu:,.0f}x)",
    )
    print("windows chunks in the loop (records: hand-over, of it the columns, µs a record):")
    for m, t, c in seen["win"]:
        print(f"  {m:5d}: {t * 1e6 / m:6.2f}  columns {c * 1e6 / m:6.2f}")
    rows_per_window = sum(m for m, _ in seen["jobs"]) / nw
    print(f"jobs chunks in the loop (µs a window, {rows_per_window:.1f} rows a window):")
    print("  " + ", ".join(f"{t * 1e6 / m * rows_per_window:.2f}" for m, t in seen["jobs"]))
    if "recs" not in seen:
        return
    gc.disable()
    recs, run = seen["recs"], seen["run"]
    m, n, limits = len(recs), run.n, run.rec.limits
    ch = rc.changes_array(recs, n)
    cols = rc.records_columns(recs, n, limits, changes=ch)
    w2 = ChunkWriter([out / "w2.csv"], windows.empty)
    w2.chunks = 1  # (no header)
    j2 = ChunkWriter([out / "j2.csv"], jobs_frame([]))
    j2.chunks = 1
    print(f"windows chunk {args.chunk} ({m} records) again after the loop, a record:")
    print(
        "  records_columns ",
        _timed(lambda: rc.records_columns(recs, n, limits, changes=ch), args.repeat, m),
    )
    print("  changes_array   ", _timed(lambda: rc.changes_array(recs, n), args.repeat, m))
    print("  CSV text        ", _timed(lambda: w2.write_columns(cols), args.repeat, m))
    rows = seen["rows"]
    print(f"jobs chunk 1 ({len(rows)} rows) again after the loop, a window:")
    print(
        "  CSV text        ",
        _timed(lambda: j2.write_rows(rows), args.repeat, len(rows) / rows_per_window),
    )


if __name__ == "__main__":
    main()
