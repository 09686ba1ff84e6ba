"""``rtsim validate [--quick] --out DIR [--set KEY=VALUE] [--workers N]``: analysis vs simulation.

Runs `rtsim.validate.run_validation`: the paper's set over n and r_H (w_sch, w_rta,
w_sim searched twice, response times at w_sch against the exact WCRT) and random UUniFast
sets, through the sweep engine (parallel, resumable). Writes the table, figures and
``DIR/report.md``. Exit status: 0 when nothing is flagged, 1 when a simulated response is
above its analytic bound (or a point failed to run), 2 on bad input.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from typing import Any

from rtsim.cli._set import add_set_option, set_overrides
from rtsim.cli.analyze import json_safe
from rtsim.cli.common import (
    add_figure_options,
    add_force,
    add_json,
    add_quiet,
    add_workers,
    figure_format,
    progress_enabled,
)
from rtsim.cli.plausible import check_hough_radius
from rtsim.errors import InputError
from rtsim.io.atomic import dumps
from rtsim.io.ranges import parse_int_values, parse_values

__all__ = ["register", "run"]


def register(sub: Any) -> None:
    """Add the ``validate`` sub-command."""
    p = sub.add_parser(
        "validate",
        help="validate the analysis against the simulator",
        description=__doc__.splitlines()[0],
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="small grid: n in {1,2,4}, r_H in {10,30}, 100 windows, 3 random sets",
    )
    p.add_argument(
        "--out", required=True, metavar="DIR", help="output directory (resumed when run again)"
    )
    add_workers(p, "run the points on an existing dask.distributed scheduler")
    p.add_argument(
        "--restart",
        action="store_true",
        help="discard earlier sweep results in DIR (needed when options changed)",
    )
    p.add_argument(
        "--taskset",
        default=None,
        metavar="FILE",
        help="a processing-window task set (default: the paper's, packaged)",
    )
    p.add_argument(
        "--scenario",
        default=None,
        metavar="FILE",
        help="the world whose beams are counted (default: "
        "experiments/scenarios/test1.toml); its formation gets n followers",
    )
    p.add_argument(
        "--followers",
        default=None,
        metavar="RANGE",
        help="n values, e.g. 1..10 or 1,2,4 (overrides the grid)",
    )
    p.add_argument(
        "--hough-radius",
        default=None,
        metavar="RANGE",
        help="r_H values in cm, e.g. 10..50:10 (overrides the grid)",
    )
    p.add_argument(
        "--windows", type=int, default=None, help="windows per simulated run (at least 100)"
    )
    p.add_argument("--random-sets", type=int, default=None, help="number of random task sets")
    p.add_argument(
        "--histograms",
        type=int,
        default=None,
        metavar="N",
        help="configurations to draw response-time histograms for (default 2, quick 1; 0 = none)",
    )
    p.add_argument("--seed", type=int, default=None, help="the validation's seed (default 1)")
    add_force(p)

    add_set_option(
        p,
        "change a key of the task set (a key of its tables or [window], e.g. "
        "tasks.command.wcet=12) or else of the scenario (e.g. leader.speed=20): a dotted "
        "path, the value read as TOML; repeatable; n and r_H: --followers, --hough-radius",
    )

    add_figure_options(p, default_dpi=300)  # rtsim.validate.runner.DPI (not imported: slow)
    add_json(p, "print summary.json (and the failures) as one JSON object")
    add_quiet(p, "no progress bar, no summary")

    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the validation; exit status as in the module docstring."""
    from rtsim.validate import FULL, QUICK, run_validation  # lazy: CLI start-up (pandas)

    cfg = QUICK if args.quick else FULL
    changes: dict[str, Any] = {}
    if args.followers is not None:
        changes["n"] = tuple(parse_int_values(args.followers, "--followers"))
    if args.hough_radius is not None:
        changes["r_H"] = tuple(float(x) for x in parse_values(args.hough_radius, "--hough-radius"))

        check_hough_radius(args, changes["r_H"])
    if args.windows is not None:
        changes["windows"] = args.windows
    if args.histograms is not None:
        if args.histograms < 0:
            raise InputError(f"--histograms must be >= 0, got {args.histograms}")
        changes["histogram_configs"] = args.histograms
    if args.random_sets is not None:
        changes["random_sets"] = args.random_sets
    if args.seed is not None:
        if args.seed < 0:
            raise InputError(f"--seed must be a non-negative integer, got {args.seed}")
        changes["seed"] = args.seed
    if args.taskset is not None:
        changes["taskset_path"] = args.taskset
    if args.scenario is not None:
        changes["scenario_path"] = args.scenario

    overrides = set_overrides(args)
    if overrides:
        changes["overrides"] = tuple(overrides.items())
    if args.workers is not None and args.workers < 1:
        raise InputError(f"--workers must be at least 1, got {args.workers}")
    if changes:
        cfg = replace(cfg, **changes)
    out = args.out
    from rtsim.validate.runner import DPI  # lazy: CLI start-up (pandas)

    outcome = run_validation(
        out,
        cfg,
        workers=args.workers,
        dask=args.dask,
        progress=progress_enabled(args),
        restart=args.restart,
        argv=["rtsim", *sys.argv[1:]],
        fig_format=figure_format(args),
        dpi=args.dpi or DPI,
    )
    if args.json:
        print(
            dumps(
                json_safe(
                    {
                        "ok": outcome.ok,
                        "out": str(outcome.out_dir),
                        "summary": outcome.summary,
                        "failures": [f.as_dict() for f in outcome.failures],
                        "point_errors": list(outcome.point_errors),
                    }
                )
            )
        )
    elif not args.quiet:
        s = outcome.summary
        for key in ("paper/wcet-cpu", "paper/counted-idle"):
            e = s.get(key)
            if e and e.get("w_sch_over_w_sim", {}).get("min") is not None:
                r = e["w_sch_over_w_sim"]
                print(f"{key}: w_sch/w_sim {r['min']:.4f}..{r['max']:.4f}")
        fails = [f for f in outcome.failures if f.severity == "failure"]
        for f in fails[:5]:
            print(f"FAILURE {f.config} {f.task} {f.mode}: {f.check}: {f.value:.6g} > {f.bound:.6g}")
        for e in outcome.point_errors[:5]:
            print(f"failed point: {e}")
        print(
            f"{len(fails)} failure(s), {len(outcome.point_errors)} failed "
            f"point(s) -> {outcome.out_dir / 'report.md'}"
        )
    return 0 if outcome.ok else 1
