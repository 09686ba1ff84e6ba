"""What a reader finds in the README, the documentation, the help texts and the docstrings:
no pointers outside the repository (``../shared``), no citations of the project's internal
specification, no internal work-item numbers; a README short enough to be a front door whose
every link resolves inside the repository."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from rtsim.cli import COMMANDS, build_parser

ROOT = Path(__file__).resolve().parents[2]
#: ``../shared``, a citation of the specification (``SPEC §5``, ``SPEC.md``, ``per SPEC``), or
#: an internal work item (``issue 10``, ``issues 13–15``, ``#24``-style references).
FORBIDDEN = re.compile(r"\.\./shared|\bSPEC\b|\b[Ii]ssues? #?\d+|\bitem \d+ of issue")
#: The one use of the word that is none of those: the metavariable of a distribution option.
ALLOWED = re.compile(
    r"\"SPEC\"|\bSPEC\.toml\b|\[--periods SPEC\]|--periods SPEC|--deadlines SPEC|"
    r"\[--deadlines SPEC\]"
)


def _hits(text: str) -> list[str]:
    return [m.group(0) for m in FORBIDDEN.finditer(ALLOWED.sub("", text))]


def _files() -> list[Path]:
    out = [ROOT / "README.md", ROOT / "README.pypi.md", ROOT / "mkdocs.yml", ROOT / "CITATION.cff"]
    out += sorted((ROOT / "docs").rglob("*.md"))
    out += sorted((ROOT / "rtsim").rglob("*.py"))
    out += sorted((ROOT / "rtsim" / "data").rglob("*.toml"))
    out += sorted((ROOT / "examples").rglob("*.ipynb"))
    return [p for p in out if p.is_file()]


@pytest.mark.parametrize("path", _files(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_no_pointers_outside_the_repository(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    bad = [(n, line.strip()) for n, line in enumerate(text.splitlines(), 1) if _hits(line)]
    assert not bad, f"{path.relative_to(ROOT)}: {bad[:5]}"


@pytest.mark.parametrize("command", ["", *COMMANDS])
def test_help_texts_cite_nothing_outside(command: str) -> None:
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    text = (sub.choices[command] if command else parser).format_help()
    assert not _hits(text), _hits(text)


def test_the_guard_catches_what_it_is_for() -> None:
    for bad in ("see ../shared/SPEC.md", "(SPEC §5)", "issue 10", "issues 13–15", "Issue #24"):
        assert _hits(bad), bad
    for good in ('"periods": "SPEC"', "the specification of a task", "tissue 5"):
        assert not _hits(good), good


def test_readme_is_a_front_door() -> None:
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) < 200, len(lines)


def test_every_readme_link_resolves_in_the_repository() -> None:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    links = re.findall(r"!?\[[^\]]*\]\(([^)\s]+)\)", text)
    assert links
    for link in links:
        assert not link.startswith(("http://", "https://")), link
        target = (ROOT / link.split("#", 1)[0]).resolve()
        assert target.exists(), link
        assert ROOT in target.parents, link
