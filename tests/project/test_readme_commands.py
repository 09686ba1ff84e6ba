"""Every ``rtsim`` command line in the README's shell blocks runs as written (in order, from a
directory laid out like the repository's root), with exit status 0."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def readme_command_lines() -> list[str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    body = text.split("\n## ", 1)[1]  # the two set-up commands are tested by test_readme.py
    blocks = re.findall(r"```(?:bash|sh)\n(.+?)\n```", body, flags=re.S)
    return [line for b in blocks for line in b.splitlines() if line.startswith("rtsim ")]


def test_readme_has_command_lines_for_every_command() -> None:
    from rtsim.cli import COMMANDS

    used = {line.split()[1] for line in readme_command_lines()}
    assert set(COMMANDS) <= used, set(COMMANDS) - used


@pytest.mark.slow
def test_every_readme_command_line_runs_as_written(tmp_path: Path) -> None:
    for name in ("tasksets", "experiments"):
        (tmp_path / name).symlink_to(ROOT / name)
    env = {
        **os.environ,
        "MPLBACKEND": "Agg",
        "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}",
    }
    for line in readme_command_lines():
        proc = subprocess.run(
            ["bash", "-c", line],
            cwd=tmp_path,
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
            stdin=subprocess.DEVNULL,
        )
        assert proc.returncode == 0, f"{line}\n{proc.stderr[-1500:]}"
