"""When the command task is long (e_cmd = 120 ms): which window do the analyses ask for, and
which window does the simulator need?

``python experiments/command_window.py [--n 2,6,10] [--e-cmd 120] [--out DIR]``

For the paper's set (r_H = 25 cm) with the command task's WCET raised to ``--e-cmd`` and each
n: w_sch, w_rta, the suspension-aware w_susp, the offset-based w_txn
(:func:`rtsim.analysis.transaction.w_txn`), and w_sim: the least window at which none of
``RUNS`` adversarial simulations misses a deadline (Δt leaving the CPU idle, fixed priority,
every job at its WCET; the dead-reckoning task's first release at 0, 2, …, 38 ms against the
window's, over ``WINDOWS`` windows each; bisected to 0.01 ms with a scan above:
:func:`rtsim.analysis.validation.smallest_passing`). Also the command task's simulated worst
response at w_txn beside its transaction bound there.

Writes ``command_window.csv`` and ``command_window.md`` to ``--out`` (default
``out/command_window``), with a manifest.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import pandas as pd

from rtsim.analysis.bounds import w_txn, window_bounds
from rtsim.analysis.transaction import transaction_bounds
from rtsim.analysis.validation import smallest_passing
from rtsim.config.taskset import load_taskset
from rtsim.io.atomic import write_table, write_text
from rtsim.io.manifest import write_manifest
from rtsim.model.taskset import TaskSet
from rtsim.sim import simulate

TASKSET = Path(__file__).resolve().parent.parent / "tasksets" / "barrel_robots.toml"
WINDOWS = 40  # simulated windows per run
OFFSETS = tuple(float(x) for x in range(0, 40, 2))  # dead reckoning's first release (ms)
RUNS = len(OFFSETS)


def taskset(n: int, e_cmd: float) -> TaskSet:
    """The paper's set with n followers, r_H = 25 cm and the command task's WCET e_cmd."""
    ts = load_taskset(TASKSET).with_window(n=n, r_H=25.0)
    return replace(
        ts, tasks=tuple(replace(t, wcet=e_cmd) if t.name == "command" else t for t in ts.tasks)
    )


def runs(ts: TaskSet, w: float) -> list[object]:
    """The adversarial runs at window w (module doc)."""
    out = []
    for off in OFFSETS:
        moved = replace(
            ts, tasks=tuple(replace(t, offset=off) if not t.per_window else t for t in ts.tasks)
        )
        out.append(simulate(moved, WINDOWS * w, window=w, suspension="idle"))
    return out


def row(n: int, e_cmd: float) -> dict[str, float]:
    ts = taskset(n, e_cmd)
    b = window_bounds(ts)
    wt = w_txn(ts)

    def passes(w: float) -> bool:
        return all(r.misses == 0 for r in runs(ts, w))  # type: ignore[attr-defined]

    sim = smallest_passing(passes, 0.5 * ts.window.g(), b.w_sch, scan=10).w  # type: ignore[union-attr]
    at = runs(ts, wt)
    worst = max(r.tasks["command"].max_response for r in at)  # type: ignore[attr-defined]
    bound = transaction_bounds(ts, wt)["command"]
    return {
        "n": n,
        "e_cmd": e_cmd,
        "w_sch": b.w_sch,
        "w_rta": b.w_rta,
        "w_susp": b.w_susp,
        "w_txn": wt,
        "w_sim": sim,
        "w_susp/w_sim": b.w_susp / sim,
        "w_txn/w_sim": wt / sim,
        "command_bound_at_w_txn": bound if bound is not None else float("nan"),
        "command_simulated_at_w_txn": worst,
    }


def markdown(df: pd.DataFrame) -> str:
    lines = [
        "| n | w_sch | w_rta | w_susp | w_txn | w_sim (simulated) | w_susp / w_sim | "
        "w_txn / w_sim | command at w_txn: bound / simulated |",
        "|" + "---|" * 9,
    ]
    for r in df.to_dict("records"):
        lines.append(
            f"| {r['n']} | {r['w_sch']:.2f} | {r['w_rta']:.2f} | {r['w_susp']:.2f} | "
            f"{r['w_txn']:.2f} | {r['w_sim']:.2f} | {r['w_susp/w_sim']:.3f} | "
            f"{r['w_txn/w_sim']:.3f} | {r['command_bound_at_w_txn']:.2f} / "
            f"{r['command_simulated_at_w_txn']:.2f} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", default="2,6,10", help="followers, comma-separated")
    ap.add_argument("--e-cmd", type=float, default=120.0, help="command WCET (ms)")
    ap.add_argument("--out", type=Path, default=Path("out/command_window"))
    args = ap.parse_args(argv)
    ns = [int(x) for x in args.n.split(",")]
    df = pd.DataFrame([row(n, args.e_cmd) for n in ns])
    args.out.mkdir(parents=True, exist_ok=True)
    write_table(args.out / "command_window.csv", df)
    write_text(args.out / "command_window.md", markdown(df))
    write_manifest(
        args.out,
        command="experiments/command_window.py",
        seed=None,
        inputs={
            "n": ns,
            "e_cmd": args.e_cmd,
            "taskset": str(TASKSET),
            "windows": WINDOWS,
            "offsets": list(OFFSETS),
        },
    )
    print(markdown(df))
    return 0


if __name__ == "__main__":
    sys.exit(main())
