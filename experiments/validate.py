"""Validate the analysis against the simulator: ``python experiments/validate.py [--quick]``.

The same library code as ``rtsim validate`` (:func:`rtsim.validate.run_validation`): the
paper's task set over n = 1..10 and r_H = 10..50 cm and 30 random UUniFast sets (``--quick``:
n in {1, 2, 4}, r_H in {10, 30}, 3 sets, about 20 s on 2 cores). Writes ``report.md``, the
validation table (CSV, Parquet), the figures with their data as CSV, and the histograms to
``--out`` (default ``out/validate`` or ``out/validate-quick``). Exit status as the command:
1 when a simulated response is above its analytic bound.
"""

from __future__ import annotations

import sys

from rtsim.cli import main

if __name__ == "__main__":
    argv = sys.argv[1:]
    if not any(a == "--out" or a.startswith("--out=") for a in argv):  # the command needs one
        argv += ["--out", "out/validate-quick" if "--quick" in argv else "out/validate"]
    sys.exit(main(["validate", *argv]))
