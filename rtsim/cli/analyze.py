"""``rtsim analyze FILE [--json] [--check] [--window W] [--scheduler fp|edf]``: schedulability.

Per task: priority, wcet, period, deadline, utilization, worst-case response time (exact,
fixed-point iteration) and the verdict; then the total utilization, the Liu–Layland and
hyperbolic tests, and the verdict for the set. A processing-window set is analysed at
``--window`` (default: the analytic w_sch), its chain counted as one task of cost g with the
radio round trip as CPU time. The exit status is 0 whatever the verdict; with ``--check`` it
is 1 when the set is not schedulable.

``--scheduler edf`` (or ``[scheduler] policy = "edf"`` in the file): the EDF analysis instead
(rtsim.analysis.edf): the processor-demand criterion by QPA decides for the whole set, and
each task gets Spuri's (1996) response-time bound; suspensions count as CPU time.
"""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from rtsim.analysis.edf import EdfAnalysis, analyze_edf, edf_arrivals
from rtsim.analysis.rta import analyze
from rtsim.analysis.transaction import with_transaction_bounds
from rtsim.cli import one_line
from rtsim.cli._set import add_set_option, set_overrides
from rtsim.cli.common import add_force, add_json, add_quiet, add_suspension
from rtsim.config.taskset import load_taskset
from rtsim.errors import InputError
from rtsim.io.limits import check
from rtsim.io.work import check_work
from rtsim.sim.policy import SCHEDULERS

__all__ = ["register", "run", "format_analysis", "format_edf", "format_transaction", "json_safe"]


def register(sub: Any) -> None:
    """Add the ``analyze`` sub-command."""
    p = sub.add_parser(
        "analyze",
        help="exact response-time analysis of a task set",
        description=__doc__.splitlines()[0],
    )
    p.add_argument("file", metavar="FILE", help="task-set TOML file")

    add_json(p)
    add_quiet(p, "print nothing (the exit status with --check)")
    add_set_option(p)
    p.add_argument(
        "--check", action="store_true", help="exit with status 1 when the set is not schedulable"
    )
    p.add_argument(
        "--window",
        metavar="MS",
        default=None,
        help="window w in ms for a [window] set (default: w_sch)",
    )
    add_suspension(
        p,
        "radio round trip / suspensions: counted as CPU time (default, the "
        "paper's) or CPU free (suspension-aware bounds, docs/model/beyond.md)",
    )
    p.add_argument(
        "--overhead",
        metavar="MS",
        type=float,
        default=None,
        help="context-switch cost in ms: 2·O per higher-priority segment start, O per "
        "own segment, as simulate --overhead (default: the file's, or 0)",
    )
    p.add_argument(
        "--scheduler",
        metavar="NAME",
        default=None,
        help="a scheduling policy with an analysis: fp (exact response-time "
        "analysis) or edf (demand criterion and Spuri's bound); default: the "
        "file's [scheduler] policy",
    )
    add_force(
        p,
        "analyse even when the EDF bound would examine more than 1e6 "
        "arrivals (a busy period very long against the periods: minutes) or the "
        "offset-based (transaction) analysis evaluate more than 1e7 interference terms",
    )
    p.set_defaults(func=run)


def _window(text: str | None) -> float | None:
    if text is None:
        return None
    try:
        w = float(text)
    except ValueError:
        raise InputError(f"--window: cannot parse {text!r} as a number of ms") from None
    if not (math.isfinite(w) and w > 0):
        raise InputError(f"--window: must be a positive number of ms, got {text!r}")

    check("option: --window", w, "--window")
    return w


def _num(x: float | None, digits: int = 3) -> str:
    return "miss" if x is None else f"{x:.{digits}f}"


_RESOURCES = {
    "pcp": "blocking: immediate priority ceiling protocol (one section of a lower task whose "
    "resource's ceiling reaches the task), included in the WCRT",
    "srp": "blocking: stack resource policy (one section of a lower-level task whose "
    "resource's ceiling reaches the task), included in the WCRT",
    "npr": "blocking: non-preemptive critical sections (the longest section of a lower task), "
    "included in the WCRT",
}


