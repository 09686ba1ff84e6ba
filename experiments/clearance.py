"""Many followers with the clearance: each count runs safely or is refused before the run.

Runs the shipped Test 2 (policy plan) with n = 6..10 followers and Test 1 with n = 6..10,
one lap each, seeds 13, 17, 21, 29, 37 (seeds no other document uses), and writes per
(test, n) over the seeds: whether the count runs (or the loader's one-line refusal),
collisions, the closest two robots' centres came (cm), scans below the clearance, the
contact bound's breaks (window-follower pairs whose true closest approach fell below
2·r_F + clearance, summary.json ``violations["contact"]``), misses, lost tracks, windows
beyond 5 %, and lap / oracle (smallest and largest).

Outputs in DIR: ``clearance.csv`` (a row per run), ``clearance_summary.csv``,
``clearance.md``, ``manifest.json``.

    python experiments/clearance.py [--quick] [--out DIR]

``--quick``: Test 2, n = 6 and 9, seed 13 (the test suite).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import pandas as pd

from rtsim.analysis.kinematics import BOUND_KINDS
from rtsim.coupling import run_scenario
from rtsim.errors import ScenarioError
from rtsim.io.atomic import write_table, write_text
from rtsim.io.manifest import write_manifest

TESTS = ("test2", "test1")
NS = (6, 7, 8, 9, 10)
SEEDS = (13, 17, 21, 29, 37)


def run_one(test: str, n: int, seed: int) -> dict[str, Any]:
    """One run (a row of clearance.csv); a refused count is a row with ``refused`` set."""
    row: dict[str, Any] = {"test": test, "n": n, "seed": seed, "refused": ""}
    try:
        s = run_scenario(
            test,
            seed=seed,
            record_jobs=False,
            windows=False,
            overrides={"formation.followers": n},
        ).summary
    except ScenarioError as exc:
        row["refused"] = str(exc).split(": ", 1)[-1]
        return row
    row.update(
        {
            "collisions": s["collisions"],
            "min_robot_distance_cm": s["min_robot_distance_cm"],
            "clearance_cm": s["clearance_cm"],
            "clearance_violations": s["clearance_violations"],
            "contact_breaks": s["violations"]["contact"],
            "missed": s["missed"],
            "tracks_lost": s["tracks_lost"],
            "viol5": sum(s["violations_beyond_5pct"][k] for k in BOUND_KINDS),
            "lap_over_oracle": math.nan
            if s["lap_over_oracle"] is None
            else float(s["lap_over_oracle"]),
        }
    )
    return row


def summarize(runs: pd.DataFrame) -> pd.DataFrame:
    """Per (test, n) over the seeds. Pure."""
    rows = []
    for (test, n), part in runs.groupby(["test", "n"], sort=False):
        refused = part["refused"].astype(str)
        ran = part[refused == ""]
        rows.append(
            {
                "test": test,
                "n": n,
                "seeds": len(part),
                "runs": len(ran),
                "refused": refused[refused != ""].iloc[0] if len(ran) < len(part) else "",
                "collisions": int(ran["collisions"].sum()) if len(ran) else 0,
                "closest_min_cm": float(ran["min_robot_distance_cm"].min())
                if len(ran)
                else math.nan,
                "closest_max_cm": float(ran["min_robot_distance_cm"].max())
                if len(ran)
                else math.nan,
                "clearance_violations": int(ran["clearance_violations"].sum()) if len(ran) else 0,
                "contact_breaks": int(ran["contact_breaks"].sum()) if len(ran) else 0,
                "missed": int(ran["missed"].sum()) if len(ran) else 0,
                "tracks_lost": int(ran["tracks_lost"].sum()) if len(ran) else 0,
                "viol5": int(ran["viol5"].sum()) if len(ran) else 0,
                "oracle_min": float(ran["lap_over_oracle"].min()) if len(ran) else math.nan,
                "oracle_max": float(ran["lap_over_oracle"].max()) if len(ran) else math.nan,
            }
        )
    return pd.DataFrame(rows)


def markdown(df: pd.DataFrame) -> str:
    """The summary as a Markdown table."""
    lines = [
        "| test | n | runs / seeds | collisions | closest centres (cm) | scans below the "
        "clearance | contact breaks | misses | lost | windows > 5 % | lap / oracle |",
        "|" + "---|" * 11,
    ]
    for r in df.to_dict("records"):
        if r["runs"] == 0:
            lines.append(
                f"| {r['test']} | {r['n']} | 0 / {r['seeds']} | refused before the run: "
                f"{r['refused']} | | | | | | | |"
            )
            continue
        lines.append(
            f"| {r['test']} | {r['n']} | {r['runs']} / {r['seeds']} | {r['collisions']} | "
            f"{r['closest_min_cm']:.1f}–{r['closest_max_cm']:.1f} | "
            f"{r['clearance_violations']} | {r['contact_breaks']} | {r['missed']} | "
            f"{r['tracks_lost']} | "
            f"{r['viol5']} | {r['oracle_min']:.3f}–{r['oracle_max']:.3f} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="Test 2, n = 6 and 9, seed 13")
    p.add_argument("--out", metavar="DIR", help="output directory")
    args = p.parse_args(argv)
    out = Path(args.out or ("out/clearance-quick" if args.quick else "out/clearance"))
    tests, ns, seeds = (("test2",), (6, 9), (13,)) if args.quick else (TESTS, NS, SEEDS)
    runs = pd.DataFrame([run_one(t, n, s) for t in tests for n in ns for s in seeds])
    summary = summarize(runs)
    out.mkdir(parents=True, exist_ok=True)
    write_table(out / "clearance.csv", runs)
    write_table(out / "clearance_summary.csv", summary)
    write_text(out / "clearance.md", markdown(summary))
    write_manifest(
        out,
        command="experiments/clearance.py",
        seed=seeds[0],
        inputs={"quick": args.quick, "tests": list(tests), "n": list(ns), "seeds": list(seeds)},
        argv=[sys.argv[0], *(argv if argv is not None else sys.argv[1:])],
        extra={"outputs": ["clearance.csv", "clearance_summary.csv", "clearance.md"]},
    )
    print(markdown(summary), end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
