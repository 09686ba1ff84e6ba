"""A full disk gives one line naming the output that could not be written (the target the
user gave, never a hidden staging name), exit 2, and leaves nothing behind.

The first test fills a real 256 KiB tmpfs (it needs the right to mount: skipped without);
the second makes the writers fail with ENOSPC by hand, so it runs everywhere."""

from __future__ import annotations

import errno
import subprocess
from pathlib import Path

import pytest

from rtsim.cli import main

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = str(ROOT / "tasksets" / "example.toml")
NO_SPACE = "No space left on device"


@pytest.fixture
def tiny(tmp_path: Path) -> Path:
    d = tmp_path / "tiny"
    d.mkdir()
    try:
        r = subprocess.run(
            ["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs", str(d)],
            capture_output=True,
            check=False,
            timeout=20,
        )
    except (OSError, subprocess.TimeoutExpired):
        pytest.skip("cannot run mount")
    if r.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {r.stderr.decode(errors='replace').strip()}")
    try:
        yield d
    finally:
        r = subprocess.run(["umount", str(d)], capture_output=True, check=False, timeout=20)
        if r.returncode != 0:  # still busy: a descriptor left open (a failure of its own)
            subprocess.run(["umount", "-l", str(d)], check=False, timeout=20)
        assert r.returncode == 0, f"the full disk was still in use: {r.stderr!r}"


def _one_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err.strip()


@pytest.mark.parametrize(
    "out",
    [
        ["simulate", EXAMPLE, "--horizon", "1e6", "--trace", "{d}/t.csv"],
        ["simulate", EXAMPLE, "--horizon", "1e6", "--jobs", "{d}/j.parquet"],
        ["simulate", EXAMPLE, "--horizon", "1e6", "--perfetto", "{d}/p.json"],
        ["scenario", "test2", "--duration", "60", "--no-figures", "--out", "{d}/run"],
        [
            "scenario",
            "test2",
            "--duration",
            "10",
            "--no-figures",
            "--out",
            "{d}/run",
            "--perfetto",
            "{d}/run/p.json",
        ],
    ],
)
def test_a_full_disk_names_the_file(
    tiny: Path, out: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    argv = [a.format(d=tiny) for a in out]
    assert main(argv) == 2
    line = _one_line(capsys)
    assert line.endswith(f": {NO_SPACE}"), line
    named = line[len("rtsim: ") : -len(f": {NO_SPACE}")]
    assert Path(named).parent in (tiny, tiny / "run"), line  # a target, not a staging name
    assert Path(named).name in {"t.csv", "j.parquet", "p.json", "windows.csv", "jobs.csv"}
    assert list(tiny.iterdir()) == [], "nothing is left on the full disk"


def _enospc(*_: object, **__: object) -> None:
    raise OSError(errno.ENOSPC, "No space left on device")  # as write() raises it: no name


def test_enospc_from_any_writer_names_its_target(
    tmp_path: Path, monkeypatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import rtsim.io.columns as columns
    import rtsim.io.spool as spool

    with monkeypatch.context() as m:
        m.setattr(columns.ChunkWriter, "_append_to", _enospc)
        assert (
            main(["simulate", EXAMPLE, "--horizon", "1e5", "--jobs", str(tmp_path / "j.csv")]) == 2
        )
        assert _one_line(capsys) == f"rtsim: {tmp_path / 'j.csv'}: {NO_SPACE}"
        assert (
            main(
                [
                    "scenario",
                    "test2",
                    "--duration",
                    "3",
                    "--no-figures",
                    "--out",
                    str(tmp_path / "run"),
                ]
            )
            == 2
        )
        assert _one_line(capsys) == f"rtsim: {tmp_path / 'run' / 'windows.csv'}: {NO_SPACE}"
    with monkeypatch.context() as m:
        m.setattr(spool.pickle, "dump", _enospc)
        assert (
            main(["simulate", EXAMPLE, "--horizon", "1e5", "--perfetto", str(tmp_path / "p.json")])
            == 2
        )
        assert _one_line(capsys) == f"rtsim: {tmp_path / 'p.json'}: {NO_SPACE}"
    assert sorted(p.name for p in tmp_path.iterdir()) == [], "no output, no staging left"
