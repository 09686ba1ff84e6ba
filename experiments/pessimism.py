"""How pessimistic is each window lower bound? The paper's set for n = 1..10 followers.

``python experiments/pessimism.py [--n 1-10] [--out DIR]``

For the paper's task set (``tasksets/barrel_robots.toml``, r_H = 25 cm) and each n: the
paper's w_sch, the exact w_rta (Δt counted as CPU time), the suspension-aware w_susp (Δt with
the CPU idle), the EDF demand criterion's w_edf, the offset-based w_txn (the window chain and
the command task as one transaction, each task its least sound bound:
:func:`rtsim.analysis.transaction.w_txn`), and w_sim: the least window at which the
simulator, with every job at its WCET, Δt leaving the CPU idle, fixed priority and all tasks
released together at 0, shows no deadline miss over 60 windows (bisected to 1e-3 ms with a
scan of the range above it for non-monotonicity:
:func:`rtsim.analysis.validation.smallest_passing`).
w_sim is one schedule, not a bound: other release phasings could need a larger window, so it
is a floor for what any sound analysis of that model may claim.

Writes ``pessimism.csv``, ``pessimism.md`` (the table of docs/analysis.md) and
``pessimism_compact.md`` (the README's, n across) to ``--out``
(default ``out/pessimism``), with a ``manifest.json``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

from rtsim.analysis.bounds import w_txn, window_bounds
from rtsim.analysis.validation import smallest_passing
from rtsim.config.taskset import load_taskset
from rtsim.io.atomic import write_table, write_text
from rtsim.io.manifest import write_manifest
from rtsim.sim import simulate

TASKSET = Path(__file__).resolve().parent.parent / "tasksets" / "barrel_robots.toml"
WINDOWS = 60  # simulated windows per run


def w_sim(ts, hi: float) -> float:  # type: ignore[no-untyped-def]
    """Least w with no miss in the synchronous WCET run, Δt idle (module doc)."""

    def passes(w: float) -> bool:
        return simulate(ts, WINDOWS * w, window=w, suspension="idle").misses == 0

    return smallest_passing(passes, 0.5 * ts.window.g(), hi, tol=1e-3, scan=10).w


def row(n: int) -> dict[str, float]:
    ts = load_taskset(TASKSET).with_window(n=n, r_H=25.0)
    b = window_bounds(ts)
    sim = w_sim(ts, b.w_sch)
    wt = w_txn(ts)
    return {
        "n": n,
        "w_sch": b.w_sch,
        "w_rta": b.w_rta,
        "w_susp": b.w_susp,
        "w_edf": b.w_edf,
        "w_txn": wt,
        "w_sim": sim,
        "w_sch/w_sim": b.w_sch / sim,
        "w_rta/w_sim": b.w_rta / sim,
        "w_susp/w_sim": b.w_susp / sim,
        "w_txn/w_sim": wt / sim,
    }


def markdown(df: pd.DataFrame) -> str:
    head = (
        "| n | w_sch | w_rta | w_susp | w_edf | w_txn | w_sim (simulated) | w_sch / w_sim | "
        "w_rta / w_sim | w_susp / w_sim | w_txn / w_sim |"
    )
    lines = [head, "|" + "---|" * 11]
    for r in df.to_dict("records"):
        lines.append(
            f"| {r['n']} | {r['w_sch']:.2f} | {r['w_rta']:.2f} | {r['w_susp']:.2f} | "
            f"{r['w_edf']:.2f} | {r['w_txn']:.2f} | {r['w_sim']:.2f} | "
            f"{r['w_sch/w_sim']:.3f} | {r['w_rta/w_sim']:.3f} | "
            f"{r['w_susp/w_sim']:.3f} | {r['w_txn/w_sim']:.3f} |"
        )
    return "\n".join(lines) + "\n"


def compact(df: pd.DataFrame) -> str:
    """The same bounds with n across (the README's short table)."""
    cols = ["w_sch", "w_rta", "w_susp", "w_edf", "w_txn", "w_sim"]
    lines = ["| ms | " + " | ".join(f"n={n}" for n in df["n"]) + " |", "|---|" + "---|" * len(df)]
    for c in cols:
        lines.append(f"| {c} | " + " | ".join(f"{v:.1f}" for v in df[c]) + " |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", default="1-10", help="followers: a range a-b (default 1-10)")
    ap.add_argument("--out", type=Path, default=Path("out/pessimism"))
    args = ap.parse_args(argv)
    a, _, b = args.n.partition("-")
    ns = range(int(a), int(b or a) + 1)
    df = pd.DataFrame([row(n) for n in ns])
    args.out.mkdir(parents=True, exist_ok=True)
    write_table(args.out / "pessimism.csv", df)
    write_text(args.out / "pessimism.md", markdown(df))
    write_text(args.out / "pessimism_compact.md", compact(df))
    write_manifest(
        args.out,
        command="experiments/pessimism.py",
        seed=None,
        inputs={"n": list(ns), "taskset": str(TASKSET), "windows": WINDOWS},
    )
    print(markdown(df))
    print(compact(df))
    return 0


if __name__ == "__main__":
    sys.exit(main())
