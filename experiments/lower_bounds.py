"""Which window lower bound should the robots use?

``python experiments/lower_bounds.py [--quick] [--out DIR]``

Runs the paper's Test 1 and Test 2 (``adjust`` mode) with ``[adjust] lower_bound`` = w_sch
(the paper's), w_rta (exact RTA) and w_susp (suspension-aware: Δt with the CPU idle, which is
how the coupling's CPU runs), all with the leader's CPU under fixed priority, and w_edf (the
EDF demand criterion, Δt counted as CPU time) with the CPU under EDF (``[scheduler] policy =
"edf"``), and reports, per run: the scheduler, the bound (ms), the critical share (time
with min MSB below the bound), the minimum and the time-weighted mean V_L/V_Ld, the lap time
(s per lap), deadline misses, scans that broke Eq 1's point count, the mean slack w − bound
(ms), and the world's bound violations. ``--quick``: 20 simulated seconds per run (the tests);
default: the scenario's duration (at least a lap). Writes ``lower_bounds.csv`` and
``lower_bounds.md`` with a ``manifest.json`` to ``--out`` (default ``out/lower_bounds`` or
``out/lower_bounds-quick``).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rtsim.analysis.bounds import BOUND_SCHEDULER, LOWER_BOUNDS
from rtsim.config.scenario import load_scenario
from rtsim.coupling import run_scenario
from rtsim.io.atomic import write_table, write_text
from rtsim.io.manifest import write_manifest

SCENARIOS = Path(__file__).resolve().parent / "scenarios"
TESTS = {"Test 1": SCENARIOS / "test1.toml", "Test 2": SCENARIOS / "test2.toml"}


def run_one(label: str, path: Path, bound: str, duration_s: float | None) -> dict[str, Any]:
    """One scenario with one lower bound: the row of the table."""
    sc = load_scenario(path)
    sc = replace(
        sc,
        adjust=sc.adjust.model_copy(update={"lower_bound": bound}),
        scheduler=BOUND_SCHEDULER[bound],
    )
    res = run_scenario(sc, duration_s=duration_s, record_jobs=False)
    df, s = res.windows, res.summary
    w = df["w"].to_numpy(dtype=float)
    speed = df["v_leader"].to_numpy(dtype=float) / df["v_leader_desired"].to_numpy(dtype=float)
    laps = float(s["laps"])
    return {
        "test": label,
        "lower_bound": bound,
        "scheduler": BOUND_SCHEDULER[bound],
        "bound_ms": float(s["w_sch"]),
        "windows": int(s["windows"]),
        "critical_share": float(s["critical_share"]),
        "min_speed_ratio": float(s["min_speed_ratio"]),
        "mean_speed_ratio": float(np.sum(w * speed) / np.sum(w)),
        "lap_time_s": float(s["duration_s"]) / laps if laps > 0 else float("nan"),
        "laps": laps,
        "missed": int(s["missed"]),
        "assumption_broken": int(s["assumption_broken"]),
        "mean_slack_ms": float(df["slack"].mean()),
        "violations": int(sum(s["violations"].values())),
    }


def table(rows: list[dict[str, Any]]) -> pd.DataFrame:
    """Every test × bound."""
    return pd.DataFrame(rows)


def markdown(df: pd.DataFrame) -> str:
    """The table as Markdown (3 decimals)."""
    cols = list(df.columns)
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for row in df.itertuples(index=False):
        lines.append(
            "| " + " | ".join(f"{v:.3f}" if isinstance(v, float) else str(v) for v in row) + " |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="20 simulated seconds per run")
    p.add_argument("--out", metavar="DIR", help="output directory")
    args = p.parse_args(argv)
    out = Path(args.out or ("out/lower_bounds-quick" if args.quick else "out/lower_bounds"))
    duration = 20.0 if args.quick else None
    rows = [
        run_one(label, path, bound, duration)
        for label, path in TESTS.items()
        for bound in LOWER_BOUNDS
    ]
    df = table(rows)
    out.mkdir(parents=True, exist_ok=True)
    write_table(out / "lower_bounds.csv", df)
    write_text(out / "lower_bounds.md", markdown(df))
    write_manifest(
        out,
        command="experiments/lower_bounds.py",
        seed=0,
        inputs={
            "quick": args.quick,
            "duration_s": duration,
            "scenarios": {k: str(v) for k, v in TESTS.items()},
        },
        argv=[sys.argv[0], *(argv if argv is not None else sys.argv[1:])],
        extra={"outputs": ["lower_bounds.csv", "lower_bounds.md"]},
    )
    print(markdown(df), end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
