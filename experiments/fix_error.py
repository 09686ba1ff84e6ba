"""The Hough fix's error against range: the table of docs/localization.md.

A lone follower (a disc of radius r_F = 25 cm) stands ρ behind the leader at a bearing drawn
uniformly in 180° ± 30°; the laser (361 beams, range noise σ) scans it and the Hough window
(r_H, its centre the truth moved by N(0, 1 cm²) per coordinate, as a predicted centre is)
locates it. Per range, over ``--scans`` scans: the beams it returned, the fix error's mean,
per-coordinate standard deviation, p95 and max (cm), and the share of scans with no fix. The
Gaussian stand-in's error for comparison is position_noise·√(χ²₂): mean 1.25σ, p95 2.45σ.

    python experiments/fix_error.py [--ranges 100,150,...] [--scans N] [--range-noise CM]
        [--hough-radius CM] [--out DIR]

Writes ``fix_error.csv`` and ``fix_error.md`` under --out (default results/fix_error).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from rtsim.io.atomic import write_table, write_text
from rtsim.validate.report import markdown_table
from rtsim.world.hough import Accumulator
from rtsim.world.rangefinder import Rangefinder

R_F = 25.0
MIN_POINTS = 3


def measure(rho: float, scans: int, sd: float, r_H: float, seed: int = 0) -> dict[str, float]:
    """One range's row (module docstring)."""
    rng = np.random.default_rng(seed)
    rf = Rangefinder(R_F, math.inf, sd, fast=True)
    acc = Accumulator(1, R_F, r_H, fast=True)
    errs, beams, none = [], [], 0
    dx, dy = [], []
    for _ in range(scans):
        b = math.pi + math.radians(rng.uniform(-30.0, 30.0))
        tx, ty = rho * math.cos(b), rho * math.sin(b)
        px, py, owner = rf.scan(np.array([tx]), np.array([ty]), rng.standard_normal(361))
        beams.append(int((owner >= 0).sum()))
        c = rng.normal(0.0, 1.0, 2)
        out = acc.locate(px, py, owner, np.array([tx + c[0]]), np.array([ty + c[1]]), r_H)[0]
        if out["votes"] < MIN_POINTS:
            none += 1
            continue
        dx.append(out["fix_x"] - tx)
        dy.append(out["fix_y"] - ty)
        errs.append(math.hypot(dx[-1], dy[-1]))
    e = np.asarray(errs)
    return {
        "rho_cm": rho,
        "beams": float(np.mean(beams)),
        "error_mean_cm": float(e.mean()) if e.size else math.nan,
        "error_sd_cm": float(np.sqrt(0.5 * (np.var(dx) + np.var(dy)))) if e.size else math.nan,
        "error_p95_cm": float(np.percentile(e, 95)) if e.size else math.nan,
        "error_max_cm": float(e.max()) if e.size else math.nan,
        "no_fix_share": none / scans,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ranges", default="100,150,200,325,390,500,800,1200")
    ap.add_argument("--scans", type=int, default=2000)
    ap.add_argument("--range-noise", type=float, default=1.0)
    ap.add_argument("--hough-radius", type=float, default=25.0)
    ap.add_argument("--out", type=Path, default=Path("results/fix_error"))
    a = ap.parse_args(argv)
    try:
        ranges = [float(x) for x in a.ranges.split(",")]
    except ValueError:
        print(f"--ranges: not a list of numbers: {a.ranges!r}", file=sys.stderr)
        return 2
    rows = [measure(r, a.scans, a.range_noise, a.hough_radius) for r in ranges]
    df = pd.DataFrame(rows)
    a.out.mkdir(parents=True, exist_ok=True)
    write_table(a.out / "fix_error.csv", df)
    write_text(a.out / "fix_error.md", markdown_table(df, digits=3) + "\n")
    print(df.to_string(index=False))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
