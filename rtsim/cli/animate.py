"""``rtsim animate RUN_DIR --out FILE``: a scenario run as an animation (GIF, MP4 or HTML).

One frame per processing window: the robots (truth filled, the leader's estimates hollow),
the laser beams that hit each follower, each Hough window (red when the window is critical),
and below a Gantt strip of the current and the previous window with w and w_sch drawn.
RUN_DIR is an output directory of rtsim scenario. MP4 needs ffmpeg (or pip install
imageio-ffmpeg); GIF and HTML need nothing more.
"""

from __future__ import annotations

import sys
from typing import Any

__all__ = ["register", "run"]


def register(sub: Any) -> None:
    """Add the ``animate`` sub-command."""
    p = sub.add_parser("animate", help="animate a scenario run (robots, laser, schedule)",
                       description=__doc__.splitlines()[0])
    p.add_argument("run_dir", metavar="DIR", help="an output directory of rtsim scenario")
    p.add_argument("--out", required=True, metavar="FILE",
                   help="the animation: .gif, .mp4 or .html (by the suffix)")
    p.add_argument("--start", type=float, default=None, metavar="SECONDS",
                   help="first simulated second shown (default: the run's start)")
    p.add_argument("--end", type=float, default=None, metavar="SECONDS",
                   help="last simulated second shown (default: the run's end)")
    p.add_argument("--fps", type=int, default=10, metavar="N",
                   help="frames (windows) per second of animation (default 10)")
    p.add_argument("--every", type=int, default=1, metavar="N",
                   help="draw every N-th window only (default 1: every window)")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args: Any) -> int:
    """Render the animation (see the module docstring)."""
    from rtsim.animate import animate_run

    bar: Any = None

    def progress(i: int, total: int) -> None:
        nonlocal bar
        if args.quiet:
            return
        if bar is None:
            from tqdm.auto import tqdm

            bar = tqdm(total=total, desc="animate", unit="frame", file=sys.stderr,
                       disable=not sys.stderr.isatty())
        bar.update(1)

    try:
        path = animate_run(args.run_dir, args.out, start_s=args.start, end_s=args.end,
                           fps=args.fps, every=args.every, progress=progress)
    finally:
        if bar is not None:
            bar.close()
    if not args.quiet:
        print(f"rtsim: animate: -> {path}", file=sys.stderr)
    return 0
