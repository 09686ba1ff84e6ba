"""The command line's conventions, command by command: ``-q/--quiet`` everywhere, ``--out`` on
every command that writes files, ``--json`` on every command that prints a result,
``--format``/``--dpi`` on every command that draws; results on stdout, diagnostics on stderr;
progress bars only on a terminal (or with ``RTSIM_PROGRESS=1``), never with ``-q``, and
without any effect on the results."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from rtsim.cli import COMMANDS, build_parser, main

ROOT = Path(__file__).resolve().parents[2]
RTSIM = [sys.executable, "-m", "rtsim"]

#: Commands that write files (they take --out).
WRITES = {"generate", "scenario", "sweep", "validate", "histogram", "animate", "reproduce"}
#: Commands that draw figures (they take --format and --dpi).
DRAWS = {"scenario", "simulate", "histogram", "validate", "animate", "reproduce"}


def _options(command: str) -> list[str]:
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    return sub.choices[command].option_strings()


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_has_the_shared_options(command: str) -> None:
    opts = _options(command)
    assert "-q" in opts and "--quiet" in opts
    assert "--json" in opts  # every command prints a result
    assert ("--out" in opts) == (command in WRITES)
    sub = next(a for a in build_parser()._actions if a.dest == "command").choices[command]
    out = [a for a in sub._actions if "--out" in a.option_strings]
    assert all(a.required for a in out)  # where results go is always said, never a default
    assert ("--format" in opts and "--dpi" in opts) == (command in DRAWS)


def test_the_help_defaults_of_dpi_are_the_libraries() -> None:
    """The parsers do not import the plotting modules (slow); their help says the same."""
    from rtsim.plots.scenario import DPI as SCENARIO
    from rtsim.validate.histogram import DPI as HISTOGRAM
    from rtsim.validate.runner import DPI as VALIDATE

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    for command, dpi in (
        ("scenario", SCENARIO),
        ("reproduce", SCENARIO),
        ("histogram", HISTOGRAM),
        ("validate", VALIDATE),
    ):
        text = " ".join(sub.choices[command].format_help().split())
        assert f"(default {dpi})" in text, command


def _bounds_sweep(tmp: Path) -> str:
    spec = tmp / "bounds.toml"
    spec.write_text(
        '[sweep]\nkind = "bounds"\nbase = "barrel_robots"\n\n[grid]\nn = [1, 2]\n', "utf-8"
    )
    return str(spec)


#: One quick invocation per command that prints a result; OUT and SWEEP are filled in.
RUNS: list[list[str]] = [
    ["analyze", "example"],
    ["bounds", "--followers", "1,2"],
    ["examples"],
    ["examples", "test2"],
    ["simulate", "example", "--horizon", "2000"],
    ["generate", "--tasks", "3", "--utilization", "0.5", "--count", "2", "--out", "OUT"],
    ["scenario", "test1", "--duration", "3", "--no-figures", "--out", "OUT"],
    ["histogram", "example", "--horizon", "2000", "--out", "OUT"],
    ["sweep", "SWEEP", "--workers", "1", "--out", "OUT"],
]


def _argv(argv: list[str], tmp: Path, tag: str) -> list[str]:
    out = {"OUT": str(tmp / tag), "SWEEP": _bounds_sweep(tmp)}
    return [out.get(a, a) for a in argv]


@pytest.mark.parametrize("argv", RUNS, ids=[" ".join(r[:2]) for r in RUNS])
def test_json_is_one_object_on_stdout_and_quiet_prints_nothing(
    argv: list[str],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv("RTSIM_PROGRESS", raising=False)
    assert main(_argv(argv, tmp_path, "text")) == 0
    text, err = capsys.readouterr()
    assert text.strip() and err == ""  # a result, no diagnostics
    assert main(_argv(argv, tmp_path, "json") + ["--json"]) == 0
    out, err = capsys.readouterr()
    json.loads(out)  # one JSON document, nothing else
    assert err == ""
    assert main(_argv(argv, tmp_path, "quiet") + ["-q"]) == 0
    assert capsys.readouterr() == ("", "")


def _magic(path: Path) -> str:
    head = path.read_bytes()[:64]
    if head.startswith(b"\x89PNG"):
        return "png"
    if head.startswith(b"%PDF"):
        return "pdf"
    if b"<svg" in path.read_bytes()[:2000] or head.lstrip().startswith(b"<?xml"):
        return "svg"
    return "?"


def _png_width(path: Path) -> int:
    return int.from_bytes(path.read_bytes()[16:20], "big")


def test_simulate_figures_take_their_format_from_the_file_or_format(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    g, h = tmp_path / "g.svg", tmp_path / "h.pdf"
    assert (
        main(
            [
                *"simulate example --horizon 2000 --gantt".split(),
                str(g),
                *"--histogram".split(),
                str(h),
                *"-q".split(),
            ]
        )
        == 0
    )
    assert _magic(g) == "svg" and _magic(h) == "pdf"
    plain = tmp_path / "gantt"  # no suffix: --format decides
    assert (
        main(
            [
                *"simulate example --horizon 2000 --gantt".split(),
                str(plain),
                *"--format pdf -q".split(),
            ]
        )
        == 0
    )
    assert _magic(plain) == "pdf"
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    assert main(["simulate", "example", "--horizon", "2000", "--gantt", str(a), "-q"]) == 0
    assert (
        main(["simulate", "example", "--horizon", "2000", "--gantt", str(b), "--dpi", "60", "-q"])
        == 0
    )
    assert _png_width(a) == pytest.approx(2 * _png_width(b), abs=2)  # 120 dpi vs 60
    capsys.readouterr()
    assert (
        main(
            [
                *"simulate example --horizon 2000 --gantt".split(),
                str(tmp_path / "c.png"),
                *"--format svg".split(),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "ends in .png but --format is svg" in err[0]
    assert not (tmp_path / "c.png").exists()


def test_histogram_writes_the_format_asked_for(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "h"
    assert (
        main(
            [
                *"histogram example --horizon 2000 --format svg --out".split(),
                str(out),
                *"--json".split(),
            ]
        )
        == 0
    )
    files = [Path(f) for f in json.loads(capsys.readouterr().out)["files"]]
    figures = [f for f in files if f.suffix != ".csv"]
    assert figures and all(f.suffix == ".svg" and _magic(f) == "svg" for f in figures)
    assert not list(out.glob("*.png"))


def test_animate_formats_are_its_own(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["animate", str(tmp_path), "--out", str(tmp_path / "a.gif"), "--format", "svg"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "invalid choice: 'svg'" in err[0] and "gif" in err[0]
    assert (
        main(["animate", str(tmp_path), "--out", str(tmp_path / "a.gif"), "--format", "mp4"]) == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "ends in .gif but --format is mp4" in err[0]


@pytest.mark.slow
def test_reproduce_writes_svg_figures_and_json(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from rtsim.reproduce import MODES, TESTS, figure_stems

    out = tmp_path / "paper"
    assert (
        main(
            [
                *"reproduce --duration 4 --workers 1 --format svg --out".split(),
                str(out),
                *"--json".split(),
            ]
        )
        == 0
    )
    got, err = capsys.readouterr()
    runs = json.loads(got)["runs"]
    assert [(r["test"], r["mode"]) for r in runs] == [(t, m) for t in TESTS for m in MODES]
    assert "step/s" not in err  # stderr is not a terminal: no bar (progress lines only)
    svgs = sorted(p.stem for p in (out / "figures").glob("*.svg"))
    assert svgs == sorted(figure_stems())
    assert not list((out / "figures").glob("*.png"))
    assert all(_magic(p) == "svg" for p in (out / "figures").glob("*.svg"))
    manifest = json.loads((out / "manifest.json").read_text("utf-8"))
    assert f"figures/{figure_stems()[0]}.svg" in manifest["outputs"]


@pytest.mark.slow
def test_validate_writes_pdf_figures_and_json(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "v"
    assert (
        main(
            [
                *"validate --quick --followers 1 --hough-radius 25 --random-sets 0".split(),
                *"--histograms 1 --workers 1 --format pdf --out".split(),
                str(out),
                *"--json".split(),
            ]
        )
        == 0
    )
    got = json.loads(capsys.readouterr().out)
    assert got["ok"] is True and got["failures"] == []
    figures = [p for p in out.rglob("*") if p.suffix in (".png", ".svg", ".pdf")]
    assert len(figures) >= 5 and all(p.suffix == ".pdf" and _magic(p) == "pdf" for p in figures)
    assert "figures/bounds_vs_n.pdf" in (out / "report.md").read_text("utf-8")


# --- progress ------------------------------------------------------------------------


def test_progress_follows_the_terminal_the_variable_and_quiet(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from types import SimpleNamespace

    from rtsim.sim.progress import progress_enabled

    loud, quiet = SimpleNamespace(quiet=False), SimpleNamespace(quiet=True)
    monkeypatch.delenv("RTSIM_PROGRESS", raising=False)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert progress_enabled(loud) and not progress_enabled(quiet)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: False)
    assert not progress_enabled(loud)
    monkeypatch.setenv("RTSIM_PROGRESS", "1")
    assert progress_enabled(loud) and not progress_enabled(quiet)
    monkeypatch.setenv("RTSIM_PROGRESS", "0")
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert not progress_enabled(loud)


def test_scenario_progress_bar_changes_no_output(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The bar is drawn (forced on) and the files are byte for byte those of a run without."""
    runs = {}
    for flag in ("1", "0"):
        monkeypatch.setenv("RTSIM_PROGRESS", flag)
        out = tmp_path / f"p{flag}"
        assert (
            main(["scenario", "test2", "--duration", "8", "--no-figures", "--out", str(out)]) == 0
        )
        runs[flag] = (out, capsys.readouterr())
    bar = runs["1"][1].err
    assert "scenario:" in bar and "%|" in bar and "s simulated" in bar
    assert "%|" not in runs["0"][1].err
    assert runs["1"][1].out.replace("p1", "p0") == runs["0"][1].out
    for name in ("windows.csv", "jobs.csv", "summary.json"):
        assert (runs["1"][0] / name).read_bytes() == (runs["0"][0] / name).read_bytes(), name


