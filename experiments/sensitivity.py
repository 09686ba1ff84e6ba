"""How the paper's picture depends on the assumed thresholds T_ε, T_ρ, T_β.

``python experiments/sensitivity.py [--quick] [--out DIR] [--workers N]``

Runs Test 1 and Test 2 (``experiments/scenarios``) in the three modes for every
T_ε ∈ {0.0125, 0.025, 0.05} × T_ρ ∈ {0.005, 0.01, 0.02} (T_β = 5°), and T_β ∈ {2.5°, 10°}
at the default T_ε = 0.025, T_ρ = 0.01. ``adjust`` runs one lap (the default duration); the
baselines run 45 s (Test 2: 40 s; both cover the first turn). ``--quick`` (CI): Test 2 only,
T_ε ∈ {0.025, 0.05} in adjust mode and the baselines at 0.025, T_ρ = 0.01, 32 s per run
(the first turn starts at 26.7 s) — a few seconds.

Writes to ``--out`` (default ``out/sensitivity`` or ``out/sensitivity-quick``):
``sensitivity.csv`` (one row per run: the summary's scalars), ``sensitivity.md`` (the table
for the README), ``sensitivity.png`` and ``manifest.json``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path
from typing import Any

import pandas as pd

from rtsim.config.scenario import load_scenario
from rtsim.coupling import run_scenario
from rtsim.io.atomic import write_table, write_text
from rtsim.io.manifest import write_manifest

SCEN = Path(__file__).resolve().parent / "scenarios"
MODES = ("adjust", "fixed-wsch", "min-msb")


def points(quick: bool) -> list[dict[str, Any]]:
    """The runs: test, mode, thresholds, duration (None = the default, one lap)."""
    out: list[dict[str, Any]] = []
    if quick:
        for t_eps in (0.025, 0.05):
            for mode in MODES if t_eps == 0.025 else ("adjust",):
                out.append(
                    dict(
                        test="test2",
                        mode=mode,
                        T_eps=t_eps,
                        T_rho=0.01,
                        T_beta_deg=5.0,
                        duration=32.0,
                    )
                )
        return out
    grid = [(e, r, 5.0) for e in (0.0125, 0.025, 0.05) for r in (0.005, 0.01, 0.02)]
    grid += [(0.025, 0.01, 2.5), (0.025, 0.01, 10.0)]
    for test in ("test1", "test2"):
        for t_eps, t_rho, t_beta in grid:
            for mode in MODES:
                dur = None if mode == "adjust" else (45.0 if test == "test1" else 40.0)
                out.append(
                    dict(
                        test=test,
                        mode=mode,
                        T_eps=t_eps,
                        T_rho=t_rho,
                        T_beta_deg=t_beta,
                        duration=dur,
                    )
                )
    return out


def run_point(p: dict[str, Any]) -> dict[str, Any]:
    """One run; returns the point and the summary's scalars."""
    sc = load_scenario(SCEN / f"{p['test']}.toml")
    thr = replace(
        sc.world.thresholds,
        T_eps=p["T_eps"],
        T_rho=p["T_rho"],
        T_beta=math.radians(p["T_beta_deg"]),
    )
    sc = replace(sc, world=replace(sc.world, thresholds=thr))
    t0 = time.perf_counter()
    res = run_scenario(sc, policy=p["mode"], duration_s=p["duration"], seed=0, record_jobs=False)
    s = res.summary
    row = {k: v for k, v in p.items() if k != "duration"}
    row.update(
        duration_s=s["duration_s"],
        laps=s["laps"],
        windows=s["windows"],
        missed=s["missed"],
        tracks_lost=s["tracks_lost"],
        critical_share=s["critical_share"],
        min_msb_over_wsch=s["min_msb_over_wsch"],
        min_speed_ratio=s["min_speed_ratio"],
        binding_critical=";".join(f"{k}={v}" for k, v in s["binding_critical"].items()),
    )
    for k, v in s["violations"].items():
        row[f"viol_{k}"] = v
    row["viol5"] = sum(s["violations_beyond_5pct"].values())
    row["max_viol_ratio"] = max(s["max_violation_ratio"].values())
    row["wall_s"] = time.perf_counter() - t0
    return row


