"""``rtsim animate RUN_DIR --out FILE``: a scenario run as an animation (GIF, MP4 or HTML).

One frame per processing window: the robots (truth filled, the leader's estimates hollow),
the laser beams that hit each follower, each Hough window (red when the window is critical),
and below a Gantt strip of the current and the previous window with w and w_sch drawn.
RUN_DIR is an output directory of rtsim scenario. MP4 needs ffmpeg (or pip install
imageio-ffmpeg); GIF and HTML need nothing more.
"""

from __future__ import annotations

from typing import Any

from rtsim.cli.common import (
    ANIMATION_FORMATS,
    add_figure_options,
    add_json,
    add_quiet,
    figure_format,
    progress_enabled,
)
from rtsim.sim.progress import progress_bar

__all__ = ["register", "run"]


def register(sub: Any) -> None:
    """Add the ``animate`` sub-command."""
    p = sub.add_parser(
        "animate",
        help="animate a scenario run (robots, laser, schedule)",
        description=__doc__.splitlines()[0],
    )
    p.add_argument("run_dir", metavar="DIR", help="an output directory of rtsim scenario")
    p.add_argument(
        "--out",
        required=True,
        metavar="FILE",
        help="the animation: .gif, .mp4 or .html (by the suffix)",
    )
    p.add_argument(
        "--start",
        type=float,
        default=None,
        metavar="SECONDS",
        help="first simulated second shown (default: the run's start)",
    )
    p.add_argument(
        "--end",
        type=float,
        default=None,
        metavar="SECONDS",
        help="last simulated second shown (default: the run's end)",
    )
    p.add_argument(
        "--fps",
        type=int,
        default=10,
        metavar="N",
        help="frames (windows) per second of animation (default 10)",
    )
    p.add_argument(
        "--every",
        type=int,
        default=1,
        metavar="N",
        help="draw every N-th window only (default 1: every window)",
    )

    add_figure_options(
        p,
        default_dpi=80,
        formats=ANIMATION_FORMATS,  # rtsim.animate's
        what="animation",
        default="the suffix of --out",
    )
    add_json(p, "print the file written as one JSON object")
    add_quiet(p, "no progress bar, no name of the file written")
    p.set_defaults(func=run)


def run(args: Any) -> int:
    """Render the animation (see the module docstring)."""
    from rtsim.animate import animate_run  # lazy: CLI start-up (pandas)

    figure_format(args, args.out, "--out", ANIMATION_FORMATS)  # --format agrees with --out
    bar: Any = None

    def progress(i: int, total: int) -> None:
        nonlocal bar
        if not progress_enabled(args):
            return
        if bar is None:
            bar = progress_bar(args, total=total, desc="animate", unit="frame")
        bar.update(1)

    try:
        path = animate_run(
            args.run_dir,
            args.out,
            start_s=args.start,
            end_s=args.end,
            fps=args.fps,
            every=args.every,
            progress=progress,
            dpi=args.dpi or 80,
        )
    finally:
        if bar is not None:
            bar.close()
    if args.json:
        import json

        print(json.dumps({"out": str(path)}))
    elif not args.quiet:
        print(path)
    return 0
