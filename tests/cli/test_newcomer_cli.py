"""A newcomer's slips, each answered (issue 34, item 6): ``--set`` on every command that reads
an input file, the unit hints for a scenario file's keys as for the options, a horizon shorter
than the longest period, did-you-mean on shipped names, the range syntax, and one-line errors
from the Python API without a chained pydantic traceback."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

import rtsim
from rtsim.cli import main

ROOT = Path(__file__).resolve().parents[2]


def _parsers() -> dict[str, argparse.ArgumentParser]:
    from rtsim.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    code = main(argv)
    out, err = capsys.readouterr()
    assert code == 2, (argv, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def test_every_command_that_reads_an_input_file_takes_set() -> None:
    readers = []
    for name, p in _parsers().items():
        dests = {a.dest for a in p._actions}
        positional = [a for a in p._actions if not a.option_strings and a.dest == "file"]
        if positional:
            readers.append(name)
            assert "set" in dests, f"rtsim {name} reads FILE but has no --set"
    assert {"scenario", "simulate", "analyze", "bounds", "histogram"} <= set(readers)


def test_set_changes_the_file_of_bounds_and_histogram(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    import json

    assert main(["bounds", "--json"]) == 0
    plain = json.loads(capsys.readouterr().out)
    assert main(["bounds", "--set", "window.n=4", "--json"]) == 0
    four = json.loads(capsys.readouterr().out)
    assert main(["bounds", "--followers", "4", "--json"]) == 0
    assert four == json.loads(capsys.readouterr().out) != plain  # as the option says
    out = tmp_path / "h"
    argv = ["histogram", "example", "--horizon", "1000", "--out", str(out), "--json"]
    assert main([*argv, "--set", "tasks.0.wcet=6"]) == 0
    capsys.readouterr()
    bounds = (out / "bounds.csv").read_text()
    assert main(argv) == 0
    assert (out / "bounds.csv").read_text() != bounds  # the WCET moved the analysed WCRT
    line = _error(capsys, ["histogram", "--scenario", str(tmp_path), "--set", "n=2", "--out", "o"])
    assert "--set changes FILE's keys" in line


def test_a_unit_slip_in_a_scenario_key_is_refused_like_the_option(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    text = (ROOT / "experiments" / "scenarios" / "test2.toml").read_text("utf-8")
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("r_H = 25 ", "r_H = 0.25 "), encoding="utf-8")
    line = _error(capsys, ["scenario", str(bad), "--out", str(tmp_path / "o")])
    assert line.endswith(
        "bad.toml: sensing.r_H is in cm: 0.25 cm is under 1 cm (did you mean 25 cm, given in "
        "metres?); --force runs it anyway"
    )
    option = _error(capsys, ["bounds", "--hough-radius", "0.25"])
    hint = "is in cm: 0.25 cm is under 1 cm (did you mean 25 cm, given in metres?)"
    assert hint in option and hint in line  # the same hint
    line = _error(capsys, ["scenario", "test2", "--set", "duration=60000", "--out", "o"])
    assert "test2.toml: duration is in simulated seconds" in line and "60 s, given in ms" in line


def test_a_horizon_shorter_than_the_longest_period_warns(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # example: periods 40, 250, 500 ms; 60 ms releases the 500 ms task once
    assert main(["simulate", "example", "--horizon", "60"]) == 0
    err = capsys.readouterr().err
    assert "warning: --horizon is in ms: 60 ms is shorter than the longest period (500 ms)" in err
    assert "did you mean 60000 ms" in err
    assert main(["simulate", "example", "--horizon", "600"]) == 0
    assert "warning" not in capsys.readouterr().err


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (
            ["scenario", "tset2", "--out", "o"],
            "tset2: no such scenario file (did you mean 'test2', shipped with rtsim? "
            "`rtsim examples` lists the scenarios)",
        ),
        (
            ["bounds", "barrel_robot"],
            "barrel_robot: no such file (did you mean 'barrel_robots', shipped with rtsim? "
            "`rtsim examples` lists the task sets)",
        ),
        (
            ["scenario", "mine", "--out", "o"],
            "mine: no such scenario file (`rtsim examples` lists the scenarios shipped with "
            "rtsim, usable by name)",
        ),
        (
            ["bounds", "--followers", "1-10"],
            "--followers: cannot parse '1-10': ranges are written 1..10 (a..b or a..b:step), "
            "lists 1,2,5",
        ),
    ],
)
def test_names_and_ranges_get_a_hint(
    capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    argv: list[str],
    expected: str,
) -> None:
    monkeypatch.chdir(tmp_path)
    assert _error(capsys, argv) == f"rtsim: {expected}"


def test_python_api_errors_are_one_line_without_a_chained_traceback() -> None:
    with pytest.raises(rtsim.ScenarioError) as exc:
        rtsim.load_scenario("test2", {"sensing.r_H": "x"})
    assert str(exc.value) == "test2.toml: sensing.r_H: must be a number, got 'x'"
    assert exc.value.__context__ is None and exc.value.__cause__ is None
    from rtsim.sweep import parse_sweep

    with pytest.raises(rtsim.SweepError) as sw:
        parse_sweep({"sweep": {"kind": "bounds", "seed": -1}, "grid": {"n": [1]}}, "s.toml")
    assert "\n" not in str(sw.value) and sw.value.__context__ is None


def test_validate_set_changes_the_task_set_or_the_scenario(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """``rtsim validate --set``: a task-set key changes the analysed set (its w_sch is the one
    ``rtsim bounds`` computes with the same ``--set``), a scenario key the world, a key the
    grid sets or of neither file is refused in one line."""
    import json

    import pandas as pd

    assert "set" in {a.dest for a in _parsers()["validate"]._actions}
    grid = ["--followers", "1", "--hough-radius", "10"]
    change = ["--set", "tasks.dead_reckoning.wcet=10"]
    expected = {}
    for argv in ([], change):
        assert main(["bounds", *grid, *argv, "--json"]) == 0
        expected[bool(argv)] = json.loads(capsys.readouterr().out)["w_sch"]
    assert expected[True] > expected[False]  # the hp task's WCET enters eq. (11)
    out = tmp_path / "v"
    small = ["--random-sets", "0", "--windows", "100", "--histograms", "0", "--workers", "1"]
    argv = ["validate", "--out", str(out), *grid, *small, "--quiet", *change]
    assert main([*argv, "--set", "leader.speed=20"]) == 0
    table = pd.read_csv(out / "validation.csv")
    assert table["w_sch"].dropna().unique().tolist() == pytest.approx([expected[True]])
    manifest = (out / "manifest.json").read_text("utf-8")
    assert "leader.speed" in manifest and "tasks.dead_reckoning.wcet" in manifest
    bad = ["validate", "--out", str(tmp_path / "b"), *grid, *small]
    line = _error(capsys, [*bad, "--set", "formation.followers=3"])
    assert line.endswith(
        "--set formation.followers: set by the validation grid at every "
        "point; use --followers instead"
    )
    line = _error(capsys, [*bad, "--set", "leader.sped=20"])
    assert "test1.toml: overrides.leader.sped" in line and "speed" in line