def test_simulate_with_progress_gives_the_same_jobs() -> None:
    from rtsim.config.taskset import load_taskset
    from rtsim.sim import simulate

    ts = load_taskset()
    calls: list[tuple[float, float]] = []
    a = simulate(ts, 30_000, seed=4, exec_model="uniform", record_jobs=True)
    b = simulate(
        ts,
        30_000,
        seed=4,
        exec_model="uniform",
        record_jobs=True,
        progress=lambda s, t: calls.append((s, t)),
    )
    assert a.jobs.equals(b.jobs)
    shares = [s for s, _ in calls]
    assert shares == sorted(shares) and shares[-1] == 1.0 and len(calls) >= 100
    assert calls[0] == (pytest.approx(0.01), pytest.approx(300.0))


def _under_a_terminal(argv: list[str], env: dict[str, str]) -> str:
    """Run ``rtsim argv`` with stderr on a pseudo-terminal; what it wrote there."""
    import fcntl
    import pty
    import struct
    import termios

    controller, terminal = pty.openpty()
    fcntl.ioctl(terminal, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    try:
        proc = subprocess.Popen(
            [*RTSIM, *argv],
            stdout=subprocess.DEVNULL,
            stderr=terminal,
            stdin=subprocess.DEVNULL,
            env=env,
            cwd=ROOT,
        )
        os.close(terminal)
        chunks = []
        while True:
            try:
                data = os.read(controller, 4096)
            except OSError:  # EIO: the terminal closed, the process is done
                break
            if not data:
                break
            chunks.append(data)
        assert proc.wait(timeout=120) == 0
    finally:
        os.close(controller)
    return b"".join(chunks).decode("utf-8", "replace")


@pytest.mark.skipif(sys.platform == "win32", reason="pseudo-terminals are POSIX")
def test_a_terminal_gets_a_bar_and_quiet_none() -> None:
    env = {k: v for k, v in os.environ.items() if k != "RTSIM_PROGRESS"}
    argv = ["simulate", "example", "--horizon", "20000"]
    shown = _under_a_terminal(argv, env)
    assert "simulate:" in shown and "%|" in shown
    assert _under_a_terminal([*argv, "-q"], env) == ""