def table(df: pd.DataFrame) -> str:
    """Markdown: per (test, T_ε, T_ρ, T_β) the adjust results and the baselines' failures."""
    keys = ["test", "T_eps", "T_rho", "T_beta_deg"]
    adj = df[df["mode"] == "adjust"].set_index(keys)
    fix = df[df["mode"] == "fixed-wsch"].set_index(keys)
    mm = df[df["mode"] == "min-msb"].set_index(keys)
    viol = [c for c in df.columns if c.startswith("viol_")]
    lines = [
        "| test | T_ε | T_ρ | T_β (°) | adjust: violations > 5 % / max ratio / misses / "
        "lost (all violations) | critical share | min MSB/w_sch | min V_L/V_Ld | "
        "binding (critical) | fixed-wsch: violations (path, sep) | min-msb: misses |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for key, a in adj.iterrows():
        f = fix.loc[key] if key in fix.index else None
        m = mm.loc[key] if key in mm.index else None
        fv = (
            f"{int(f['viol_path_diversion'])}, {int(f['viol_separation'])}"
            if f is not None
            else "–"
        )
        lines.append(
            f"| {key[0]} | {key[1]:g} | {key[2]:g} | {key[3]:g} | {int(a['viol5'])} / "
            f"{a['max_viol_ratio']:.2f} / {int(a['missed'])} / {int(a['tracks_lost'])} "
            f"({int(sum(a[c] for c in viol))}) | {a['critical_share']:.2f} | "
            f"{a['min_msb_over_wsch']:.2f} | {a['min_speed_ratio']:.2f} | "
            f"{str(a['binding_critical']).replace(';', ', ')} | "
            f"{fv} | {int(m['missed']) if m is not None else '–'} |"
        )
    return "\n".join(lines) + "\n"


def figure(df: pd.DataFrame, path: Path) -> None:
    """min V_L/V_Ld and min MSB/w_sch (adjust) against T_ε, one line per (test, T_ρ)."""
    from matplotlib.figure import Figure

    from rtsim.plots.scenario import save_figure

    adj = df[(df["mode"] == "adjust") & (df["T_beta_deg"] == 5.0)]
    fig = Figure(figsize=(9, 3.6))
    axes = fig.subplots(1, 2)
    for (test, t_rho), g in adj.groupby(["test", "T_rho"]):
        g = g.sort_values("T_eps")
        ls = "-" if test == "test1" else "--"
        label = f"{test}, T_ρ={t_rho:g}"
        axes[0].plot(g["T_eps"], g["min_msb_over_wsch"], ls, marker="o", label=label)
        axes[1].plot(g["T_eps"], g["min_speed_ratio"], ls, marker="o", label=label)
    for ax, lab in zip(axes, ("min MSB / w_sch", "min V_L / V_Ld"), strict=True):
        ax.set_xlabel("T_ε")
        ax.set_ylabel(lab)
        ax.axhline(1.0, color="k", lw=0.8, ls=":")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle("Sensitivity to the assumed thresholds (adjust mode, T_β = 5°)")
    fig.tight_layout()
    save_figure(fig, path)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="CI mode: a few seconds")
    ap.add_argument("--out", default=None, help="output directory")
    ap.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    args = ap.parse_args(argv)
    out = Path(args.out or ("out/sensitivity-quick" if args.quick else "out/sensitivity"))
    pts = points(args.quick)
    t0 = time.perf_counter()
    if args.quick or args.workers <= 1:
        rows = [run_point(p) for p in pts]
    else:
        with ProcessPoolExecutor(args.workers) as ex:
            rows = list(ex.map(run_point, pts))
    df = pd.DataFrame(rows)
    write_table(out / "sensitivity.csv", df)
    md = table(df)
    write_text(out / "sensitivity.md", md)
    figure(df, out / "sensitivity.png")
    write_manifest(
        out,
        command="experiments/sensitivity.py",
        seed=0,
        inputs={
            "points": pts,
            "scenarios": [str(SCEN / "test1.toml"), str(SCEN / "test2.toml")],
            "quick": args.quick,
        },
        argv=[sys.argv[0], *(argv if argv is not None else sys.argv[1:])],
        extra={
            "timing": {"total_s": time.perf_counter() - t0},
            "outputs": ["sensitivity.csv", "sensitivity.md", "sensitivity.png"],
        },
    )
    print(md, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
