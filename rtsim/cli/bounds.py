"""``rtsim bounds [FILE] [--followers N] [--hough-radius R] [--json]``: the window bounds.

Prints e_hough (Eq 1), g (Eq 5/6), Eq 7, Eq 11, w_sch = max(Eq 7, Eq 11), the exact w_rta,
the suspension-aware w_susp (Δt with the CPU idle, docs/model/beyond.md), w_edf (the CPU under
EDF: the processor-demand criterion, Δt as CPU time) and w_txn (the offset-based transaction
analysis, Δt with the CPU idle, docs/analysis.md).
FILE defaults to the paper's task set; n and r_H default to the file's. Both options also take
lists and inclusive ranges (``1..10``, ``10..50:10``, ``10,20,30``): one row per combination.
``--json`` prints one object (a list of them with lists or ranges) that echoes every input.
"""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from rtsim.analysis.bounds import w_txn, window_bounds
from rtsim.cli._set import add_set_option, set_overrides
from rtsim.cli.analyze import json_safe
from rtsim.cli.common import add_force, add_json, add_quiet
from rtsim.cli.plausible import check_hough_radius
from rtsim.config.taskset import load_taskset
from rtsim.errors import InputError
from rtsim.io.limits import check
from rtsim.io.ranges import parse_int_values, parse_values

__all__ = ["register", "run"]


def register(sub: Any) -> None:
    """Add the ``bounds`` sub-command."""
    p = sub.add_parser(
        "bounds",
        help="the paper's window bounds w_sch and the exact w_rta",
        description=__doc__.splitlines()[0],
    )
    p.add_argument(
        "file",
        metavar="FILE",
        nargs="?",
        default=None,
        help="task-set TOML file with a [window] (default: the paper's set)",
    )
    p.add_argument(
        "--followers",
        metavar="RANGE",
        default=None,
        help="n: a number, a list 1,2,5 or a range 1..10 (default: the file's)",
    )
    p.add_argument(
        "--hough-radius",
        metavar="RANGE",
        default=None,
        help="r_H in cm: a number, a list or a range 10..50:10 (default: the file's)",
    )

    add_set_option(p)

    add_json(p, "print JSON (a list for several rows)")
    add_quiet(p, "print nothing (a check of the inputs)")
    add_force(
        p,
        "run even when a value looks like a mistake of unit, or w_txn's offset-based "
        "analysis would evaluate more than 1e7 interference terms",
    )
    p.set_defaults(func=run)


def _is_list(text: str | None) -> bool:
    return text is not None and ("," in text or ".." in text)


def _values(args: argparse.Namespace, n0: int, r0: float) -> tuple[list[int], list[float]]:
    ns = [n0] if args.followers is None else parse_int_values(args.followers, "--followers")
    for n in ns:
        if n < 1:
            raise InputError(f"--followers: must be at least 1, got {n} in {args.followers!r}")
    rs = [r0] if args.hough_radius is None else parse_values(args.hough_radius, "--hough-radius")
    for r in rs:
        if r <= 0:
            raise InputError(
                f"--hough-radius: must be positive (cm), got {r:g} in {args.hough_radius!r}"
            )

    check_hough_radius(args, rs)
    for n in ns:
        check("option: --followers", n, "--followers")
    for r in rs:
        check("option: --hough-radius", r, "--hough-radius")
    return ns, rs


def _cell(x: float) -> str:
    return f"{x:.3f}" if math.isfinite(x) else ("none" if x > 0 else "-")


def run(args: argparse.Namespace) -> int:
    """Run the sub-command (InputError is reported by the caller)."""
    ts = load_taskset(args.file, overrides=set_overrides(args))
    if ts.window is None:
        raise InputError(f"{ts.source}: has no [window]; bounds needs a processing-window set")
    ns, rs = _values(args, ts.window.n, ts.window.r_H)
    sets = [ts.with_window(n=n, r_H=r) for n in ns for r in rs]
    rows = [window_bounds(one) for one in sets]
    txn = [w_txn(one, force=args.force) for one in sets]
    many = len(rows) > 1 or _is_list(args.followers) or _is_list(args.hough_radius)
    dicts = [
        {**b.as_dict(), "w_txn": x if math.isfinite(x) else None}
        for b, x in zip(rows, txn, strict=True)
    ]
    if args.json:
        out: Any = [json_safe(d) for d in dicts] if many else json_safe(dicts[0])
        print(json.dumps(out, indent=2, allow_nan=False))
        return 0
    if args.quiet:
        return 0
    print(f"task set: {ts.name or '(unnamed)'}  ({ts.source})")
    if not many:
        b = rows[0]
        print(f"n = {b.inputs['n']} followers, r_H = {b.inputs['r_H']:g} cm\n")
        for label, value, note in [
            ("e_hough", b.e_hough, "Eq 1, localization"),
            ("g", b.g, "Eq 5/6, one window's processing time"),
            ("Eq 7", b.w_eq7, "the window chain"),
            ("Eq 11", b.w_eq11, "T_lp (Eq 10 corrected); '-' without T_lp"),
            ("w_sch", b.w_sch, "max(Eq 7, Eq 11), the paper's bound"),
            ("w_rta", b.w_rta, "exact response-time analysis; 'none': never schedulable"),
            ("w_susp", b.w_susp, "suspension-aware analysis, Δt with the CPU idle"),
            ("w_edf", b.w_edf, "EDF processor-demand criterion, Δt as CPU time"),
            ("w_txn", txn[0], "offset-based (transaction) analysis, Δt with the CPU idle"),
        ]:
            print(f"{label:<8} {_cell(value):>10} ms   {note}")
        return 0
    head = (
        f"{'n':>4} {'r_H':>7} {'e_hough':>9} {'g':>9} {'Eq 7':>9} {'Eq 11':>9} "
        f"{'w_sch':>9} {'w_rta':>9} {'w_susp':>9} {'w_edf':>9} {'w_txn':>9}"
    )
    print(f"times in ms, r_H in cm\n\n{head}\n{'-' * len(head)}")
    for b, x in zip(rows, txn, strict=True):
        print(
            f"{b.inputs['n']:>4} {b.inputs['r_H']:>7g} {_cell(b.e_hough):>9} {_cell(b.g):>9} "
            f"{_cell(b.w_eq7):>9} {_cell(b.w_eq11):>9} {_cell(b.w_sch):>9} "
            f"{_cell(b.w_rta):>9} {_cell(b.w_susp):>9} {_cell(b.w_edf):>9} {_cell(x):>9}"
        )
    return 0