def format_analysis(res: Any, source: str, w_from: str | None) -> str:
    """The readable report of an [`Analysis`][rtsim.analysis.rta.Analysis]."""
    lines = [f"task set: {one_line(res.name or '(unnamed)')}  ({one_line(source)})"]
    if res.w is not None:
        how = (
            "radio round trip counted as CPU time"
            if res.suspension == "cpu"
            else "radio round trip with the CPU idle (suspension-aware: each task the smaller "
            "of its sound bounds)"
        )
        lines.append(
            f"window: w = {res.w:.3f} ms ({w_from}); the chain is one task of cost g, " + how
        )
    names = {t.name: one_line(t.name) for t in res.tasks}  # escaped, as in error lines
    width = max(4, *(len(n) for n in names.values()))
    blk = getattr(res, "resources", None) is not None
    head = (
        f"{'prio':>5}  {'task':<{width}}  {'wcet':>9}  {'period':>9}  {'deadline':>9}  "
        f"{'util':>6}  " + (f"{'blocking':>9}  " if blk else "") + f"{'WCRT':>9}  schedulable"
    )
    lines += ["", head, "-" * len(head)]
    for t in res.tasks:
        lines.append(
            f"{t.priority:>5}  {names[t.name]:<{width}}  {t.wcet:>9.3f}  {t.period:>9.3f}  "
            f"{t.deadline:>9.3f}  {t.utilization:>6.4f}  "
            + (f"{t.blocking:>9.3f}  " if blk else "")
            + f"{_num(t.wcrt):>9}  "
            f"{'yes' if t.schedulable else 'NO'}"
        )
    if blk:
        lines.append(_RESOURCES[res.resources])
    if res.overhead:
        lines.append(
            f"context-switch overhead: {res.overhead:g} ms (2x per higher-priority "
            "segment start, 1x per own segment)"
        )
    if res.offsets_ignored:
        lines.append(
            "offsets: ignored (every task analysed as if released together; sound, "
            "possibly pessimistic)"
        )
    n = len(res.tasks)
    lines += ["", f"total utilization: {res.utilization:.4f} ({n} task{'s' * (n != 1)})"]
    if res.rm_implicit:
        lines.append(
            f"Liu-Layland: U <= n(2^(1/n) - 1) = {res.liu_layland_bound:.4f}: "
            f"{'passes' if res.liu_layland else 'not proven'}"
        )
        lines.append(
            f"hyperbolic: prod(U_i + 1) = {res.hyperbolic_product:.4f} <= 2: "
            f"{'passes' if res.hyperbolic else 'not proven'}"
        )
    else:
        lines.append(
            "Liu-Layland, hyperbolic: do not apply (need implicit deadlines and "
            "rate-monotonic priorities)"
        )
    lines.append(
        f"schedulable (exact response-time analysis): {'yes' if res.schedulable else 'NO'}"
    )
    return "\n".join(lines)


def format_edf(res: Any, source: str, w_from: str | None) -> str:
    """The readable report of an [`EdfAnalysis`][rtsim.analysis.edf.EdfAnalysis]."""
    lines = [f"task set: {one_line(res.name or '(unnamed)')}  ({one_line(source)}), scheduler: EDF"]
    if res.w is not None:
        lines.append(
            f"window: w = {res.w:.3f} ms ({w_from}); the chain is one task of cost g, "
            "radio round trip counted as CPU time (suspension-oblivious)"
        )
    names = {t.name: one_line(t.name) for t in res.tasks}  # escaped, as in error lines
    width = max(4, *(len(n) for n in names.values()))
    blk = getattr(res, "resources", None) is not None
    head = (
        f"{'task':<{width}}  {'wcet':>9}  {'period':>9}  {'deadline':>9}  {'jitter':>7}  "
        f"{'util':>6}  "
        + (f"{'blocking':>9}  " if blk else "")
        + f"{'WCRT':>9}  {'bound':>8}  meets D"
    )
    lines += ["", head, "-" * len(head)]
    for t in res.tasks:
        lines.append(
            f"{names[t.name]:<{width}}  {t.wcet:>9.3f}  {t.period:>9.3f}  {t.deadline:>9.3f}  "
            f"{t.jitter:>7.3f}  {t.utilization:>6.4f}  "
            + (f"{t.blocking:>9.3f}  " if blk else "")
            + f"{_num(t.wcrt):>9}  {t.bound:>8}  "
            f"{'yes' if t.schedulable else 'NO'}"
        )
    if blk:
        lines.append(_RESOURCES[res.resources] + "; the demand test adds Baker's B(t)")
    lines.append(
        "WCRT: Spuri's (1996) response-time bound under EDF, from arrival (bound: "
        "spuri); where his search does not close and the demand criterion accepts "
        "the set, the deadline D (bound: deadline)"
    )
    if res.overhead:
        lines.append(
            f"context-switch overhead: {res.overhead:g} ms (2x per compute stretch of every job)"
        )
    if res.offsets_ignored:
        lines.append("offsets: ignored (sound, possibly pessimistic)")
    lines += ["", f"total utilization: {res.utilization:.4f}"]
    if res.limit is None:
        lines.append(f"processor demand: decided by utilization ({res.limit_kind})")
    else:
        lines.append(
            f"processor demand h(t) <= t checked by QPA up to L = {res.limit:.3f} ms "
            f"({res.limit_kind}; {res.qpa_steps} steps)"
        )
    if res.failed_at is not None:
        lines.append(f"demand exceeds the time at t = {res.failed_at:.3f} ms")
    lines.append(
        f"schedulable (processor-demand criterion, the whole set): "
        f"{'yes' if res.schedulable else 'NO'}"
    )
    return "\n".join(lines)


