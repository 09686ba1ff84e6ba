"""The example files shipped inside the package, usable by name wherever a file is asked for.

=================  ==========  ==========================================================
name               kind        what
=================  ==========  ==========================================================
``barrel_robots``  task set    the paper's Table 1 (= ``tasksets/barrel_robots.toml``)
``example``        task set    a generic rate-monotonic set (= ``tasksets/example.toml``)
``test1``          scenario    the paper's Test 1 (= ``experiments/scenarios/test1.toml``)
``test2``          scenario    the paper's Test 2 (= ``experiments/scenarios/test2.toml``)
``smoke``          sweep       10 points over n and r_H (= ``experiments/sweeps/smoke.toml``,
                               with its base given by name)
``quickstart``     notebook    the quickstart notebook (= ``examples/quickstart.ipynb``)
=================  ==========  ==========================================================

A name is used only when no file of that name exists, so a local file always wins:
``rtsim analyze example``, ``rtsim scenario test2 --out DIR``, ``rtsim sweep smoke --out DIR``.
``rtsim examples`` lists them; ``rtsim examples NAME`` prints one (to copy and edit).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path

from rtsim._suggest import close_match
from rtsim.errors import InputError

__all__ = ["Example", "EXAMPLES", "example", "packaged_text", "shipped_hint"]


@dataclass(frozen=True)
class Example:
    """One shipped file: its name, kind, path inside ``rtsim/data`` and a one-line summary."""

    name: str
    kind: str  # "taskset" | "scenario" | "sweep"
    resource: str
    summary: str

    def file(self) -> Traversable:
        """The file inside the installed package."""
        node = resources.files("rtsim") / "data"
        for part in self.resource.split("/"):
            node = node / part
        return node

    def text(self) -> str:
        return self.file().read_text("utf-8")


EXAMPLES: dict[str, Example] = {
    e.name: e
    for e in (
        Example(
            "barrel_robots",
            "taskset",
            "barrel_robots.toml",
            "the paper's Table 1: dead reckoning, the processing window, the command task",
        ),
        Example(
            "example",
            "taskset",
            "example.toml",
            "a generic rate-monotonic set: (5, 40), (200, 250), (25, 500)",
        ),
        Example(
            "test1",
            "scenario",
            "scenarios/test1.toml",
            "the paper's Test 1: V_Ld 25 cm/s, turns of 2 m radius, two followers",
        ),
        Example(
            "test2",
            "scenario",
            "scenarios/test2.toml",
            "the paper's Test 2: V_Ld 30 cm/s, sharper turns (1.2 m)",
        ),
        Example(
            "smoke",
            "sweep",
            "sweeps/smoke.toml",
            "a 10-point simulate sweep over n = 1..5 and r_H = 10, 25 cm",
        ),
        Example(
            "quickstart",
            "notebook",
            "notebooks/quickstart.ipynb",
            "the quickstart notebook: a run, a plot, a sweep, a histogram",
        ),
    )
}


def example(name: str) -> Example:
    """The example called ``name``; an InputError listing the names otherwise."""
    try:
        return EXAMPLES[name]
    except KeyError:
        raise InputError(f"{name}: no such example (one of {', '.join(EXAMPLES)})") from None


def packaged_text(path: str | os.PathLike[str], kind: str) -> str | None:
    """The text of the shipped example of ``kind`` named ``path``, when ``path`` is such a
    name and no file of that name exists; else None (the caller reads the file)."""
    name = os.fspath(path)
    ex = EXAMPLES.get(name)
    if ex is None or ex.kind != kind or Path(name).exists():
        return None
    return ex.text()


def shipped_hint(path: str | os.PathLike[str], kind: str) -> str:
    """The end of a "no such file" message: `` (did you mean 'test2', shipped with rtsim?
    ...)`` when the name is close to a shipped example of ``kind`` (``"scenario"``,
    ``"taskset"``), a pointer to ``rtsim examples`` for another bare name, else ``""``."""
    p = Path(path)
    names = [e.name for e in EXAMPLES.values() if e.kind == kind]
    guess = close_match(p.stem if p.suffix == ".toml" else p.name, names)
    what = "task sets" if kind == "taskset" else f"{kind}s"
    if guess is not None:
        return f" (did you mean {guess!r}, shipped with rtsim? `rtsim examples` lists the {what})"
    if str(p.parent) == "." and p.suffix == "":
        return f" (`rtsim examples` lists the {what} shipped with rtsim, usable by name)"
    return ""
