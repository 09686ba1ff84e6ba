"""MkDocs hooks for rtsim's site (mkdocs.yml ``hooks:``).

Every page under docs/ is in the site's navigation: a page that mkdocs.yml's ``nav`` does not
list is appended under "More", titled by its first heading, so a page added by anyone is never
an orphan (the nav is kept tidy by hand; this is the safety net).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

SKIP_DIRS = {"figures", "_hooks"}


def _listed(nav: Any) -> set[str]:
    out: set[str] = set()
    if isinstance(nav, str):
        out.add(nav)
    elif isinstance(nav, list):
        for item in nav:
            out |= _listed(item)
    elif isinstance(nav, dict):
        for value in nav.values():
            out |= _listed(value)
    return out


def _title(path: Path) -> str:
    if path.suffix == ".md":
        for line in path.read_text(encoding="utf-8").splitlines():
            m = re.match(r"#\s+(.+)", line)
            if m:
                return m.group(1).strip()
    return path.stem.replace("_", " ").replace("-", " ").capitalize()


def on_config(config: Any, **_: Any) -> Any:
    docs = Path(config["docs_dir"])
    nav = config.get("nav")
    if not nav:
        return config
    listed = _listed(nav)
    extra = []
    for path in sorted(docs.rglob("*")):
        rel = path.relative_to(docs).as_posix()
        if (
            path.suffix not in (".md", ".ipynb")
            or rel in listed
            or SKIP_DIRS & set(rel.split("/")[:-1])
        ):
            continue
        extra.append({_title(path): rel})
    if extra:
        nav.append({"More": extra})
    return config


#: The paper's symbols as the pages write them (docs/glossary.md explains each): a page that
#: uses one and does not link the glossary gets a line pointing to it.
SYMBOLS = re.compile(r"(?<![\w`])(?:r_H|w_sch|ρ_d|V_Ld|T_ρ|T_ε|e_hough|MSBs?|β_d|r_F)(?![\w])")
GLOSSARY = "glossary.md"


def glossary_line(markdown: str, src_uri: str) -> str:
    """``markdown`` with a pointer to the glossary appended when it uses the paper's symbols
    and links no glossary (``src_uri``: the page's path under docs/)."""
    if src_uri == GLOSSARY or GLOSSARY in markdown or not SYMBOLS.search(markdown):
        return markdown
    if src_uri.endswith(".ipynb"):
        return markdown
    up = "../" * src_uri.count("/")
    return (
        markdown.rstrip("\n")
        + f"\n\n---\n\n*Symbols* (n, r_H, w_sch, ρ_d, MSB …): the [glossary]({up}{GLOSSARY}).\n"
    )


def on_page_markdown(markdown: str, page: Any, **_: Any) -> str:
    return glossary_line(markdown, page.file.src_uri)
