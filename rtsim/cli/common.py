"""Options the sub-commands share, added one way: ``-q/--quiet``, ``--json``, ``--out``,
``--format``/``--dpi``, a simulation's ``--exec``, ``--suspension`` and window set
(`add_simulation`), ``--workers``/``--dask`` and ``--force``; and the progress bar.

The conventions they keep (tests/cli/test_conventions.py checks them per command):

- results go to standard output (a table, a summary line, the files written, or one JSON
  object with ``--json``), diagnostics to standard error (progress, notes, errors);
- ``-q`` prints nothing but errors — no progress, no notes, no text summary — except what
  ``--json`` asks for;
- every command that writes files takes ``--out``; every command that prints a result
  takes ``--json``; every command that draws takes ``--format`` and ``--dpi``.

Progress bars (``tqdm.auto``) go to standard error when it is a terminal, never with ``-q``;
``RTSIM_PROGRESS=1`` forces them on (``0``: off) whatever standard error is.
"""

from __future__ import annotations

import os
import sys
from typing import Any

from rtsim.cli import one_line
from rtsim.errors import InputError
from rtsim.sim.progress import SimulationBar
from rtsim.sim.progress import progress_enabled as enabled

__all__ = [
    "FIGURE_FORMATS",
    "ANIMATION_FORMATS",
    "add_quiet",
    "add_json",
    "add_figure_options",
    "add_force",
    "add_exec",
    "add_suspension",
    "add_simulation",
    "add_workers",
    "figure_format",
    "progress_enabled",
    "simulation_bar",
    "note",
]

#: Formats of the commands that draw figures (raster PNG, or vector SVG and PDF for papers).
FIGURE_FORMATS: tuple[str, ...] = ("png", "svg", "pdf")
#: Formats of ``rtsim animate``.
ANIMATION_FORMATS: tuple[str, ...] = ("gif", "mp4", "html")


def add_quiet(p: Any, what: str = "no progress bar, no notes on stderr") -> None:
    """``-q/--quiet``."""
    p.add_argument("--quiet", "-q", action="store_true", help=what)


def add_json(p: Any, what: str = "print the result as one JSON object") -> None:
    """``--json``: the result on standard output as one JSON object instead of text."""
    p.add_argument("--json", action="store_true", help=what)


def add_force(p: Any, what: str = "run even when a value looks like a mistake of unit") -> None:
    """``--force``: run past a limit or a plausibility check (``what``: which)."""
    p.add_argument("--force", action="store_true", help=what)


def add_exec(
    p: Any, what: str = "execution times: wcet (default) or uniform in [bcet, wcet]"
) -> None:
    """``--exec wcet|uniform`` (``args.exec_model``)."""
    p.add_argument(
        "--exec", dest="exec_model", choices=("wcet", "uniform"), default="wcet", help=what
    )


def add_suspension(
    p: Any, what: str = "radio round trip: counted as CPU time (default) or CPU free"
) -> None:
    """``--suspension cpu|idle``."""
    p.add_argument("--suspension", choices=("cpu", "idle"), default="cpu", help=what)


def add_simulation(p: Any) -> None:
    """A simulation's ``--exec`` and ``--suspension``, and ``--followers``,
    ``--hough-radius`` and ``--window`` for a processing-window set."""
    add_exec(p)
    add_suspension(p)
    p.add_argument("--followers", type=int, help="n, for a processing-window set")
    p.add_argument("--hough-radius", type=float, help="r_H in cm, for a processing-window set")
    p.add_argument("--window", type=float, help="fixed window w in ms (default w_sch)")


def add_workers(p: Any, dask: str | None = None) -> None:
    """``--workers`` and, with ``dask`` (its help), ``--dask``."""
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="local worker processes (default: the CPU count; 1 = in this process)",
    )
    if dask is not None:
        p.add_argument("--dask", default=None, metavar="ADDRESS", help=dask)


def add_figure_options(
    p: Any,
    *,
    default_dpi: int,
    formats: tuple[str, ...] = FIGURE_FORMATS,
    what: str = "figures",
    default: str | None = None,
) -> None:
    """``--format`` (dest ``fig_format``; default: a named file's suffix, else the first of
    ``formats``; ``default`` says so in the help) and ``--dpi`` (raster resolution)."""
    vector = [f for f in formats if f in ("svg", "pdf")]
    tail = f"; {' and '.join(vector)} are vector" if vector else ""
    p.add_argument(
        "--format",
        dest="fig_format",
        choices=formats,
        default=None,
        help=f"file format of the {what}: {', '.join(formats)} (default "
        f"{default or formats[0]}{tail})",
    )
    p.add_argument(
        "--dpi",
        type=int,
        default=None,
        help=f"resolution of raster {what} in dots per inch (default {default_dpi})",
    )


def check_suffix(
    path: str | os.PathLike[str] | None, option: str, suffixes: tuple[str, ...]
) -> None:
    """Refuse an output file whose suffix does not name the format written there (one of
    ``suffixes``, e.g. ``(".json",)``): a file's name says what it holds."""
    from pathlib import Path

    if path is None:
        return
    suffix = Path(path).suffix.lower()
    if suffix not in suffixes:
        got = f"ends in {suffix}" if suffix else "has no suffix"
        raise InputError(
            f"{option} {os.fsdecode(path)}: {got}, but it is written as "
            f"{' or '.join(s.lstrip('.') for s in suffixes)}; give a file ending in "
            f"{' or '.join(suffixes)}"
        )


def figure_format(
    args: Any,
    path: str | os.PathLike[str] | None = None,
    option: str = "--out",
    formats: tuple[str, ...] = FIGURE_FORMATS,
) -> str:
    """The format to write: ``--format``, else the suffix of ``path`` (a file the user
    named) when it is one of ``formats``, else the first of ``formats``. A ``--format``
    that contradicts the named file's suffix, and a suffix that is none of ``formats``
    (``--gantt g.csv`` would be a PNG named .csv), are input errors."""
    from pathlib import Path

    given = getattr(args, "fig_format", None)
    suffix = Path(path).suffix.lstrip(".").lower() if path is not None else ""
    if suffix:
        check_suffix(path, option, tuple(f".{f}" for f in formats))
    if given is not None:
        if suffix in formats and suffix != given:
            raise InputError(
                f"{option} {path}: ends in .{suffix} but --format is {given}; "
                f"give one of them, or a file ending in .{given}"
            )
        return str(given)
    return suffix if suffix in formats else formats[0]


def progress_enabled(args: Any) -> bool:
    """Whether to show progress bars (`rtsim.sim.progress.progress_enabled`)."""
    return enabled(args)


def simulation_bar(args: Any, desc: str) -> Any:
    """The progress bar of one simulation run (`rtsim.sim.progress.SimulationBar`)."""
    return SimulationBar(args, desc)


def note(args: Any, text: str) -> None:
    """A diagnostic line on standard error (``rtsim: <text>``), unless ``-q``."""
    if not getattr(args, "quiet", False):
        print(f"rtsim: {one_line(text)}", file=sys.stderr)