def format_transaction(txn: dict[str, float | None]) -> str:
    """One line: each task's offset-based (transaction) bound, the least sound bound rtsim
    has for it under fixed priority (docs/analysis.md)."""
    parts = ", ".join(f"{one_line(name)} {_num(r)}" for name, r in txn.items())
    return f"offset-based (transaction) WCRT: {parts}"


def json_safe(obj: Any) -> Any:
    """Replace non-finite floats by None so the JSON has no NaN/Infinity tokens."""
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [json_safe(v) for v in obj]
    return obj


def run(args: argparse.Namespace) -> int:
    """Run the sub-command (InputError is reported by the caller)."""
    w = _window(args.window)
    ts = load_taskset(args.file, overrides=set_overrides(args))
    if w is not None and ts.window is None:
        raise InputError(f"{args.file}: --window: the task set has no [window]")
    if args.overhead is not None and not (math.isfinite(args.overhead) and args.overhead >= 0):
        raise InputError(f"--overhead: must be a non-negative number of ms, got {args.overhead:g}")
    if args.scheduler is not None:
        scheduler = args.scheduler
        policy = SCHEDULERS.resolve(scheduler, "--scheduler", allow_code=True)
    else:
        scheduler = ts.scheduler
        policy = SCHEDULERS.resolve(scheduler, f"{args.file}: [scheduler] policy")
    if policy.analysis is None:
        with_analysis = ", ".join(n for n, c in SCHEDULERS.items() if c.analysis is not None)
        raise InputError(
            f"{args.file}: [scheduler] policy {scheduler!r} has no analysis; "
            f"use --scheduler with one of {with_analysis}"
        )
    w_from = None if ts.window is None else ("--window" if w is not None else "w_sch")

    if policy.analysis is analyze_edf:  # Spuri's search over arrivals (the FP analysis stops
        # by itself: a deadline passed, or MAX_BUSY_JOBS jobs of one busy period)
        check_work(
            "arrivals",
            edf_arrivals(ts, w, args.overhead),
            str(ts.source or args.file),
            force=args.force,
        )
    res: Any = policy.analysis(ts, w, overhead=args.overhead, suspension=args.suspension)
    if isinstance(res, EdfAnalysis):
        text = format_edf(res, str(ts.source), w_from)
    else:
        text = format_analysis(res, str(ts.source), w_from)
        if policy.analysis is analyze:  # FP: the offset-based bound (as the library's)
            res = with_transaction_bounds(ts, res, force=args.force)
            if res.transaction is not None:
                head, _, last = text.rpartition("\n")  # before the verdict line
                text = f"{head}\n{format_transaction(dict(res.transaction))}\n{last}"
    if args.json:
        out = {"source": ts.source, "w_from": w_from, "scheduler": scheduler, **res.as_dict()}
        print(json.dumps(json_safe(out), indent=2, allow_nan=False))
    elif not args.quiet:
        print(text)
    return 1 if args.check and not res.schedulable else 0
