"""Every help text is plain text: no reST markup, no internal issue references, and every
value option shows a metavariable from one small vocabulary."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from rtsim.cli import COMMANDS, build_parser

ROOT = Path(__file__).resolve().parents[1]
VOCABULARY = {"FILE", "DIR", "N", "MS", "CM", "U", "SPEC", "RANGE", "A..B", "PNG", "ADDRESS",
              "SECONDS", "NAME", "S", "KEY=VALUE"}
MARKUP = re.compile(r"``|:(?:func|mod|class|data|meth):|\bissue \d|\bissues? #?\d")


def _subparsers():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    return parser, sub.choices


@pytest.mark.parametrize("command", ["", *COMMANDS])
def test_help_is_plain_text(command: str) -> None:
    parser, subs = _subparsers()
    text = (subs[command] if command else parser).format_help()
    assert not MARKUP.search(text), MARKUP.search(text)


@pytest.mark.parametrize("command", COMMANDS)
def test_metavars_come_from_one_vocabulary(command: str) -> None:
    _, subs = _subparsers()
    for action in subs[command]._actions:
        if action.nargs == 0 or action.choices is not None or action.dest == "help":
            continue
        assert action.metavar in VOCABULARY, (command, action.dest, action.metavar)
        assert action.help, (command, action.dest)


@pytest.mark.parametrize("script", sorted(p.name for p in (ROOT / "experiments").glob("*.py")))
def test_experiment_scripts_help_is_plain(script: str) -> None:
    proc = subprocess.run([sys.executable, str(ROOT / "experiments" / script), "--help"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert not MARKUP.search(proc.stdout), MARKUP.search(proc.stdout)
