"""``rtsim histogram``: response-time histograms per task with the analytic bounds drawn in.

Sources (exactly one):

- ``rtsim histogram FILE --horizon H [--seed S] [--exec wcet|uniform] [--suspension cpu|idle]
  [--followers N] [--hough-radius R] [--window W] [--set KEY=VALUE]``: simulate a task set;
- ``rtsim histogram --scenario DIR``: the job table of ``rtsim scenario --out DIR``;
- ``rtsim histogram --sweep DIR --point I``: point I of a ``simulate`` sweep, re-run.

Writes into ``--out DIR``: ``histograms.png`` (the run in one figure, a panel per task, 300
dpi) and ``histogram-<task>.png`` (``.svg``, ``.pdf`` with ``--format``) per
task (lines: exact WCRT, deadline, w_sch), ``histogram.csv``, ``bounds.csv`` and
``manifest.json``.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from rtsim.analysis.bounds import window_bounds
from rtsim.cli._set import add_set_option
from rtsim.cli.common import (
    add_figure_options,
    add_force,
    add_json,
    add_quiet,
    add_simulation,
    figure_format,
)
from rtsim.cli.plausible import check_horizon, check_hough_radius, periods_ms, warn_short_horizon
from rtsim.cli.simulate import require_bcet, window_taskset
from rtsim.errors import InputError
from rtsim.io.atomic import dumps
from rtsim.io.outdir import stage

__all__ = ["register", "run"]


def register(sub: Any) -> None:
    """Add the ``histogram`` sub-command."""
    p = sub.add_parser(
        "histogram",
        help="response-time histograms with the analytic bounds",
        description=__doc__.splitlines()[0],
    )
    p.add_argument("file", nargs="?", help="task-set TOML file to simulate")
    p.add_argument("--scenario", metavar="DIR", help="a scenario output directory (jobs.csv)")
    p.add_argument("--sweep", metavar="DIR", help="a simulate sweep's output directory")
    p.add_argument("--point", type=int, metavar="N", help="the sweep point (0-based)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.add_argument("--bins", type=int, default=50, help="bins per histogram (default 50)")
    p.add_argument("--horizon", type=float, help="simulated ms (with FILE)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    add_simulation(p)
    add_force(p)

    add_set_option(
        p,
        "with FILE: change a key of the task set (a dotted path, the value read "
        "as TOML; repeatable), e.g. --set tasks.command.wcet=12",
    )

    add_figure_options(p, default_dpi=300, what="histograms")  # rtsim.validate.histogram.DPI
    add_json(p, "print the files written as one JSON object")
    add_quiet(p, "no progress bar, no list of the files written")
    p.set_defaults(func=run)


def _source(args: argparse.Namespace) -> Any:
    from rtsim.validate.histogram import (  # lazy: CLI start-up (pandas)
        from_scenario_dir,
        from_simulation,
        from_sweep_point,
    )

    given = [x for x in (args.file, args.scenario, args.sweep) if x is not None]
    if len(given) != 1:
        raise InputError("histogram: give exactly one of FILE, --scenario DIR, --sweep DIR")
    if args.set and args.file is None:
        raise InputError(
            "histogram: --set changes FILE's keys; it does not apply to "
            "--scenario or --sweep (their runs are recorded as they were)"
        )
    if args.sweep is not None:
        if args.point is None:
            raise InputError("histogram: --sweep needs --point I")
        return from_sweep_point(args.sweep, args.point)
    if args.point is not None:
        raise InputError("histogram: --point applies to --sweep only")
    if args.scenario is not None:
        return from_scenario_dir(
            args.scenario, n=args.followers, r_H=args.hough_radius, w=args.window
        )

    if args.horizon is None or not (math.isfinite(args.horizon) and args.horizon > 0):
        raise InputError("histogram: FILE needs --horizon H, a positive number of ms")

    ts = window_taskset(args)
    if args.hough_radius is not None:
        check_hough_radius(args, [args.hough_radius])
    if ts.window is not None:
        w = args.window if args.window is not None else window_bounds(ts).w_sch
        check_horizon(args, args.horizon, w, periods=periods_ms(ts, w))
    else:
        check_horizon(args, args.horizon, None, periods=periods_ms(ts, None))
    if args.seed < 0:
        raise InputError(f"--seed must be a non-negative integer, got {args.seed}")
    if args.exec_model == "uniform":
        require_bcet(ts, str(args.file))
    kwargs: dict[str, Any] = {
        "seed": args.seed,
        "exec_model": args.exec_model,
        "suspension": args.suspension,
    }
    if args.window is not None:
        kwargs["window"] = args.window

    warn_short_horizon(args)  # every input checked: the run goes ahead
    src = from_simulation(ts, args.horizon, **kwargs)
    return src


def run(args: argparse.Namespace) -> int:
    """Write the histograms; print the files written."""
    from rtsim.validate.histogram import write_histograms  # lazy: CLI start-up (pandas)

    if args.bins < 1:
        raise InputError(f"--bins must be at least 1, got {args.bins}")
    from rtsim.validate.histogram import DPI  # lazy: CLI start-up (pandas)

    fmt = figure_format(args)
    with stage(args.out, command="histogram") as staged:
        src = _source(args)
        written = write_histograms(
            src,
            staged.path,
            bins=args.bins,
            argv=["rtsim", *sys.argv[1:]],
            fmt=fmt,
            dpi=args.dpi or DPI,
        )
        staged.commit()
    files = [str(Path(args.out) / p.name) for p in written]
    if args.json:
        print(dumps({"out": str(args.out), "files": files}))
    elif not args.quiet:
        print("\n".join(files))
    return 0
