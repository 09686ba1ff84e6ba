"""``rtsim examples [NAME]``: list the example files shipped with rtsim, or print one.

Each name works wherever a file is expected (when no file of that name exists):
``rtsim analyze example``, ``rtsim scenario test2 --out DIR``, ``rtsim sweep smoke --out DIR``.
Print one to start your own: ``rtsim examples test2 > my_scenario.toml``.
"""

from __future__ import annotations

from typing import Any

from rtsim.cli.common import add_json, add_quiet
from rtsim.examples import EXAMPLES, example

__all__ = ["register", "run"]


def register(sub: Any) -> None:
    """Add the ``examples`` sub-command."""
    p = sub.add_parser(
        "examples",
        help="list the shipped example files, or print one",
        description=__doc__.splitlines()[0],
    )
    p.add_argument("name", nargs="?", metavar="NAME", help="print this example's file")

    add_json(p, "list the examples (or give the one named: name, kind, summary, text) as JSON")
    add_quiet(p, "print nothing (a check that the example exists)")
    p.set_defaults(func=run)


def run(args: Any) -> int:
    """List the examples, or print the one named."""
    if args.json:
        import json

        def entry(ex: Any, text: bool) -> dict[str, Any]:
            d = {"name": ex.name, "kind": ex.kind, "summary": ex.summary}
            return {**d, "text": ex.text()} if text else d

        obj: Any = (
            entry(example(args.name), True)
            if args.name
            else [entry(ex, False) for ex in EXAMPLES.values()]
        )
        print(json.dumps(obj, indent=2))
        return 0
    if args.quiet:
        if args.name:
            example(args.name)
        return 0
    if args.name:
        print(example(args.name).text(), end="")
        return 0
    width = max(len(n) for n in EXAMPLES)
    for ex in EXAMPLES.values():
        print(f"{ex.name:<{width}}  {ex.kind:<8}  {ex.summary}")
    return 0
