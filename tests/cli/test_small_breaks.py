"""Small breaks (issue 35, item 11): output suffixes that name the format written, booleans
refused as numbers in the library, ``generate`` checking what it writes."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import rtsim
from rtsim.cli import main
from rtsim.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "tasksets" / "example.toml"


def _refused(capsys: pytest.CaptureFixture[str], argv: list[str], words: str) -> None:
    assert main(argv) == 2, argv
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("rtsim: ") and words in err, err


@pytest.mark.parametrize(
    ("opt", "name", "words"),
    [
        ("--gantt", "g.csv", "ends in .csv, but it is written as png or svg or pdf"),
        ("--histogram", "h.txt", "ends in .txt"),
        ("--gantt", "g.png.gz", "ends in .gz"),
        ("--perfetto", "p.csv", "ends in .csv, but it is written as json"),
        ("--perfetto", "p", "has no suffix"),
        ("--jobs", "j.json", "must end in .csv or .parquet"),
    ],
)
def test_simulate_refuses_a_suffix_that_is_not_the_format(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], opt: str, name: str, words: str
) -> None:
    """``simulate --gantt g.csv`` wrote a PNG named .csv: refused before the run, nothing
    written."""
    _refused(
        capsys, ["simulate", str(EXAMPLE), "--horizon", "100", opt, str(tmp_path / name)], words
    )
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("name", "magic"), [("g.png", b"\x89PNG"), ("g.SVG", b"<?xml"), ("g.pdf", b"%PDF")]
)
def test_a_figure_is_written_in_the_format_its_suffix_names(
    tmp_path: Path, name: str, magic: bytes
) -> None:
    out = tmp_path / name
    assert main(["simulate", str(EXAMPLE), "--horizon", "100", "--gantt", str(out)]) == 0
    assert out.read_bytes().startswith(magic)


def test_scenario_and_animate_refuse_a_wrong_suffix(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _refused(
        capsys,
        [
            "scenario",
            "test2",
            "--duration",
            "1",
            "--out",
            str(tmp_path / "o"),
            "--perfetto",
            str(tmp_path / "p.csv"),
        ],
        "--perfetto",
    )
    assert not (tmp_path / "o").exists()
    _refused(capsys, ["animate", str(tmp_path), "--out", str(tmp_path / "a.csv")], "ends in .csv")


@pytest.mark.parametrize(
    "kw",
    [
        {"horizon": True},
        {"horizon": np.True_},
        {"horizon": 100.0, "overhead": True},
        {"horizon": 100.0, "hist_bin": False},
        {"horizon": "100"},
    ],
    ids=["horizon", "numpy-bool", "overhead", "hist_bin", "text"],
)
def test_library_simulate_refuses_booleans_as_numbers(kw: dict) -> None:
    """``rtsim.simulate(path, horizon=True)`` ran 1 ms: a bool is not a number of ms."""
    with pytest.raises(InputError, match="must be a number of ms"):
        rtsim.simulate(EXAMPLE, **kw)


def test_library_simulate_takes_numpy_numbers() -> None:
    a = rtsim.simulate(EXAMPLE, np.float32(200), overhead=np.int64(0))
    b = rtsim.simulate(EXAMPLE, 200.0, overhead=0.0)
    assert a.horizon == b.horizon == 200.0 and a.misses == b.misses
    assert math.isclose(a.busy_time, b.busy_time)


@pytest.mark.parametrize(
    ("periods", "words"),
    [
        ("loguniform:1e-300..1e-299", "period: "),
        ("loguniform:1e12..1e13", "is outside"),
        ("1e12,2e12", "wcet: "),
        ("loguniform:0.0002..0.002", "period: "),  # some sets only: the count finds one
    ],
)
def test_generate_refuses_sets_the_readers_refuse(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], periods: str, words: str
) -> None:
    """``generate --periods loguniform:1e-300..1e-299`` wrote sets that ``analyze`` refuses:
    every set is read back with the task-set reader's ranges; one line, nothing written."""
    out = tmp_path / "g"
    argv = ["generate", "--tasks", "4", "--utilization", "0.5", "--periods", periods]
    _refused(capsys, [*argv, "--count", "20", "--out", str(out)], words)
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_every_generated_set_is_read_by_analyze(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "g"
    argv = "generate --tasks 5 --utilization 0.7 --periods loguniform:0.01..1e6 --count 5"
    assert main([*argv.split(), "--out", str(out)]) == 0
    for f in sorted(out.glob("set_*.toml")):
        assert main(["analyze", str(f), "-q"]) in (0, 1), capsys.readouterr().err
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize(
    ("extra", "magic"),
    [([], b"\x89PNG"), (["--format", "svg"], b"<?xml"), (["--format", "pdf"], b"%PDF")],
)
def test_a_figure_named_without_a_suffix_is_in_the_format_asked(
    tmp_path: Path, extra: list[str], magic: bytes
) -> None:
    """docs/reliability.md: a figure without a suffix (``--gantt g``) is written in
    ``--format``'s format, PNG by default (the only outputs a missing suffix does not
    refuse)."""
    g, h = tmp_path / "g", tmp_path / "h"
    argv = ["simulate", str(EXAMPLE), "--horizon", "1000", "-q", *extra]
    assert main([*argv, "--gantt", str(g), "--histogram", str(h)]) == 0
    assert g.read_bytes().startswith(magic) and h.read_bytes().startswith(magic)
