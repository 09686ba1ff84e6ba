"""``rtsim schema taskset|scenario|sweep``: print the JSON Schema of an input file kind.

The schema is generated from the same models that check the files when rtsim reads them
(keys, types, ranges and units), so an editor that validates TOML against it (add
``#:schema FILE`` as a file's first line, with Taplo or Even Better TOML) flags the same
mistakes. The package ships them too: ``rtsim/data/schemas/<kind>.json``.
"""

from __future__ import annotations

import sys
from typing import Any

from rtsim.cli.common import add_json, add_quiet
from rtsim.config.schema import KINDS, schema_text

__all__ = ["register", "run"]


def register(sub: Any) -> None:
    """Add the ``schema`` sub-command."""
    p = sub.add_parser(
        "schema",
        help="print the JSON Schema of task-set, scenario or sweep files",
        description=__doc__.splitlines()[0],
    )
    p.add_argument("kind", choices=KINDS, help="the kind of file: " + ", ".join(KINDS))

    add_json(p, "print the schema (one JSON object, with or without this option)")
    add_quiet(p, "print nothing (only check that the kind exists)")
    p.set_defaults(func=run)


def run(args: Any) -> int:
    """Print the schema to stdout."""
    if args.json or not args.quiet:
        sys.stdout.write(schema_text(args.kind))
    return 0
