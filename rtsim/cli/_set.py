"""``--set KEY=VALUE``: change a key of the input file for one run, without editing it.

KEY is a dotted path as in a sweep's grid (``formation.followers``, ``tasks.command.wcet``,
``window.delta_t``, or a shortcut: a ``[window]`` key or a top-level key); VALUE is read as
a TOML value (``4``, ``2.5``, ``true``, ``inf``, ``[1, 2]``, ``"text"``), a bare word as a
string (``--set formation.model=follow-the-leader``). The changed file is checked by the
same model as the file itself, and the manifest records each ``--set`` as given.
"""

from __future__ import annotations

from typing import Any

from rtsim.config.dotted import parse_assignment

__all__ = ["add_set_option", "set_overrides", "set_strings"]

HELP = (
    "change a key of the input file: a dotted path as in a sweep's grid, the value read as "
    "TOML (a bare word as text); repeatable, e.g. --set formation.followers=4"
)


def add_set_option(parser: Any, help: str = HELP) -> None:
    """Add ``--set KEY=VALUE`` (repeatable) to ``parser``."""
    parser.add_argument(
        "--set", dest="set", action="append", default=[], metavar="KEY=VALUE", help=help
    )


def set_strings(args: Any) -> list[str]:
    """The ``--set`` options as given (for the manifest)."""
    return list(getattr(args, "set", None) or [])


def set_overrides(args: Any) -> dict[str, Any]:
    """The ``--set`` options as dotted path → value (a key given twice: the last wins)."""
    return dict(parse_assignment(text) for text in set_strings(args))
