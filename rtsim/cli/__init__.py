"""The ``rtsim`` command line: the only place that parses options.

Each sub-command lives in its own module ``rtsim.cli.<name>`` with a function
``register(subparsers)`` that adds its parser and sets ``func(args) -> int``.
Input errors, and files that cannot be read or written, print one line,
``rtsim: <message>``, and exit 2; no traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from rtsim.errors import InputError

__all__ = ["main", "COMMANDS"]

#: Sub-commands, in the order ``rtsim --help`` lists them.
COMMANDS: tuple[str, ...] = (
    "analyze",
    "bounds",
    "simulate",
    "generate",
    "scenario",
    "sweep",
    "validate",
    "histogram",
    "examples",
)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every available sub-command registered."""
    from rtsim import __version__

    parser = argparse.ArgumentParser(
        prog="rtsim",
        description="Real-time scheduling simulator for dynamic processing windows "
        "(Qadi, Goddard, Huang & Farritor).",
    )
    parser.add_argument("--version", action="version", version=f"rtsim {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMANDS:
        importlib.import_module(f"rtsim.cli.{name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``rtsim`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except InputError as exc:
        print(f"rtsim: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into head, say
        return 0
    except OSError as exc:  # an output path that cannot be written, a full disk, ...
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"rtsim: {where}{exc.strerror or exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("rtsim: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
