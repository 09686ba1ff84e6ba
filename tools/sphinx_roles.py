"""Rewrite Sphinx roles in docstrings and ``#:`` comments into what the API pages render.

MkDocs' mkdocstrings shows a Sphinx role (``:class:`~rtsim.x.Y```) literally. This tool
rewrites each role:

- into a cross-reference, ``[`Y`][rtsim.x.Y]``, when its target is an object the site
  renders (listed in the built site's ``objects.inv``; a relative target is tried inside the
  module being rewritten too) — mkdocs-autorefs turns it into a link;
- else into plain code, ``` `Y` ```.

A ``~`` prefix shows the last component only, as Sphinx does. Roles: ``class``, ``func``,
``meth``, ``data``, ``mod``, ``attr``, ``exc``, ``obj``.

    python tools/sphinx_roles.py --inventory site/objects.inv rtsim/   # rewrite in place
    python tools/sphinx_roles.py --check rtsim/                        # list what is left

Only the standard library is used.
"""

from __future__ import annotations

import argparse
import re
import sys
import zlib
from collections.abc import Iterable
from pathlib import Path

ROLES = ("class", "func", "meth", "data", "mod", "attr", "exc", "obj")
#: ``:role:`target``` or ``:role:`~target```; a target broken over two lines counts too
ROLE = re.compile(r":(?:py:)?(" + "|".join(ROLES) + r"):`(~?)([^`]+?)`")


def read_inventory(path: str | Path) -> set[str]:
    """The identifiers of a Sphinx-format ``objects.inv`` (as mkdocstrings writes it)."""
    raw = Path(path).read_bytes()
    lines = raw.split(b"\n", 4)  # four header lines, then the zlib-compressed body
    body = zlib.decompress(lines[4]).decode("utf-8")
    return {line.split(" ", 1)[0] for line in body.splitlines() if line.strip()}


def module_of(path: Path, root: Path) -> str:
    """``rtsim/io/scenario.py`` → ``rtsim.io.scenario`` (a package's ``__init__``: itself)."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def rewrite(text: str, known: set[str], module: str = "") -> str:
    """``text`` with every role rewritten (module doc); ``known``: the rendered identifiers,
    ``module``: the dotted name of the file's module, for relative targets."""

    def one(m: re.Match[str]) -> str:
        tilde, target = m.group(2), re.sub(r"\s+", "", m.group(3))  # a broken line joined
        bare = target.lstrip(".")
        title = bare.rsplit(".", 1)[-1] if tilde else bare
        candidates = [bare]
        if module:
            candidates += [f"{module}.{bare}"]
            package = module.rsplit(".", 1)[0]
            candidates += [f"{package}.{bare}"]
        for c in candidates:
            if c in known:
                return f"[`{title}`][{c}]"
        return f"`{title}`"

    return ROLE.sub(one, text)


#: Lines a rewrite made longer than this are wrapped (the project's line length).
WIDTH = 100
_LEAD = re.compile(r"^(\s*(?:#: |# )?)")


def wrap(line: str, width: int = WIDTH) -> list[str]:
    """``line`` broken at spaces into lines of at most ``width`` (where it can be), each
    continuation with the first line's indentation and comment marker (``#:``, ``#``)."""
    lead = _LEAD.match(line).group(1)  # type: ignore[union-attr]
    out = []
    while len(line) > width:
        cut = line.rfind(" ", len(lead) + 1, width + 1)
        if cut <= len(lead):
            break
        out.append(line[:cut].rstrip())
        line = lead + line[cut + 1 :].lstrip()
    return [*out, line]


def rewrite_file(text: str, known: set[str], module: str = "", width: int = WIDTH) -> str:
    """:func:`rewrite` line by line; a line it made longer than ``width`` is wrapped. A role
    broken over two lines is joined onto the first."""
    text = re.sub(  # the next line joins the first (wrapped again below when too long)
        r"(:(?:py:)?(?:" + "|".join(ROLES) + r"):`~?[^`\n]*)\n\s*(?:#:?\s*)?([^`\n]*`)",
        r"\1\2",
        text,
    )
    out = []
    for line in text.split("\n"):
        new = rewrite(line, known, module)
        out += wrap(new, width) if new != line and len(new) > width else [new]
    return "\n".join(out)


def files(paths: Iterable[str]) -> list[Path]:
    out: list[Path] = []
    for p in map(Path, paths):
        out += sorted(p.rglob("*.py")) if p.is_dir() else [p]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("paths", nargs="+", help="files or directories (*.py)")
    ap.add_argument("--inventory", help="the built site's objects.inv (targets to link)")
    ap.add_argument("--check", action="store_true", help="list the roles left; exit 1 if any")
    args = ap.parse_args(argv)
    if args.check:
        left = [
            f"{f}:{f.read_text('utf-8').count(chr(10), 0, m.start()) + 1}: {m.group(0)}"
            for f in files(args.paths)
            for m in ROLE.finditer(f.read_text("utf-8"))
        ]
        print("\n".join(left))
        return 1 if left else 0
    known = read_inventory(args.inventory) if args.inventory else set()
    changed = 0
    for f in files(args.paths):
        root = next((p for p in f.parents if not (p / "__init__.py").exists()), f.parent)
        text = f.read_text("utf-8")
        new = rewrite_file(text, known, module_of(f, root))
        if new != text:
            f.write_text(new, encoding="utf-8")
            changed += 1
    print(f"{changed} files rewritten", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
