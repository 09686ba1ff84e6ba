"""The command line catches mistakes: no abbreviations, unknown options answered with a
did-you-mean, values that are almost certainly a mistake of unit refused with a one-line hint
naming the unit (unless ``--force``) — each one line on stderr, exit 2, before any work."""

from __future__ import annotations

from pathlib import Path

import pytest

from rtsim.cli import main

ROOT = Path(__file__).resolve().parents[2]
PAPER = str(ROOT / "tasksets" / "barrel_robots.toml")


def _one_line_error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    code = main(argv)
    out, err = capsys.readouterr()
    assert code == 2, (argv, err)
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "usage:" not in err and "Traceback" not in err
    return lines[0]


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (
            ["scenario", "test2", "--duraton", "60", "--out", "OUT"],
            "unknown option --duraton (did you mean --duration?)",
        ),
        (["simulate", PAPER, "--hor", "100"], "unknown option --hor (did you mean --horizon?)"),
        (["analyze", "example", "--jsn"], "unknown option --jsn (did you mean --json?)"),
        (["reproduce", "--quik", "--out", "OUT"], "unknown option --quik (did you mean --quick?)"),
    ],
)
def test_unknown_and_abbreviated_options_get_a_did_you_mean(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, argv: list[str], expected: str
) -> None:
    argv = [str(tmp_path / "o") if a == "OUT" else a for a in argv]
    line = _one_line_error(capsys, argv)
    assert expected in line
    assert not (tmp_path / "o").exists()


def test_an_invalid_choice_gets_a_did_you_mean(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["scenario", "test2", "--mode", "adjsut", "--out", str(tmp_path / "o")])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "did you mean 'adjust'?" in err[0] and "usage" not in err[0]


@pytest.mark.parametrize(
    ("argv", "unit", "fix"),
    [
        (["simulate", PAPER, "--horizon", "60"], "--horizon is in ms", "60000 ms"),
        (["histogram", PAPER, "--horizon", "60", "--out", "OUT"], "--horizon is in ms", "60000 ms"),
        (["bounds", "--hough-radius", "0.25"], "--hough-radius is in cm", "25 cm"),
        (
            ["simulate", PAPER, "--horizon", "60000", "--hough-radius", "0.3"],
            "--hough-radius is in cm",
            "30 cm",
        ),
        (
            ["scenario", "test2", "--duration", "60000", "--out", "OUT"],
            "--duration is in simulated seconds",
            "60 s",
        ),
        (
            ["reproduce", "--duration", "60000", "--out", "OUT"],
            "--duration is in simulated seconds",
            "60 s",
        ),
        (
            ["validate", "--quick", "--hough-radius", "0.1,0.3", "--out", "OUT"],
            "--hough-radius is in cm",
            "10 cm",
        ),
    ],
)
def test_implausible_values_are_refused_with_the_unit(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, argv: list[str], unit: str, fix: str
) -> None:
    argv = [str(tmp_path / "o") if a == "OUT" else a for a in argv]
    line = _one_line_error(capsys, argv)
    assert unit in line and f"did you mean {fix}" in line and "--force" in line
    assert not (tmp_path / "o").exists()  # refused before any work


def test_force_runs_an_implausible_value(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bounds", "--hough-radius", "0.25", "--force", "--json"]) == 0
    assert '"r_H": 0.25' in capsys.readouterr().out
    assert main(["simulate", PAPER, "--horizon", "60", "--force"]) == 0


def test_plausible_values_pass(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bounds", "--hough-radius", "1,25"]) == 0  # 1 cm is the edge, allowed
    assert main(["simulate", PAPER, "--horizon", "240"]) == 0  # just over one window
    capsys.readouterr()


def test_quiet_exists_on_every_command_that_reports_progress() -> None:
    from rtsim.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for name in ("sweep", "validate", "reproduce", "animate"):
        opts = sub.choices[name].option_strings()
        assert "-q" in opts and "--quiet" in opts, name


def test_policy_help_lists_every_registered_policy() -> None:
    from rtsim.cli import build_parser
    from rtsim.control.policy import ADJUSTMENT_POLICIES

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    text = " ".join(sub.choices["scenario"].format_help().split())
    for name in ADJUSTMENT_POLICIES:
        assert name in text, name


def test_scenario_writes_svg_figures(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "svg"
    assert main(["scenario", "test1", "--duration", "5", "--format", "svg", "--out", str(out)]) == 0
    svgs = sorted(p.name for p in out.glob("*.svg"))
    from rtsim.plots.scenario import SCENARIO_FIGURES

    assert svgs == sorted(f"{stem}.svg" for stem in SCENARIO_FIGURES)
    assert not list(out.glob("*.png"))
    for p in out.glob("*.svg"):
        assert p.read_text("utf-8").lstrip().startswith("<?xml") and "<svg" in p.read_text()
    report = (out / "report.html").read_text("utf-8")
    assert report.count("data:image/svg+xml;base64,") == len(SCENARIO_FIGURES)  # embedded
    capsys.readouterr()
