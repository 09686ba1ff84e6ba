"""tools/sphinx_roles.py: Sphinx roles become autorefs links or plain code (issue 34, item 3),
and none is left in rtsim/."""

from __future__ import annotations

import importlib.util
import zlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _tool():  # type: ignore[no-untyped-def]
    spec = importlib.util.spec_from_file_location(
        "sphinx_roles", ROOT / "tools" / "sphinx_roles.py"
    )
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


KNOWN = {"rtsim.io.scenario.load_scenario", "rtsim.coupling.ScenarioResult", "rtsim.io"}


@pytest.mark.parametrize(
    ("text", "module", "want"),
    [
        (
            ":func:`rtsim.io.scenario.load_scenario`",
            "",
            "[`rtsim.io.scenario.load_scenario`][rtsim.io.scenario.load_scenario]",
        ),
        (
            ":class:`~rtsim.coupling.ScenarioResult`",
            "",
            "[`ScenarioResult`][rtsim.coupling.ScenarioResult]",
        ),
        (":mod:`rtsim.io`", "", "[`rtsim.io`][rtsim.io]"),
        (
            ":meth:`load_scenario`",
            "rtsim.io.scenario",
            "[`load_scenario`][rtsim.io.scenario.load_scenario]",
        ),
        (
            ":class:`ScenarioResult`",
            "rtsim.coupling.scenario_run",
            "[`ScenarioResult`][rtsim.coupling.ScenarioResult]",
        ),
        (":data:`~rtsim.sweep.nothere.X`", "", "`X`"),  # not rendered: plain code
        (":exc:`ValueError`", "rtsim.x", "`ValueError`"),
        (":attr:`Scenario.duration`", "rtsim.x", "`Scenario.duration`"),
        (":obj:`tomllib.loads`", "", "`tomllib.loads`"),
        (":py:func:`rtsim.io`", "", "[`rtsim.io`][rtsim.io]"),
        ("a :func:`f` and :meth:`~a.b.g` here", "", "a `f` and `g` here"),
        ("``code`` and :unknown:`x` stay", "", "``code`` and :unknown:`x` stay"),
    ],
)
def test_roles_are_rewritten(text: str, module: str, want: str) -> None:
    assert _tool().rewrite(text, KNOWN, module) == want


def test_a_line_made_too_long_is_wrapped_with_its_indentation() -> None:
    tool = _tool()
    line = "    #: " + "word " * 15 + ":class:`~rtsim.coupling.ScenarioResult` and more words here"
    out = tool.rewrite_file(line, KNOWN, "", width=60).split("\n")
    assert all(len(x) <= 60 for x in out) and len(out) > 1
    assert all(x.startswith("    #: ") for x in out)
    assert " ".join(x[len("    #: ") :] for x in out) == tool.rewrite(line, KNOWN)[len("    #: ") :]
    short = "x :func:`f`"
    assert tool.rewrite_file(short, KNOWN) == "x `f`"


def test_a_role_broken_over_two_lines_is_joined() -> None:
    text = '    """Integrate (:func:`rtsim.io.\n    scenario.load_scenario`: exact)."""'
    out = _tool().rewrite_file(text, KNOWN)
    assert ":func:" not in out
    assert "[`rtsim.io.scenario.load_scenario`][rtsim.io.scenario.load_scenario]" in out
    assert out == (
        '    """Integrate ([`rtsim.io.scenario.load_scenario`][rtsim.io.scenario.load_scenario]:'
        ' exact)."""'
    )


def test_the_inventory_is_read(tmp_path: Path) -> None:
    body = "rtsim.io py:module 1 api/io/#$ -\nrtsim.run_sweep py:function 1 api/#$ -\n"
    head = b"# Sphinx inventory version 2\n# Project: rtsim\n# Version: 0\n# zlib\n"
    (tmp_path / "objects.inv").write_bytes(head + zlib.compress(body.encode()))
    assert _tool().read_inventory(tmp_path / "objects.inv") == {"rtsim.io", "rtsim.run_sweep"}


def test_no_sphinx_role_is_left_in_the_package() -> None:
    tool = _tool()
    left = [
        f"{f.relative_to(ROOT)}: {m.group(0)!r}"
        for f in tool.files([str(ROOT / "rtsim")])
        for m in tool.ROLE.finditer(f.read_text("utf-8"))  # a role broken over lines too
    ]
    assert not left, f"{len(left)} Sphinx roles left (python tools/sphinx_roles.py): {left[:5]}"
