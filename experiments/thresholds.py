"""How the headline verdicts hang on the thresholds the paper does not give.

T_ε, T_ρ and T_β (the bounds' thresholds, SPEC §4) and the followers' bearing offset on
straights are rtsim's assumptions. This sweeps each over a stated range, one at a time, the
others at the shipped files' values:

* T_ε ∈ {0.02, 0.025, 0.03, 0.035, 0.04} (shipped 0.025);
* T_ρ ∈ {0.0025, 0.005, 0.01} (shipped 0.005);
* T_β ∈ {2.5°, 5°, 10°} (shipped 5°);
* bearing offset ∈ {10°, 12.5°, 15°} (shipped 15°; above about 16.9° Test 2's inner follower
  stands further off the trace than the 120 cm turn's radius less r_F, and the scenario is
  refused before the run);

on Test 1 and Test 2 (two followers) with the shipped policy ``plan`` and the paper's
algorithm ``adjust`` (on the paper's predictor), one lap each, seeds 13 and 17, and writes
per (parameter, value, test, policy), over the seeds:

* misses, lost tracks, windows beyond 5 % (sums), collisions (sum);
* lap / oracle (the largest; summary.json ``lap_over_oracle``) and the oracle lap (s);
* the separation bound's share of the critical windows (adjust: does separation bind?).

Outputs in DIR: ``thresholds.csv`` (a row per run), ``thresholds_summary.csv``,
``thresholds.md`` (the summary as a table), ``thresholds.png`` (lap / oracle and windows
beyond 5 % against T_ε, per test and policy), ``manifest.json``.

    python experiments/thresholds.py [--quick] [--out DIR]

``--quick``: T_ε only at 0.025 and 0.03, Test 2, seed 13, 20 simulated s (the test suite).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rtsim.analysis.kinematics import BOUND_KINDS
from rtsim.coupling import run_scenario
from rtsim.io.atomic import write_table, write_text
from rtsim.io.manifest import write_manifest

#: parameter -> (the scenario key, the values swept, the shipped value)
SWEEPS: dict[str, tuple[str, tuple[float, ...], float]] = {
    "T_eps": ("thresholds.T_eps", (0.02, 0.025, 0.03, 0.035, 0.04), 0.025),
    "T_rho": ("thresholds.T_rho", (0.0025, 0.005, 0.01), 0.005),
    "T_beta_deg": ("thresholds.T_beta_deg", (2.5, 5.0, 10.0), 5.0),
    "bearing_offset_deg": ("formation.bearing_offset_deg", (10.0, 12.5, 15.0), 15.0),
}
TESTS = ("test1", "test2")
POLICIES = ("plan", "adjust")
SEEDS = (13, 17)


def run_one(
    param: str, value: float, test: str, policy: str, seed: int, duration: float | None
) -> dict[str, Any]:
    """One run's numbers (a row of thresholds.csv)."""
    t0 = time.perf_counter()
    key = SWEEPS[param][0]
    s = run_scenario(
        test,
        policy=policy,
        seed=seed,
        duration_s=duration,
        record_jobs=False,
        windows=False,
        overrides={key: value},
    ).summary
    crit = s["critical_windows"]
    return {
        "param": param,
        "value": value,
        "test": test,
        "policy": policy,
        "predictor": s["predictor"],
        "seed": seed,
        "missed": s["missed"],
        "tracks_lost": s["tracks_lost"],
        "viol5": sum(s["violations_beyond_5pct"][k] for k in BOUND_KINDS),
        "collisions": s["collisions"],
        "lap_s": math.nan if s["lap_time_s"] is None else s["lap_time_s"],
        "lap_oracle_s": math.nan if s["lap_oracle_s"] is None else s["lap_oracle_s"],
        "lap_over_oracle": math.nan if s["lap_over_oracle"] is None else s["lap_over_oracle"],
        "critical_windows": crit,
        "separation_binds": s["binding_critical"].get("separation", 0),
        "wall_s": time.perf_counter() - t0,
    }


