"""Which prediction model for Test 1 and Test 2?

Runs both tests in adjust mode (one lap, seed 0) with each built-in predictor
(:data:`rtsim.control.predict.PREDICTORS`) and prints one Markdown row per run: deadline
misses, lost tracks, violations beyond 5 % (all kinds), the largest violation ratio, the lap
time and the critical share. ``--out FILE`` also writes the table as CSV.

    python experiments/predictors.py [--tests test1 test2] [--seed 0] [--out predictors.csv]
"""

from __future__ import annotations

import argparse
import sys
import time

import pandas as pd

from rtsim.control.predict import PREDICTORS
from rtsim.coupling import run_scenario
from rtsim.io.atomic import write_table


def row(test: str, predictor: str, seed: int) -> dict[str, object]:
    """One adjust run of ``test`` with ``predictor``: the comparison's numbers."""
    t0 = time.perf_counter()
    res = run_scenario(
        test,
        policy="adjust",
        seed=seed,
        record_jobs=False,
        # adjust on this predictor, not the paper's (its default since issue 33)
        overrides={"adjust.predictor": predictor, "adjust.paper_predictor": False},
    )
    s = res.summary
    return {
        "test": test,
        "predictor": predictor,
        "missed": s["missed"],
        "tracks_lost": s["tracks_lost"],
        "viol5": sum(s["violations_beyond_5pct"].values()),
        **{f"viol5_{k}": v for k, v in s["violations_beyond_5pct"].items()},
        "max_viol_ratio": max(s["max_violation_ratio"].values()),
        **{f"max_viol_ratio_{k}": v for k, v in s["max_violation_ratio"].items()},
        "lap_s": s["duration_s"] / s["laps"],
        "critical_share": s["critical_share"],
        "min_speed_ratio": s["min_speed_ratio"],
        "infeasible": s["infeasible"],
        "binding_critical": ";".join(f"{k}={v}" for k, v in s["binding_critical"].items()),
        "wall_s": time.perf_counter() - t0,
    }


def markdown(df: pd.DataFrame) -> str:
    lines = [
        "| test | predictor | misses | lost tracks | violations > 5 % (loc/sep/path/bear) "
        "| max violation ratio (loc/sep/path/bear) | lap (s) | critical share | "
        "min V_L/V_Ld | infeasible | binding (critical) |",
        "|" + "---|" * 11,
    ]
    for r in df.itertuples(index=False):
        lines.append(
            f"| {r.test} | {r.predictor} | {r.missed} | {r.tracks_lost} | {r.viol5} "
            f"({r.viol5_localization}/{r.viol5_separation}/{r.viol5_path_diversion}/"
            f"{r.viol5_bearing}) | {r.max_viol_ratio:.2f} ({r.max_viol_ratio_localization:.2f}/"
            f"{r.max_viol_ratio_separation:.2f}/{r.max_viol_ratio_path_diversion:.2f}/"
            f"{r.max_viol_ratio_bearing:.2f}) | {r.lap_s:.1f} | {r.critical_share:.3f} | "
            f"{r.min_speed_ratio:.2f} | {r.infeasible} | {r.binding_critical} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--tests",
        nargs="+",
        default=["test1", "test2"],
        metavar="NAME",
        help="scenarios (packaged names or files)",
    )
    p.add_argument("--seed", type=int, default=0, metavar="N", help="the runs' seed")
    p.add_argument("--out", metavar="FILE", help="also write the table as CSV")
    args = p.parse_args(argv)
    df = pd.DataFrame([row(t, m, args.seed) for t in args.tests for m in PREDICTORS])
    if args.out:
        write_table(args.out, df)
    print(markdown(df))
    return 0


if __name__ == "__main__":
    sys.exit(main())
