"""``rtsim reproduce [--quick] --out DIR``: the paper's Test 1 and Test 2 in the three window
modes, with Figures 2 and 8-15, their data, a summary table and report.html.

Runs :mod:`rtsim.reproduce` (the paper reproduction), which writes ``report.html`` in DIR
(the summary table, every figure, the data files, the manifest) and in each run directory
DIR/<test>/<mode>/ before DIR is swapped in whole (:mod:`rtsim.io.outdir`).
``--quick``: 60 simulated seconds per run (one turn), about 15 s.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["register", "run"]


def register(sub: Any) -> None:
    """Add the ``reproduce`` sub-command (the options of :func:`rtsim.reproduce.parse_args`)."""
    p = sub.add_parser("reproduce", help="reproduce the paper's experiments and figures",
                       description=__doc__.splitlines()[0])
    p.add_argument("--out", required=True, metavar="DIR",
                   help="output directory (the README's: results/paper)")
    p.add_argument("--quick", action="store_true",
                   help="60 simulated seconds per run (one turn) instead of a lap")
    p.add_argument("--seed", type=int, default=None, metavar="N",
                   help="seed of every run (default 0)")
    p.add_argument("--duration", type=float, default=None, metavar="SECONDS",
                   help="simulated seconds per run (default: each scenario's, at least a lap)")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="processes (default min(6, CPU count)); 1 runs in this process")
    p.add_argument("--docs", default=None, metavar="DIR",
                   help="also write the documentation's figures (PNG, 100 dpi) to DIR")
    p.add_argument("--force", action="store_true",
                   help="run even when --duration looks like a mistake of unit (over 6 "
                        "simulated hours)")
    from rtsim.cli._set import add_set_option
    from rtsim.cli.common import add_figure_options, add_json, add_quiet

    add_figure_options(p, default_dpi=120)  # rtsim.plots.scenario.DPI
    add_json(p, "print the summary table as one JSON object instead of Markdown")
    add_quiet(p, "no progress bar or lines, no table")
    add_set_option(p, help="change a key of both scenarios (Test 1 and Test 2): a dotted path, "
                   "the value read as TOML; repeatable")
    p.set_defaults(func=run)


def argv_for(args: Any) -> list[str]:
    """The command line of :func:`rtsim.reproduce.main` for these options."""
    argv = ["--out", str(args.out)]
    for opt, dest in (("seed", "seed"), ("duration", "duration"), ("workers", "workers"),
                      ("docs", "docs"), ("format", "fig_format"), ("dpi", "dpi")):
        value = getattr(args, dest)
        if value is not None:
            argv += [f"--{opt}", str(value)]
    argv += [a for s in getattr(args, "set", None) or [] for a in ("--set", s)]
    return argv + [f"--{flag}" for flag in ("quick", "quiet", "force", "json")
                   if getattr(args, flag)]


def run(args: Any) -> int:
    """Run the reproduction, then write the reports."""
    from rtsim.cli.plausible import check_duration
    from rtsim.report import write_run_report

    check_duration(args, args.duration)
    from rtsim.reproduce import MODES, TESTS, main

    def reports(out: Path) -> None:  # in the staging directory, before the swap
        write_run_report(out, title="rtsim reproduce: the paper's Tests 1 and 2")
        for t in TESTS:
            for m in MODES:
                if (out / t / m / "summary.json").is_file():
                    write_run_report(out / t / m, title=f"rtsim reproduce: {t}, {m}")

    return main(argv_for(args), finish=reports)
