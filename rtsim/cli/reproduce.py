"""``rtsim reproduce [--quick] --out DIR``: the paper's Test 1 and Test 2 in the three window
modes, with Figures 2 and 8-15, their data, a summary table and report.html.

Runs `rtsim.reproduce` (the paper reproduction), which writes ``report.html`` in DIR
(the summary table, every figure, the data files, the manifest) and in each run directory
DIR/<test>/<mode>/ before DIR is swapped in whole (`rtsim.io.outdir`).
``--quick``: 60 simulated seconds per run (one turn), about 15 s.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["register", "run"]


def register(sub: Any) -> None:
    """Add the ``reproduce`` sub-command (its options are `rtsim.reproduce.add_options`,
    defined once for this command and ``python -m rtsim.reproduce``)."""
    from rtsim.reproduce import add_options

    p = sub.add_parser(
        "reproduce",
        help="reproduce the paper's experiments and figures",
        description=__doc__.splitlines()[0],
    )
    add_options(p, out_required=True)
    p.set_defaults(func=run)


def run(args: Any) -> int:
    """Run the reproduction on the parsed options (one parse), then write the reports."""
    from rtsim.cli.plausible import check_duration
    from rtsim.report import write_run_report

    check_duration(args, args.duration)
    from rtsim.reproduce import MODES, TESTS
    from rtsim.reproduce import run as reproduce

    def reports(out: Path) -> None:  # in the staging directory, before the swap
        write_run_report(out, title="rtsim reproduce: the paper's Tests 1 and 2")
        for t in TESTS:
            for m in MODES:
                if (out / t / m / "summary.json").is_file():
                    write_run_report(out / t / m, title=f"rtsim reproduce: {t}, {m}")

    return reproduce(args, finish=reports)
