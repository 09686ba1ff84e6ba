"""Odd names and bytes (issue 35, item 10): paths that are not UTF-8, task names of 250
characters or with control characters, ``--set`` values with a line break."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from rtsim.cli import main

ROOT = Path(__file__).resolve().parents[2]
BARREL = ROOT / "tasksets" / "barrel_robots.toml"
EXAMPLE = ROOT / "tasksets" / "example.toml"


def _rtsim(*args: str | bytes, cwd: Path | None = None) -> subprocess.CompletedProcess[bytes]:
    return subprocess.run(
        [sys.executable, "-m", "rtsim", *args], capture_output=True, timeout=300, cwd=cwd
    )


# -- paths that are not UTF-8 --------------------------------------------------------------
@pytest.mark.parametrize(
    "extra", [["--no-figures"], ["--no-figures", "--parquet"]], ids=["csv", "parquet"]
)
def test_scenario_writes_into_a_non_utf8_out(tmp_path: Path, extra: list[str]) -> None:
    """A traceback (report.html, Parquet through pyarrow) before; now the run is written
    under the name as the file system gave it, and its report shows the bytes escaped."""
    out = os.fsencode(tmp_path) + b"/run\xff\xfe"
    r = _rtsim("scenario", "test2", "--duration", "1", *extra, "--out", out)
    assert r.returncode == 0 and b"Traceback" not in r.stderr, r.stderr
    names = set(os.listdir(os.fsdecode(out)))
    assert {"summary.json", "windows.csv", "report.html", "manifest.json"} <= names
    if "--parquet" in extra:
        with open(Path(os.fsdecode(out)) / "windows.parquet", "rb") as fh:
            df = pd.read_parquet(fh)  # (pyarrow takes a path only as UTF-8)
        assert len(df) == len(pd.read_csv(Path(os.fsdecode(out)) / "windows.csv"))
    html = (Path(os.fsdecode(out)) / "report.html").read_text("utf-8")  # valid UTF-8
    assert "run\\xff\\xfe" in html


def test_sweep_writes_and_resumes_in_a_non_utf8_out(tmp_path: Path) -> None:
    """The sweep failed after computing every point, on every resume."""
    spec = tmp_path / "s.toml"
    spec.write_text(f'[sweep]\nkind = "bounds"\nbase = "{BARREL}"\n[grid]\nn = "1..3"\n')
    out = os.fsencode(tmp_path) + b"/sw\xff"
    for done in (0, 3):
        r = _rtsim("sweep", str(spec), "--workers", "1", "--out", out)
        assert r.returncode == 0 and b"Traceback" not in r.stderr, r.stderr
        assert f"3 points ({3 - done} run now, {done} already done)".encode() in r.stdout
    with open(Path(os.fsdecode(out)) / "results.parquet", "rb") as fh:
        table = pd.read_parquet(fh)
    assert list(table["n"]) == [1, 2, 3]


# -- long task names -----------------------------------------------------------------------
def _named(tmp_path: Path, *names: str) -> Path:
    f = tmp_path / "named.toml"
    body = "".join(
        f"[[tasks]]\nname = {json.dumps(n)}\nwcet = 1\n"
        f"period = {10 * (i + 1)}\npriority = {i + 1}\n"
        for i, n in enumerate(names)
    )
    f.write_text(body, encoding="utf-8")
    return f


@pytest.mark.parametrize(
    "names",
    [["t" * 250], ["t" * 101, "t" * 100], ["a/" * 120, "a:" * 120], ["é" * 200, "x"]],
    ids=["250", "100-101", "unsafe-240", "multibyte"],
)
def test_histogram_of_tasks_with_long_names(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], names: list[str]
) -> None:
    """A 250-character task name made ``histogram`` fail after the work, naming its hidden
    staging file; figure names are now cut and hashed past 100 characters, one per task."""
    f = _named(tmp_path, *names)
    out = tmp_path / "H"
    assert main(["histogram", str(f), "--horizon", "200", "--out", str(out)]) == 0
    figs = sorted(p.name for p in out.glob("histogram-*.png"))
    assert len(figs) == len(names) and all(len(os.fsencode(n)) <= 120 for n in figs)
    assert set(pd.read_csv(out / "histogram.csv")["task"]) == set(names)
    short = [n for n in names if len(n) <= 100 and n.isascii() and "/" not in n]
    for n in short:
        assert f"histogram-{n}.png" in figs


def test_a_write_that_fails_names_the_output_not_the_staging_file(tmp_path: Path) -> None:
    from rtsim.io.atomic import write_text

    target = tmp_path / ("n" * 256)  # beyond the file system's 255 bytes
    with pytest.raises(OSError) as exc:
        write_text(target, "x")
    assert exc.value.filename == os.fspath(target)
    assert not [p for p in tmp_path.iterdir()]


# -- control characters in names on stdout -------------------------------------------------
_ODD = ["a\nrtsim: fake line", "\x1b[31mred\x1b[0m", "nul\x00here", "cr\rret"]


@pytest.mark.parametrize(
    "argv",
    [
        ["analyze", "{f}"],
        ["analyze", "{f}", "--scheduler", "edf"],
        ["simulate", "{f}", "--horizon", "200"],
    ],
    ids=["analyze-fp", "analyze-edf", "simulate"],
)
def test_task_names_are_escaped_on_stdout(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str]
) -> None:
    """Names with a line break, ESC, NUL or CR were printed raw (a name could fake an
    ``rtsim:`` line or send terminal escapes): escaped as in error lines, one line per task,
    the same number of lines as with plain names."""
    odd = _named(tmp_path, *_ODD)
    assert main([a.replace("{f}", str(odd)) for a in argv]) == 0
    out = capsys.readouterr().out
    (tmp_path / "p").mkdir()
    plain = _named(tmp_path / "p", "a", "b", "c", "d")
    assert main([a.replace("{f}", str(plain)) for a in argv]) == 0
    ref = capsys.readouterr().out
    assert out.count("\n") == ref.count("\n")
    assert not any(c in out for c in "\x1b\x00\r")
    assert not [x for x in out.splitlines() if x.startswith("rtsim:")]
    for shown in ("a\\nrtsim: fake line", "\\x1b[31mred\\x1b[0m", "nul\\x00here", "cr\\rret"):
        assert shown in out
    if argv[0] == "analyze" and "edf" not in argv:
        line = next(x for x in out.splitlines() if x.startswith("offset-based"))
        assert "a\\nrtsim: fake line" in line


# -- --set with a line break ---------------------------------------------------------------
@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", str(EXAMPLE), "--horizon", "100", "--set", "overhead=0\nname=x"],
        ["analyze", str(BARREL), "--set", "window.n=3\nwindow.r_H=1"],
        ["scenario", "test2", "--duration", "1", "--set", "formation.followers=3\r\nx=1"],
    ],
    ids=["simulate", "analyze", "scenario-crlf"],
)
def test_set_with_a_line_break_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str]
) -> None:
    """``--set $'a=1\\nb=2'`` silently dropped everything after the newline."""
    assert main([*argv, "--out", str(tmp_path / "o")] if argv[0] == "scenario" else argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "has a line break" in err and "--set" in err
    assert not (tmp_path / "o").exists()


def test_set_in_a_sweep_file_with_a_line_break_is_refused(tmp_path: Path) -> None:
    from rtsim.config.dotted import parse_assignment
    from rtsim.errors import InputError

    with pytest.raises(InputError, match="has a line break"):
        parse_assignment("a=1\nb=2")
    assert parse_assignment("a = [1, 2]") == ("a", [1, 2])
