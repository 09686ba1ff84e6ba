"""``rtsim sweep SPEC.toml --out DIR [--workers N] [--dask ADDRESS] [--restart] [--force]``.

Exit status: 0 when every point is ok, 1 when any point failed (or workers were lost),
2 for a bad sweep file, a changed sweep file without ``--restart``, a grid above the size
limit without ``--force`` or an output directory another sweep is using, 130 on Ctrl-C
(``rtsim: interrupted``) and 143 on SIGTERM (``rtsim: terminated``): the workers are stopped
and joined with timeouts, finished points kept, and the same command resumes.
"""

from __future__ import annotations

import argparse
import signal
import sys
from types import FrameType
from typing import Any

from rtsim.cli import Terminated
from rtsim.cli._set import add_set_option, set_strings
from rtsim.cli.common import add_force, add_json, add_quiet, add_workers, progress_enabled
from rtsim.io.atomic import dumps

__all__ = ["register", "run"]


def register(subparsers: Any) -> None:
    """Add the ``sweep`` sub-command."""
    p = subparsers.add_parser(
        "sweep",
        help="run a parameter sweep (resumable; local processes or a Dask cluster)",
        description="Run every point of a sweep file; results go to DIR/results.parquet. "
        "Running the same command again resumes an interrupted sweep.",
    )
    p.add_argument("spec", metavar="FILE", help="the sweep file")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    add_workers(
        p, "run the points on an existing dask.distributed scheduler (needs the extra rtsim[dask])"
    )
    p.add_argument(
        "--restart",
        action="store_true",
        help="discard the results already in DIR (needed when the sweep file changed)",
    )
    p.add_argument(
        "--retry-failed",
        action="store_true",
        help="recompute the points that failed in an earlier run",
    )
    add_force(p, "run a grid above the size limit (1e5 points)")

    add_json(p, "print the summary (points run, skipped, failed) as one JSON object")
    add_quiet(p, "no progress bar, no summary")
    add_set_option(
        p,
        help="change a key of the sweep's base file at every point, as "
        "[sweep.set] does (over it): a dotted path, the value read as TOML; "
        "repeatable",
    )
    p.set_defaults(func=run)


def _sigterm(signum: int, frame: FrameType | None) -> None:
    raise Terminated  # "rtsim: terminated", exit 143 (docs/reliability.md)


#: After an interrupt's cleanup, how long other threads get to end before the command
#: leaves without waiting for them (s).
GRACE_S = 1.0


def _leave_if_stuck(exc: KeyboardInterrupt) -> None:
    """After the interrupt path's cleanup, leave at once (``os._exit``) when a thread did
    not end: a stopped pool's manager thread (`rtsim.sweep.engine.STUCK`) or any other
    non-daemon thread (one a point's code started, say) given `GRACE_S` to end. The
    interpreter's exit would wait for them without a timeout."""
    import os
    import threading
    import time

    from rtsim.sweep.engine import STUCK  # lazy: CLI start-up (rtsim.sweep, ~27 ms)

    me = threading.current_thread()
    others = [t for t in threading.enumerate() if t is not me and not t.daemon]
    deadline = time.monotonic() + GRACE_S
    for t in others:
        t.join(max(0.0, deadline - time.monotonic()))
    if not any(t.is_alive() for t in [*STUCK, *others]):
        return
    term = isinstance(exc, Terminated)
    print(f"rtsim: {'terminated' if term else 'interrupted'}", file=sys.stderr)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(143 if term else 130)


def run(args: argparse.Namespace) -> int:
    """Run the sweep; see the module docstring for the exit status."""
    from rtsim.sweep.engine import (  # lazy: CLI start-up (rtsim.sweep, ~27 ms)
        Sweep,
        SweepIncomplete,
    )
    from rtsim.sweep.spec import load_sweep  # lazy: CLI start-up (rtsim.sweep, ~27 ms)

    sweep = Sweep(load_sweep(args.spec, set_=set_strings(args)), args.out, force=args.force)
    previous = signal.signal(signal.SIGTERM, _sigterm)
    try:
        outcome = sweep.run(
            workers=args.workers,
            dask=args.dask,
            progress=progress_enabled(args),
            restart=args.restart,
            retry_failed=args.retry_failed,
            argv=sys.argv,
        )
    except SweepIncomplete as exc:
        print(f"rtsim: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as exc:  # cleaned up: the workers stopped, the lock released
        _leave_if_stuck(exc)
        raise
    finally:
        signal.signal(signal.SIGTERM, previous)
    df = outcome.table
    failed = int((df["status"] == "failed").sum())
    results = outcome.out_dir / "results.parquet"
    if args.json:
        print(
            dumps(
                {
                    "points": len(df),
                    "computed": outcome.computed,
                    "skipped": outcome.skipped,
                    "failed": failed,
                    "results": str(results),
                    "errors": [str(e) for e in df.loc[df["status"] == "failed", "error"]],
                }
            )
        )
    elif not args.quiet:
        print(
            f"sweep: {len(df)} points ({outcome.computed} run now, {outcome.skipped} "
            f"already done), {failed} failed -> {results}"
        )
    if not args.quiet:
        for err in df.loc[df["status"] == "failed", "error"].head(3):
            print(f"rtsim: failed point: {err}", file=sys.stderr)
    return 1 if failed else 0
