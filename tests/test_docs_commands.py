"""The getting-started pages cannot drift: every ```bash and ```python block of
``docs/getting-started/`` runs, page by page in a fresh directory laid out like the
repository's root, with exit status 0.

Blocks run as written except that simulated time is cut short (:data:`SHORTER`: durations,
horizons, animation ranges, the validation grid), so that the pages run in about a minute.
A block that installs (``pip install``) is the README's and is tested there
(tests/test_readme.py); a block preceded by ``<!-- not run -->`` is skipped.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs" / "getting-started").glob("*.md"))
BLOCK = re.compile(r"(<!-- not run -->\s*)?```(bash|python)\n(.*?)\n```", re.S)

#: (pattern, replacement): the same commands on less simulated time.
SHORTER: tuple[tuple[str, str], ...] = (
    (r"--duration \d+(\.\d+)?", "--duration 4"),
    (r"--horizon \d+(\.\d+)?", "--horizon 3000"),
    (r"--start \d+(\.\d+)?", "--start 1"),
    (r"--end \d+(\.\d+)?", "--end 3"),
    (r"(?m)^duration = \d+", "duration = 4"),  # a scenario sweep's [sweep.options]
    (r"duration_s=\d+(\.\d+)?", "duration_s=4"),
    (r"rtsim validate --quick", "rtsim validate --quick --followers 1 --hough-radius 25 "
                                "--random-sets 0 --histograms 1"),
)


def blocks(page: Path) -> list[tuple[str, str]]:
    """The (language, text) of the page's blocks that run (module docstring)."""
    out = []
    for skip, lang, text in BLOCK.findall(page.read_text("utf-8")):
        if skip or "pip install" in text:
            continue
        out.append((lang, text))
    return out


def shorter(text: str) -> str:
    for pattern, repl in SHORTER:
        text = re.sub(pattern, repl, text)
    return text


def test_the_pages_have_blocks_and_every_command_appears() -> None:
    from rtsim.cli import COMMANDS

    texts = [t for page in PAGES for _, t in blocks(page)]
    assert len(texts) >= 10
    used = {m for t in texts for m in re.findall(r"(?m)^rtsim (\w+)", t)}
    assert {"scenario", "sweep", "bounds", "histogram", "validate", "simulate",
            "animate", "examples"} <= used <= set(COMMANDS)


@pytest.mark.slow
@pytest.mark.parametrize("page", [p for p in PAGES if blocks(p)], ids=lambda p: p.stem)
def test_every_block_of_the_page_runs(page: Path, tmp_path: Path) -> None:
    for name in ("tasksets", "experiments"):
        (tmp_path / name).symlink_to(ROOT / name)
    env = {**os.environ, "MPLBACKEND": "Agg",
           "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    env.pop("RTSIM_PROGRESS", None)
    for lang, text in blocks(page):
        code = shorter(text)
        argv = ["bash", "-euo", "pipefail", "-c", code] if lang == "bash" else \
            [sys.executable, "-c", code]
        proc = subprocess.run(argv, cwd=tmp_path, env=env, capture_output=True, text=True,
                              timeout=600, stdin=subprocess.DEVNULL)
        assert proc.returncode == 0, f"{page.name}:\n{code}\n{proc.stderr[-2000:]}"
