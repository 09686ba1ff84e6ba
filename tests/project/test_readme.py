"""The README's two commands: the test command is exactly what CI runs."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _readme_commands() -> list[str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    head = text.split("\n## ", 1)[0]
    return re.findall(r"```(?:bash|sh)\n(.+?)\n```", head, flags=re.S)


def test_readme_starts_with_two_commands() -> None:
    cmds = _readme_commands()
    assert len(cmds) == 2, cmds
    assert "pip install" in cmds[0] and "pip install" in cmds[1]


def test_ci_runs_the_readme_test_command() -> None:
    test_cmd = _readme_commands()[1].strip()
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert test_cmd in ci.splitlines(), f"{test_cmd!r} not a line of .ci/run"
