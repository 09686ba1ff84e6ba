"""``rtsim analyze FILE [--json] [--check] [--window W]``: exact response-time analysis.

Per task: priority, wcet, period, deadline, utilization, worst-case response time (exact,
fixed-point iteration) and the verdict; then the total utilization, the Liu–Layland and
hyperbolic tests, and the verdict for the set. A processing-window set is analysed at
``--window`` (default: the analytic w_sch), its chain counted as one task of cost g with the
radio round trip as CPU time. The exit status is 0 whatever the verdict; with ``--check`` it
is 1 when the set is not schedulable.
"""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from rtsim.errors import InputError

__all__ = ["register", "run", "format_analysis", "json_safe"]


def register(sub: Any) -> None:
    """Add the ``analyze`` sub-command."""
    p = sub.add_parser("analyze", help="exact response-time analysis of a task set",
                       description=__doc__.splitlines()[0])
    p.add_argument("file", metavar="FILE", help="task-set TOML file")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--check", action="store_true",
                   help="exit with status 1 when the set is not schedulable")
    p.add_argument("--window", metavar="MS", default=None,
                   help="window w in ms for a [window] set (default: w_sch)")
    p.add_argument("--suspension", choices=("cpu", "idle"), default="cpu",
                   help="radio round trip / suspensions: counted as CPU time (default, the "
                        "paper's) or CPU free (suspension-aware bounds, SPEC §8)")
    p.add_argument("--overhead", metavar="MS", type=float, default=None,
                   help="context-switch cost in ms: 2·O per higher-priority segment start, O per "
                        "own segment, as simulate --overhead (default: the file's, or 0)")
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
    from rtsim.io.limits import check

    check("option: --window", w, "--window")
    return w


def _num(x: float | None, digits: int = 3) -> str:
    return "miss" if x is None else f"{x:.{digits}f}"


def format_analysis(res: Any, source: str, w_from: str | None) -> str:
    """The readable report of an :class:`~rtsim.analysis.rta.Analysis`."""
    lines = [f"task set: {res.name or '(unnamed)'}  ({source})"]
    if res.w is not None:
        how = ("radio round trip counted as CPU time" if res.suspension == "cpu" else
               "radio round trip with the CPU idle (suspension-aware: each task the smaller "
               "of its sound bounds)")
        lines.append(f"window: w = {res.w:.3f} ms ({w_from}); the chain is one task of cost g, "
                     + how)
    width = max(4, *(len(t.name) for t in res.tasks))
    head = (f"{'prio':>5}  {'task':<{width}}  {'wcet':>9}  {'period':>9}  {'deadline':>9}  "
            f"{'util':>6}  {'WCRT':>9}  schedulable")
    lines += ["", head, "-" * len(head)]
    for t in res.tasks:
        lines.append(
            f"{t.priority:>5}  {t.name:<{width}}  {t.wcet:>9.3f}  {t.period:>9.3f}  "
            f"{t.deadline:>9.3f}  {t.utilization:>6.4f}  {_num(t.wcrt):>9}  "
            f"{'yes' if t.schedulable else 'NO'}"
        )
    if res.overhead:
        lines.append(f"context-switch overhead: {res.overhead:g} ms (2x per higher-priority "
                     "segment start, 1x per own segment)")
    if res.offsets_ignored:
        lines.append("offsets: ignored (every task analysed as if released together; sound, "
                     "possibly pessimistic)")
    n = len(res.tasks)
    lines += ["", f"total utilization: {res.utilization:.4f} ({n} task{'s' * (n != 1)})"]
    if res.rm_implicit:
        lines.append(f"Liu-Layland: U <= n(2^(1/n) - 1) = {res.liu_layland_bound:.4f}: "
                     f"{'passes' if res.liu_layland else 'not proven'}")
        lines.append(f"hyperbolic: prod(U_i + 1) = {res.hyperbolic_product:.4f} <= 2: "
                     f"{'passes' if res.hyperbolic else 'not proven'}")
    else:
        lines.append("Liu-Layland, hyperbolic: do not apply (need implicit deadlines and "
                     "rate-monotonic priorities)")
    lines.append(f"schedulable (exact response-time analysis): "
                 f"{'yes' if res.schedulable else 'NO'}")
    return "\n".join(lines)


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
    from rtsim.analysis.rta import analyze
    from rtsim.io.taskset import load_taskset

    w = _window(args.window)
    ts = load_taskset(args.file)
    if w is not None and ts.window is None:
        raise InputError(f"{args.file}: --window: the task set has no [window]")
    if args.overhead is not None and not (math.isfinite(args.overhead) and args.overhead >= 0):
        raise InputError(f"--overhead: must be a non-negative number of ms, got {args.overhead:g}")
    res = analyze(ts, w, overhead=args.overhead, suspension=args.suspension)
    w_from = None if ts.window is None else ("--window" if w is not None else "w_sch")
    if args.json:
        out = {"source": ts.source, "w_from": w_from, **res.as_dict()}
        print(json.dumps(json_safe(out), indent=2, allow_nan=False))
    else:
        print(format_analysis(res, str(ts.source), w_from))
    return 1 if args.check and not res.schedulable else 0
