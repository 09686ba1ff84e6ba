"""Shared fixtures: the packaged paper task set and a writer for small TOML files."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from rtsim.config.taskset import load_taskset
from rtsim.model.taskset import TaskSet

REPO = Path(__file__).resolve().parent.parent

#: A numeric input key without a registered range fails the tests (rtsim.io.limits).
os.environ["RTSIM_STRICT_RANGES"] = "1"


@pytest.fixture
def allow_code() -> Iterator[None]:
    """Input files read in the test may name code (``module:Name``), as with ``--allow-code``:
    for tests whose sweep files name their helper functions (tests/sweep_helpers.py)."""
    from rtsim.registry import opted_in

    with opted_in():
        yield


@pytest.fixture
def paper_ts() -> TaskSet:
    """The paper's Table 1 as packaged (``rtsim/data/barrel_robots.toml``)."""
    return load_taskset()


@pytest.fixture
def tmp_toml(tmp_path: Path) -> Callable[..., Path]:
    """Write ``text`` to ``tmp_path/<name>`` and return the path: ``tmp_toml(text, name=...)``."""

    def write(text: str | bytes, name: str = "set.toml") -> Path:
        path = tmp_path / name
        if isinstance(text, bytes):
            path.write_bytes(text)
        else:
            path.write_text(text, encoding="utf-8")
        return path

    return write
