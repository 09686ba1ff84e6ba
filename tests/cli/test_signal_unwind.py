"""A signal that cuts an object's constructor short leaves a half-built object whose
finaliser fails as the stack unwinds (tqdm's progress bar did, at its minimum version:
``AttributeError: ... no attribute 'disable'`` under ``rtsim: terminated``). The CLI still
says one line."""

from __future__ import annotations

import subprocess
import sys

import pytest

_CHILD = """
import argparse, sys
import rtsim.cli as cli
from rtsim.cli import Terminated

class Bar:
    def __init__(self):
        raise {exc}  # the signal, arriving before the attributes are set
    def __del__(self):
        self.disable  # AttributeError in the finaliser

def run(args):
    Bar()

def parsed(self, argv=None, namespace=None):
    return argparse.Namespace(func=run, command="simulate"), []

argparse.ArgumentParser.parse_known_args = parsed
sys.exit(cli.main(["simulate"]))
"""


@pytest.mark.parametrize(
    "exc,rc,line",
    [("Terminated", 143, "rtsim: terminated"), ("KeyboardInterrupt", 130, "rtsim: interrupted")],
)
def test_a_half_built_object_unwound_after_a_signal_prints_nothing(
    exc: str, rc: int, line: str
) -> None:
    proc = subprocess.run(
        [sys.executable, "-c", _CHILD.format(exc=exc + "()")],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == rc, proc.stderr
    assert proc.stderr.strip() == line
