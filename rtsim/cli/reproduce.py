"""``rtsim reproduce [--quick] --out DIR``: the paper's Test 1 and Test 2 in the three window
modes, with rtsim's planner beside them, Figures 2 and 8-15, their data, a summary table and
report.html.

Parses the options into [`ReproduceOptions`][rtsim.reproduce.ReproduceOptions] and runs
[`rtsim.reproduce.run`][rtsim.reproduce.run] (the paper reproduction), which writes
``report.html`` in DIR (the summary table, every figure, the data files, the manifest) and in
each run directory DIR/<test>/<mode>/ before DIR is swapped in whole (`rtsim.io.outdir`).
``--quick``: 60 simulated seconds per run (one turn), about 15 s.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import rtsim.reproduce
from rtsim.cli.common import add_force
from rtsim.cli.plausible import check_duration
from rtsim.reproduce import DEFAULT_OUT, MODES, QUICK_DURATION_S, TESTS, ReproduceOptions

__all__ = ["register", "run", "add_options", "options"]


def register(sub: Any) -> None:
    """Add the ``reproduce`` sub-command."""
    p = sub.add_parser(
        "reproduce",
        help="reproduce the paper's experiments and figures",
        description=__doc__.splitlines()[0],
    )
    add_options(p)
    p.set_defaults(func=run)


def add_options(ap: Any) -> None:
    """Add the options of [`ReproduceOptions`][rtsim.reproduce.ReproduceOptions] to the
    parser ``ap`` (``--out`` has no default, as on every command that writes)."""
    ap.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        help=f"output directory (the README's: {DEFAULT_OUT})",
    )
    ap.add_argument(
        "--quick",
        action="store_true",
        help=f"CI mode: {QUICK_DURATION_S:g} simulated s per run (one turn)",
    )
    ap.add_argument("--seed", type=int, default=0, help="seed of every run (default 0)")
    ap.add_argument(
        "--duration",
        type=float,
        default=None,
        metavar="S",
        help="simulated seconds per run (default: each scenario's, at least one lap; --quick: 60)",
    )
    ap.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="processes (default min(6, cpu count)); 1 runs in this process",
    )
    ap.add_argument(
        "--docs",
        default=None,
        metavar="DIR",
        help="also write the documentation's figures (PNG, 100 dpi) to DIR",
    )
    ap.add_argument("--quiet", "-q", action="store_true", help="no progress bar or lines, no table")
    ap.add_argument(
        "--format",
        dest="fig_format",
        choices=("png", "svg", "pdf"),
        default=None,
        help="file format of the figures (default png)",
    )
    ap.add_argument(
        "--dpi",
        type=int,
        default=None,
        help="resolution of PNG figures in dots per inch (default 300)",
    )
    ap.add_argument(
        "--json",
        action="store_true",
        help="print the summary table as one JSON object instead of Markdown",
    )
    add_force(ap, "run even when --duration looks like a mistake of unit (over 6 simulated hours)")
    ap.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="change a key of both scenarios (a dotted path, the value read as TOML); repeatable",
    )


def options(args: Any) -> ReproduceOptions:
    """The parsed command line as [`ReproduceOptions`][rtsim.reproduce.ReproduceOptions]
    (one field per option, the same names)."""
    got = {f.name: getattr(args, f.name) for f in dataclasses.fields(ReproduceOptions)}
    got["set"] = tuple(got["set"])
    return ReproduceOptions(**got)


def run(args: Any) -> int:
    """Run the reproduction on the parsed options (one parse), then write the reports."""
    from rtsim.report import write_run_report  # lazy: CLI start-up (~2 ms)

    check_duration(args, args.duration)

    def reports(out: Path) -> None:  # in the staging directory, before the swap
        write_run_report(out, title="rtsim reproduce: the paper's Tests 1 and 2")
        for t in TESTS:
            for m in MODES:
                if (out / t / m / "summary.json").is_file():
                    write_run_report(out / t / m, title=f"rtsim reproduce: {t}, {m}")

    return rtsim.reproduce.run(options(args), finish=reports)
