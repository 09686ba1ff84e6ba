"""What a pip user gets: the wheel's metadata and data files, the shipped examples by name."""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

from rtsim._version import __version__
from rtsim.cli import main
from rtsim.examples import EXAMPLES

ROOT = Path(__file__).resolve().parents[2]
#: The repository file each shipped example is a copy of.
ORIGINALS = {
    "barrel_robots": "tasksets/barrel_robots.toml",
    "example": "tasksets/example.toml",
    "test1": "experiments/scenarios/test1.toml",
    "test2": "experiments/scenarios/test2.toml",
    "smoke": "experiments/sweeps/smoke.toml",
    "quickstart": "examples/quickstart.ipynb",
}


def test_pyproject_license_is_spdx_with_a_license_file() -> None:
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text("utf-8"))["project"]
    assert meta["license"] == "MIT" and meta["license-files"] == ["LICENSE"]
    assert not any(c.startswith("License ::") for c in meta["classifiers"])  # PEP 639
    assert (ROOT / "LICENSE").read_text("utf-8").startswith("MIT License")
    assert meta["authors"]


def test_wheel_has_license_metadata_and_every_example(tmp_path: Path) -> None:
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "-q",
            "--no-deps",
            "--no-build-isolation",
            str(ROOT),
            "-w",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    (whl,) = tmp_path.glob("rtsim-*.whl")
    with zipfile.ZipFile(whl) as z:
        names = set(z.namelist())
        meta = z.read(next(n for n in names if n.endswith(".dist-info/METADATA"))).decode()
    assert "License-Expression: MIT" in meta and "Classifier: Typing :: Typed" in meta
    # the static version string is the metadata's (pyproject reads rtsim/_version.py)
    assert f"\nVersion: {__version__}\n" in meta
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    for ex in EXAMPLES.values():
        assert f"rtsim/data/{ex.resource}" in names, ex.name


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_shipped_examples_are_the_repository_files(name: str) -> None:
    shipped = EXAMPLES[name].text()
    original = (ROOT / ORIGINALS[name]).read_text("utf-8")
    if name == "smoke":  # its base is given by name instead of a relative path
        a, b = tomllib.loads(shipped), tomllib.loads(original)
        assert a["sweep"].pop("base") == "barrel_robots"
        assert b["sweep"].pop("base") == "../../tasksets/barrel_robots.toml"
        assert a == b
    else:
        assert shipped == original


def test_examples_command_lists_and_prints(capsys) -> None:
    assert main(["examples"]) == 0
    listed = [line.split()[0] for line in capsys.readouterr().out.splitlines()]
    assert listed == list(EXAMPLES)
    assert main(["examples", "test2"]) == 0
    assert capsys.readouterr().out == EXAMPLES["test2"].text()
    assert main(["examples", "nope"]) == 2
    assert "nope: no such example (one of barrel_robots" in capsys.readouterr().err


def test_examples_work_by_name_and_a_local_file_wins(tmp_path: Path, monkeypatch, capsys) -> None:
    from rtsim.config.taskset import load_taskset
    from rtsim.sweep.spec import load_sweep

    monkeypatch.chdir(tmp_path)
    assert load_taskset("example").name == "example"
    smoke = load_sweep("smoke")
    assert smoke.kind == "simulate" and len(smoke.grid) == 2
    assert smoke.base is not None and smoke.base.text == (
        ROOT / ORIGINALS["barrel_robots"]
    ).read_text("utf-8")
    assert main(["analyze", "example", "--json"]) == 0
    assert '"schedulable": true' in capsys.readouterr().out
    (tmp_path / "example").write_text('[[tasks]]\nname = "mine"\nwcet = 1\nperiod = 9\n')
    assert [t.name for t in load_taskset("example").tasks] == ["mine"]


def test_rtsim_reproduce_options_are_the_typed_options() -> None:
    """Only the CLI parses: ``rtsim reproduce``'s options map one to one onto
    ``rtsim.reproduce.ReproduceOptions``, which ``rtsim.reproduce.run`` takes."""
    import dataclasses

    from rtsim.cli import build_parser
    from rtsim.cli.reproduce import options
    from rtsim.reproduce import ReproduceOptions

    opts = ["--out", "x", "--quick", "--seed", "3", "--duration", "5", "--workers", "1"]
    opts += ["--docs", "d", "--quiet", "--format", "svg", "--dpi", "200", "--json"]
    opts += ["--set", "formation.followers=3"]
    args = build_parser().parse_args(["reproduce", *opts])
    assert options(args) == ReproduceOptions(
        out="x",
        quick=True,
        seed=3,
        duration=5.0,
        workers=1,
        docs="d",
        quiet=True,
        force=False,
        fig_format="svg",
        dpi=200,
        json=True,
        set=("formation.followers=3",),
    )
    dests = set(vars(args)) - {"command", "func"}
    assert dests == {f.name for f in dataclasses.fields(ReproduceOptions)}


def test_no_module_outside_the_cli_parses_options() -> None:
    """argparse is imported by ``rtsim/cli/`` alone (issue 31: one place parses options)."""
    bad = [
        str(p.relative_to(ROOT))
        for p in sorted((ROOT / "rtsim").rglob("*.py"))
        if "cli" not in p.relative_to(ROOT / "rtsim").parts[:1]
        and re.search(r"^\s*(import argparse|from argparse import)", p.read_text("utf-8"), re.M)
    ]
    assert bad == []


def test_classifiers_claim_what_ci_tests() -> None:
    """CI runs Python 3.11 on Linux: the classifiers claim that and no more."""
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text("utf-8"))["project"]
    versions = {
        c.rsplit(" :: ", 1)[1]
        for c in meta["classifiers"]
        if c.startswith("Programming Language :: Python :: 3.")
    }
    assert versions == {"3.11"}
    assert "Operating System :: OS Independent" not in meta["classifiers"]
    assert "Operating System :: POSIX :: Linux" in meta["classifiers"]


def test_long_description_has_no_relative_links() -> None:
    """The package index shows the readme without the repository beside it."""
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text("utf-8"))["project"]
    readme = meta["readme"] if isinstance(meta["readme"], str) else meta["readme"]["file"]
    text = (ROOT / readme).read_text("utf-8")
    links = re.findall(r"\]\(([^)\s]+)\)", text)
    assert all(link.startswith(("https://", "http://", "#")) for link in links), links