def summarize(runs: pd.DataFrame) -> pd.DataFrame:
    """Per (parameter, value, test, policy) over the seeds (module docstring). Pure."""
    out = (
        runs.groupby(["param", "value", "test", "policy"], sort=False)
        .agg(
            seeds=("seed", "count"),
            missed=("missed", "sum"),
            tracks_lost=("tracks_lost", "sum"),
            viol5=("viol5", "sum"),
            collisions=("collisions", "sum"),
            lap_s=("lap_s", "mean"),
            lap_oracle_s=("lap_oracle_s", "mean"),
            lap_over_oracle=("lap_over_oracle", "max"),
            critical_windows=("critical_windows", "sum"),
            separation_binds=("separation_binds", "sum"),
        )
        .reset_index()
    )
    crit = out["critical_windows"].to_numpy(float)
    out["separation_share"] = np.where(crit > 0, out["separation_binds"] / np.maximum(crit, 1), 0)
    out["shipped"] = [SWEEPS[p][2] == v for p, v in zip(out["param"], out["value"], strict=True)]
    return out


def markdown(df: pd.DataFrame) -> str:
    """The summary as a Markdown table (* marks the shipped value)."""
    lines = [
        "| parameter | value | test | policy | seeds | misses | lost | windows > 5 % "
        "| collisions | lap (s) | oracle (s) | lap / oracle (max) | separation binds / critical |",
        "|" + "---|" * 13,
    ]
    for r in df.to_dict("records"):
        mark = "*" if r["shipped"] else ""
        lines.append(
            f"| {r['param']} | {r['value']:g}{mark} | {r['test']} | {r['policy']} | "
            f"{r['seeds']} | {r['missed']} | {r['tracks_lost']} | {r['viol5']} | "
            f"{r['collisions']} | {r['lap_s']:.1f} | {r['lap_oracle_s']:.1f} | "
            f"{r['lap_over_oracle']:.3f} | {r['separation_binds']} / {r['critical_windows']} |"
        )
    return "\n".join(lines) + "\n"


def figure(df: pd.DataFrame, path: Path) -> None:
    """Lap / oracle (top) and windows beyond 5 % (bottom) against T_ε, one line per test and
    policy."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from rtsim.io.atomic import atomic_path

    sel = df[df["param"] == "T_eps"]
    fig, (top, bot) = plt.subplots(2, 1, figsize=(6.4, 5.6), sharex=True)
    for (test, policy), part in sel.groupby(["test", "policy"], sort=False):
        part = part.sort_values("value")
        ls = "-" if policy == "plan" else "--"
        label = f"{test}, {policy}"
        top.plot(part["value"], part["lap_over_oracle"], ls, marker="o", label=label)
        bot.plot(part["value"], part["viol5"], ls, marker="o", label=label)
    top.axhline(1.02, color="grey", lw=0.8, ls=":", label="1.02 × oracle")
    top.set_ylabel("lap / oracle (max over seeds)")
    bot.set_ylabel("windows beyond 5 % (seeds summed)")
    bot.set_xlabel("T_ε (share of ρ_d a follower may drive per window)")
    top.axvline(SWEEPS["T_eps"][2], color="grey", lw=0.6)
    bot.axvline(SWEEPS["T_eps"][2], color="grey", lw=0.6)
    top.legend(fontsize=7)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=100)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="T_eps 0.025, 0.03; Test 2; 20 s")
    p.add_argument("--out", metavar="DIR", help="output directory")
    args = p.parse_args(argv)
    out = Path(args.out or ("out/thresholds-quick" if args.quick else "out/thresholds"))
    if args.quick:
        cases = [("T_eps", v) for v in (0.025, 0.03)]
        tests, seeds, duration = ("test2",), (13,), 20.0
    else:
        cases = [(p, v) for p, (_, values, _) in SWEEPS.items() for v in values]
        tests, seeds, duration = TESTS, SEEDS, None
    runs = pd.DataFrame(
        [
            run_one(param, value, test, policy, seed, duration)
            for param, value in cases
            for test in tests
            for policy in POLICIES
            for seed in seeds
        ]
    )
    summary = summarize(runs)
    out.mkdir(parents=True, exist_ok=True)
    write_table(out / "thresholds.csv", runs)
    write_table(out / "thresholds_summary.csv", summary)
    write_text(out / "thresholds.md", markdown(summary))
    figure(summary, out / "thresholds.png")
    write_manifest(
        out,
        command="experiments/thresholds.py",
        seed=seeds[0],
        inputs={
            "quick": args.quick,
            "duration_s": duration,
            "tests": list(tests),
            "seeds": list(seeds),
            "policies": list(POLICIES),
            "cases": [[p, v] for p, v in cases],
        },
        argv=[sys.argv[0], *(argv if argv is not None else sys.argv[1:])],
        extra={
            "outputs": [
                "thresholds.csv",
                "thresholds_summary.csv",
                "thresholds.md",
                "thresholds.png",
            ]
        },
    )
    print(markdown(summary), end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
