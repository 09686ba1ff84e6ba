"""The how-to pages run as written and print what their comments say (issue 34).

Per page of ``docs/howto/``, in a fresh directory: a ```python block whose first line is
``# <name>.py`` is written to that file; every other ```python block runs (the files on its
path), and a ``print(...)`` whose line ends in ``# <numbers>[: words]`` must print those
numbers, in order (one printed line per such print, in the order of the block's prints).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGES = sorted((ROOT / "docs" / "howto").glob("*.md"))
BLOCK = re.compile(r"```python\n(.*?)\n```", re.S)
FILE = re.compile(r"^# (\w+\.py)\n")
#: a print whose comment states its output: ``print(x)   # 30.0 15.0: why``
PRINT = re.compile(r"^\s*print\(.*\)\s+#\s*([-+0-9.eE ]+?)\s*(?::.*)?$")
NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")


def expected(code: str) -> list[tuple[int, list[float]]]:
    """(index among the block's prints, the numbers its comment states)."""
    out = []
    prints = [line for line in code.splitlines() if re.match(r"^\s*print\(", line)]
    for k, line in enumerate(prints):
        m = PRINT.match(line)
        if m:
            out.append((k, [float(x) for x in NUMBER.findall(m.group(1))]))
    return out


def test_the_pages_state_outputs() -> None:
    stated = [
        e
        for page in PAGES
        for code in BLOCK.findall(page.read_text("utf-8"))
        for e in expected(code)
    ]
    assert stated, "no how-to states an output"


@pytest.mark.slow
@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.stem)
def test_every_python_block_runs_and_prints_what_it_says(page: Path, tmp_path: Path) -> None:
    env = {**os.environ, "MPLBACKEND": "Agg"}
    env["PYTHONPATH"] = os.pathsep.join(
        [str(tmp_path), *[p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p]]
    )
    for code in BLOCK.findall(page.read_text("utf-8")):
        named = FILE.match(code)
        if named:
            (tmp_path / named.group(1)).write_text(code, encoding="utf-8")
            continue
        if code.lstrip().startswith(("decide(", "def ")):  # a signature shown, not a program
            continue
        proc = subprocess.run(
            [sys.executable, "-c", code],
            cwd=tmp_path,
            env=env,
            capture_output=True,
            text=True,
            timeout=600,
            check=False,
        )
        assert proc.returncode == 0, f"{page.name}:\n{code}\n{proc.stderr[-2000:]}"
        lines = proc.stdout.splitlines()
        for k, numbers in expected(code):
            got = [float(x) for x in NUMBER.findall(lines[k])]
            assert got == pytest.approx(numbers), f"{page.name}: printed {lines[k]!r}"
