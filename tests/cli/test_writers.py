"""Every writer checks its target before any work: another command's directory, a user's
file, an input file and two outputs on one path are refused (exit 2, one line, nothing
changed); ``--restart`` removes only what the sweep made; ``generate`` writes a whole
directory; ``simulate``'s staged files are cleaned on SIGTERM and by the next run."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rtsim.cli import main

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "tasksets" / "example.toml"
BARREL = ROOT / "tasksets" / "barrel_robots.toml"


def _snapshot(d: Path) -> list[tuple[str, bytes]]:
    return sorted((str(p.relative_to(d)), p.read_bytes()) for p in d.rglob("*") if p.is_file())


@pytest.fixture(scope="module")
def scenario_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("sc") / "t2"
    assert main(["scenario", "test2", "--duration", "2", "--no-figures", "--out", str(out)]) == 0
    return out


def _refused(capsys: pytest.CaptureFixture[str], argv: list[str], words: str) -> None:
    assert main(argv) == 2, argv
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("rtsim: "), err
    assert words in err, err


@pytest.mark.parametrize(
    "argv",
    [
        ["validate", "--quick", "--out", "{d}"],
        ["histogram", str(EXAMPLE), "--horizon", "100", "--out", "{d}"],
        ["histogram", "--scenario", "{d}", "--out", "{d}"],
        ["generate", "--tasks", "3", "--utilization", "0.5", "--out", "{d}"],
        ["sweep", str(ROOT / "experiments" / "sweeps" / "thresholds_test1.toml"), "--out", "{d}"],
        [
            "sweep",
            str(ROOT / "experiments" / "sweeps" / "thresholds_test1.toml"),
            "--restart",
            "--out",
            "{d}",
        ],
        ["simulate", str(EXAMPLE), "--horizon", "100", "--jobs", "{d}/jobs.csv"],
        ["simulate", str(EXAMPLE), "--horizon", "100", "--perfetto", "{d}/p.json"],
        ["animate", "{d}", "--out", "{d}/a.gif"],
    ],
    ids=lambda a: " ".join(a[:2] + a[-2:-1]),
)
def test_another_commands_directory_is_left_alone(
    scenario_dir: Path, capsys: pytest.CaptureFixture[str], argv: list[str]
) -> None:
    before = _snapshot(scenario_dir)
    _refused(capsys, [a.replace("{d}", str(scenario_dir)) for a in argv], "rtsim scenario")
    assert _snapshot(scenario_dir) == before
    assert not [p for p in scenario_dir.parent.iterdir() if p.name.startswith(".")]


def test_a_users_file_is_never_overwritten(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mine = tmp_path / "mine.csv"
    mine.write_text("my data\n")
    for opt in ("--jobs", "--trace"):
        _refused(
            capsys,
            ["simulate", str(EXAMPLE), "--horizon", "100", opt, str(mine)],
            "was not written by `rtsim simulate`",
        )
    _refused(
        capsys,
        ["simulate", str(EXAMPLE), "--horizon", "100", "--perfetto", str(tmp_path / "mine.csv")],
        "left alone",
    )
    assert mine.read_text() == "my data\n"
    # a sweep directory holding a user's results.parquet: refused, even with --restart
    d = tmp_path / "sw"
    d.mkdir()
    (d / "results.parquet").write_text("mine")
    spec = ROOT / "experiments" / "sweeps" / "thresholds_test1.toml"
    for extra in ([], ["--restart"]):
        _refused(capsys, ["sweep", str(spec), "--out", str(d), *extra], "'results.parquet'")
    assert (d / "results.parquet").read_text() == "mine"
    assert sorted(p.name for p in d.iterdir()) == ["results.parquet"]


def test_inputs_and_two_outputs_on_one_path(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    ts = tmp_path / "ex.toml"
    ts.write_bytes(EXAMPLE.read_bytes())
    _refused(
        capsys,
        ["simulate", str(ts), "--horizon", "100", "--perfetto", str(ts)],
        "is an input of this run",
    )
    assert ts.read_bytes() == EXAMPLE.read_bytes()
    x = tmp_path / "x.csv"
    _refused(
        capsys,
        ["simulate", str(ts), "--horizon", "100", "--jobs", str(x), "--trace", str(x)],
        "give each output its own file",
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ex.toml"]


def test_simulate_reruns_into_its_own_files(tmp_path: Path) -> None:
    for horizon in ("100", "200"):
        assert (
            main(
                [
                    "simulate",
                    str(EXAMPLE),
                    "--horizon",
                    horizon,
                    "--jobs",
                    str(tmp_path / "j.csv"),
                    "--perfetto",
                    str(tmp_path / "p.json"),
                ]
            )
            == 0
        )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["j.csv", "manifest.json", "p.json"]


def test_generate_writes_a_whole_directory(tmp_path: Path) -> None:
    out = tmp_path / "sets"
    assert (
        main(
            ["generate", "--tasks", "3", "--utilization", "0.5", "--count", "3", "--out", str(out)]
        )
        == 0
    )
    assert (
        main(
            ["generate", "--tasks", "3", "--utilization", "0.5", "--count", "1", "--out", str(out)]
        )
        == 0
    )
    assert sorted(p.name for p in out.iterdir()) == ["manifest.json", "set_0000.toml"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sets"]


def test_sweep_restart_removes_only_the_sweeps_files(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = tmp_path / "s.toml"
    spec.write_text('[sweep]\nkind = "bounds"\nbase = "set.toml"\n[grid]\nn = "1..2"\n')
    (tmp_path / "set.toml").write_bytes(BARREL.read_bytes())
    out = tmp_path / "o"
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "1", "-q"]) == 0
    (out / "points" / "notes.txt").write_text("mine")
    _refused(capsys, ["sweep", str(spec), "--out", str(out), "--restart", "-q"], "notes.txt")
    assert (out / "points" / "notes.txt").read_text() == "mine"
    (out / "points" / "notes.txt").unlink()
    assert main(["sweep", str(spec), "--out", str(out), "--restart", "--workers", "1", "-q"]) == 0


def test_a_tampered_point_file_is_not_taken_on_resume(tmp_path: Path) -> None:
    spec = tmp_path / "s.toml"
    spec.write_text('[sweep]\nkind = "bounds"\nbase = "set.toml"\n[grid]\nn = "1..2"\n')
    (tmp_path / "set.toml").write_bytes(BARREL.read_bytes())
    out = tmp_path / "o"
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "1", "-q"]) == 0
    first = (out / "results.parquet").read_bytes()
    point = sorted((out / "points").iterdir())[0]
    rec = json.loads(point.read_text())
    assert len(rec["checksum"]) == 64
    metric = next(k for k, v in rec["metrics"].items() if isinstance(v, float))
    rec["metrics"][metric] *= 2  # a forged result with the old checksum
    point.write_text(json.dumps(rec))
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "1", "-q"]) == 0
    assert (out / "results.parquet").read_bytes() == first  # the point was run again
    assert json.loads(point.read_text())["metrics"][metric] == rec["metrics"][metric] / 2


def _spawn(args: list[str], cwd: Path) -> subprocess.Popen[bytes]:
    return subprocess.Popen(
        [sys.executable, "-m", "rtsim", *args],
        cwd=cwd,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )


def _wait_for_staging(d: Path, proc: subprocess.Popen[bytes]) -> None:
    deadline = time.monotonic() + 60
    while not any(
        p.name.startswith(".rtsim-files-") and (p / "jobs.csv").exists() for p in d.iterdir()
    ):
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.05)


def test_simulate_sigterm_and_kill_leave_nothing(tmp_path: Path) -> None:
    """SIGTERM cleans up like Ctrl-C (exit 143, one line); a kill -9 leaves a locked-free
    staging directory that the next run into the same place removes."""
    args = ["simulate", str(BARREL), "--horizon", "2e7", "--force", "--jobs", "jobs.csv"]
    proc = _spawn(args, tmp_path)
    _wait_for_staging(tmp_path, proc)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143 and err.decode().strip() == "rtsim: terminated"
    assert list(tmp_path.iterdir()) == []
    proc = _spawn(args, tmp_path)
    _wait_for_staging(tmp_path, proc)
    proc.kill()
    proc.wait()
    assert [p.name[:13] for p in tmp_path.iterdir()] == [".rtsim-files-"]
    assert (
        main(["simulate", str(EXAMPLE), "--horizon", "100", "--jobs", str(tmp_path / "jobs.csv")])
        == 0
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["jobs.csv", "manifest.json"]


def test_long_output_names_work(tmp_path: Path) -> None:
    """Names of 225 to 255 bytes: the staging names beside them stay within the limit."""
    for n in (225, 255):
        name = "d" * n
        assert (
            main(
                ["generate", "--tasks", "2", "--utilization", "0.3", "--out", str(tmp_path / name)]
            )
            == 0
        )
        f = "j" * (n - 4) + ".csv"
        assert (
            main(["simulate", str(EXAMPLE), "--horizon", "100", "--jobs", str(tmp_path / f)]) == 0
        )
        assert (tmp_path / name / "manifest.json").is_file() and (tmp_path / f).is_file()


def test_non_utf8_out_is_one_line(tmp_path: Path) -> None:
    out = os.fsencode(tmp_path) + b"/\xff\xfe"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "rtsim",
            "generate",
            "--tasks",
            "2",
            "--utilization",
            "0.3",
            "--out",
            out,
        ],
        capture_output=True,
    )
    assert proc.returncode == 0, proc.stderr
    assert b"Traceback" not in proc.stderr
    assert os.path.isdir(out)


@pytest.fixture(scope="module")
def sweep_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("sw")
    spec = d / "s.toml"
    spec.write_text(f'[sweep]\nkind = "bounds"\nbase = "{BARREL}"\n[grid]\nn = "1..2"\n')
    out = d / "SW"
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    return out


@pytest.mark.parametrize(
    ("inside", "argv"),
    [
        ("sweep", ["simulate", str(EXAMPLE), "--horizon", "100", "--jobs", "{d}/points/x.csv"]),
        ("sweep", ["simulate", str(EXAMPLE), "--horizon", "100", "--trace", "{d}/points/a/b.csv"]),
        ("sweep", ["scenario", "test2", "--duration", "1", "--out", "{d}/points/run"]),
        ("sweep", ["generate", "--tasks", "3", "--utilization", "0.5", "--out", "{d}/points/g"]),
        ("scenario", ["simulate", str(EXAMPLE), "--horizon", "100", "--jobs", "{d}/sub/new.csv"]),
        ("scenario", ["animate", "{d}", "--out", "{d}/figures/a.gif"]),
        ("scenario", ["scenario", "test2", "--duration", "1", "--out", "{d}/again"]),
        ("scenario", ["histogram", str(EXAMPLE), "--horizon", "100", "--out", "{d}/figures/h"]),
    ],
    ids=lambda a: a if isinstance(a, str) else " ".join(a[:1] + a[-2:]),
)
def test_nothing_is_written_into_a_subdirectory_of_another_commands_output(
    scenario_dir: Path,
    sweep_dir: Path,
    capsys: pytest.CaptureFixture[str],
    inside: str,
    argv: list[str],
) -> None:
    """Issue 35 (9): only the immediate parent was checked, so ``simulate --jobs
    SW/points/x.csv`` poisoned a sweep (its resume refused for good) and a file under a
    reproduce run's test1/ was silently deleted by the next reproduce. Every ancestor is
    checked; nothing is written, the directory stays as it was, the sweep still resumes."""
    d = sweep_dir if inside == "sweep" else scenario_dir
    before = _snapshot(d)
    entries = sorted(p.name for p in d.rglob("*"))
    _refused(
        capsys,
        [a.replace("{d}", str(d)) for a in argv],
        f"is inside the output directory of `rtsim {inside}` ({d})",
    )
    assert _snapshot(d) == before and sorted(p.name for p in d.rglob("*")) == entries
    if inside == "sweep":
        spec = d.parent / "s.toml"
        assert main(["sweep", str(spec), "--out", str(d), "--workers", "1", "--quiet"]) == 0


def test_a_directory_beside_an_output_is_fine(
    scenario_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The check looks up, not sideways: a file next to an output directory is written."""
    out = scenario_dir.parent / "beside" / "jobs.csv"
    assert main(["simulate", str(EXAMPLE), "--horizon", "100", "--jobs", str(out)]) == 0
    assert out.is_file()


def test_a_reproduce_runs_subdirectory_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--jobs RP/test1/new.csv`` (the next reproduce would delete it): RP is claimed by
    reproduce's manifest, listing test1/ (made here by the manifest writer, as reproduce
    does, rather than by a minutes-long reproduce run)."""
    from rtsim.io.manifest import write_manifest

    rp = tmp_path / "RP"
    (rp / "test1").mkdir(parents=True)
    (rp / "test1" / "windows.csv").write_text("t\n")
    write_manifest(rp, command="reproduce", seed=0, inputs={}, extra={"outputs": ["test1"]})
    for opt in ("--jobs", "--gantt", "--perfetto"):
        target = rp / "test1" / ("new.png" if opt == "--gantt" else "new.csv")
        _refused(
            capsys,
            ["simulate", str(EXAMPLE), "--horizon", "100", opt, str(target)],
            f"inside the output directory of `rtsim reproduce` ({rp})",
        )
    assert sorted(p.name for p in (rp / "test1").iterdir()) == ["windows.csv"]
