"""The first hour's paper cuts, each pinned (issue 34, item 6): the navigation, the site's
folder, files that are not tracked, CHANGELOG and CONTRIBUTING, the glossary linked from every
page that uses the paper's symbols, and the getting-started sweep page's promises."""

from __future__ import annotations

import importlib.util
import subprocess
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]


def _hooks():  # type: ignore[no-untyped-def]
    spec = importlib.util.spec_from_file_location("docs_hooks", ROOT / "tools" / "docs_hooks.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _mkdocs() -> dict:
    class Loader(yaml.SafeLoader):
        pass

    Loader.add_multi_constructor("", lambda *_: None)  # the !!python tags of plug-ins
    return yaml.load((ROOT / "mkdocs.yml").read_text("utf-8"), Loader=Loader)


def _pages(nav: object) -> list[str]:
    if isinstance(nav, str):
        return [nav]
    if isinstance(nav, list):
        return [p for item in nav for p in _pages(item)]
    if isinstance(nav, dict):
        return [p for v in nav.values() for p in _pages(v)]
    return []


def test_no_page_is_twice_in_the_navigation() -> None:
    pages = _pages(_mkdocs()["nav"])
    twice = sorted({p for p in pages if pages.count(p) > 1})
    assert not twice, twice
    assert "glossary.md" in pages


def test_the_site_builds_into_site_not_build() -> None:
    assert _mkdocs()["site_dir"] == "site"  # build/ is python -m build's
    ci = (ROOT / ".ci" / "run").read_text("utf-8")
    assert "--site-dir site" in ci and 'RTSIM_SITE_DIR="$PWD/site"' in ci
    assert "build/site" not in ci
    ignored = (ROOT / ".gitignore").read_text("utf-8").splitlines()
    assert "/site/" in ignored and ".pip.log" in ignored


def test_no_log_is_tracked() -> None:
    tracked = subprocess.run(
        ["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.splitlines()
    assert not [f for f in tracked if f.endswith(".log")]


def test_changelog_and_contributing() -> None:
    changelog = (ROOT / "CHANGELOG.md").read_text("utf-8")
    assert "Keep a Changelog" in changelog and "## [Unreleased]" in changelog
    for section in ("### Added", "### Changed"):
        assert section in changelog
    contributing = (ROOT / "CONTRIBUTING.md").read_text("utf-8")
    for topic in ("## Set-up", "## Tests", "## A plug-in", "## House rules"):
        assert topic in contributing, topic


def test_every_page_using_the_papers_symbols_links_the_glossary() -> None:
    hooks = _hooks()
    docs = ROOT / "docs"
    using = 0
    for md in sorted(docs.rglob("*.md")):
        rel = md.relative_to(docs).as_posix()
        text = md.read_text("utf-8")
        out = hooks.glossary_line(text, rel)
        if rel != "glossary.md" and hooks.SYMBOLS.search(text):
            using += 1
            assert "glossary.md" in out, rel
            depth = rel.count("/")
            link = out[out.index("glossary.md") - 3 * depth - 1 : out.index("glossary.md")]
            assert link.endswith("../" * depth), rel  # relative to the page
    assert using >= 20  # the model pages, the user guide, the results
    assert hooks.glossary_line("no symbols here", "x.md") == "no symbols here"


def test_the_sweep_page_names_only_files_a_sweep_writes() -> None:
    from rtsim.sweep.engine import MADE

    page = (ROOT / "docs" / "getting-started" / "sweep.md").read_text("utf-8")
    assert "results.csv" not in page.replace("rtsim sweep` writes no CSV", "")
    assert "results.parquet" in page and "results.parquet" in MADE
