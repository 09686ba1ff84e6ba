"""Sweeps that survive bad grids, odd metrics, dead workers, a dead parent and a second run
(issue 13, item 1): each failure class, with hypothesis variants where they fit."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rtsim.cli import main
from rtsim.errors import InputError, SweepError
from rtsim.io.lock import DirectoryLocked, lock_directory
from rtsim.io.work import LIMITS, TooMuchWork
from rtsim.sweep import Sweep, load_sweep, run_sweep
from rtsim.sweep.engine import grid_size

# the sweep files here name their helper functions (code): the user opts in
pytestmark = pytest.mark.usefixtures("allow_code")

HERE = Path(__file__).resolve().parents[1]
ROOT = HERE.parent


@pytest.fixture(autouse=True)
def _helpers_importable(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(HERE))
    monkeypatch.setenv(
        "PYTHONPATH", os.pathsep.join([str(HERE), *filter(None, [os.environ.get("PYTHONPATH")])])
    )


def _strict_load(path: Path) -> object:
    def refuse(name: str) -> None:
        raise ValueError(f"non-strict JSON constant {name} in {path}")

    return json.loads(path.read_text("utf-8"), parse_constant=refuse)


def _write(tmp_path: Path, text: str, name: str = "s.toml") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


# -- grid value types ---------------------------------------------------------------
_BASE = ROOT / "experiments" / "scenarios" / "test1.toml"


def test_mixed_grid_types_are_refused_at_load_naming_file_and_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = _write(
        tmp_path,
        f'[sweep]\nkind = "scenario"\nbase = "{_BASE}"\n'
        '[sweep.options]\nduration = 1\n[grid]\n"leader.speed" = [20, 30.5, "fast"]\n',
    )
    assert main(["sweep", str(spec), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err
    assert str(spec) in err and "grid.leader.speed" in err and "one type" in err
    assert not (tmp_path / "o" / "points").exists()  # refused before anything ran


_values = st.one_of(
    st.integers(-(10**6), 10**6),
    st.floats(-1e6, 1e6, allow_nan=False),
    st.text("abcxyz", min_size=1, max_size=4),
    st.booleans(),
)


def _kind(v: object) -> str:
    return "bool" if isinstance(v, bool) else ("number" if isinstance(v, int | float) else "text")


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(values=st.lists(_values, min_size=1, max_size=6))
def test_grid_column_of_one_type_loads_any_mix_is_refused(
    tmp_path: Path, values: list[object]
) -> None:
    text = (
        '[sweep]\nkind = "call"\nfunction = "sweep_helpers:echo"\n[grid]\nv = '
        + json.dumps(values)
        + "\n"
    )
    spec = _write(tmp_path, text)
    if len({_kind(v) for v in values}) == 1:
        assert len(load_sweep(spec).grid[0][1]) == len(values)
    else:
        with pytest.raises(SweepError, match=r"grid\.v: values must all be of one type"):
            load_sweep(spec)


def test_ints_mixed_with_bools_are_refused(tmp_path: Path) -> None:
    spec = _write(
        tmp_path,
        '[sweep]\nkind = "call"\nfunction = "sweep_helpers:echo"\n[grid]\nv = [0, 1, true]\n',
    )
    with pytest.raises(SweepError, match=r"grid\.v: .*number 0 and bool True"):
        load_sweep(spec)


# -- metrics per point ----------------------------------------------------------------
def _odd_sweep(tmp_path: Path, cases: list[str]) -> Path:
    return _write(
        tmp_path,
        '[sweep]\nkind = "call"\nfunction = "sweep_helpers:odd"\n'
        f"[grid]\ncase = {json.dumps(cases)}\n",
    )


@pytest.mark.parametrize(
    ("case", "error"),
    [
        ("big", "does not fit a 64-bit column"),
        ("clash", "clash"),
        ("array", "not a scalar"),
    ],
)
def test_a_bad_metric_fails_its_point_and_the_table_is_written(
    tmp_path: Path, case: str, error: str
) -> None:
    df = run_sweep(_odd_sweep(tmp_path, ["ok", case]), tmp_path / "o", workers=1)
    assert list(df["status"]) == ["ok", "failed"]
    assert error in df["error"].iloc[1]
    stored = pd.read_parquet(tmp_path / "o" / "results.parquet")
    pd.testing.assert_frame_equal(df, stored)


def test_a_metric_whose_type_changes_fails_that_point_and_reruns_give_the_same_table(
    tmp_path: Path,
) -> None:
    spec = _odd_sweep(tmp_path, ["ok", "text", "bool", "ok"])
    df = run_sweep(spec, tmp_path / "o", workers=1)
    assert list(df["status"]) == ["ok", "failed", "failed", "ok"]
    assert "metric 'x' is text ('seven') but number at point 0" in df["error"].iloc[1]
    assert "is bool" in df["error"].iloc[2]
    assert pd.read_parquet(tmp_path / "o" / "results.parquet")["x"].tolist()[::3] == [1.5, 1.5]
    again = run_sweep(spec, tmp_path / "o", workers=1)  # resumes: nothing stuck on disk
    pd.testing.assert_frame_equal(df, again)


def test_numpy_and_non_finite_metrics_round_trip_through_strict_point_files(tmp_path: Path) -> None:
    df = run_sweep(_odd_sweep(tmp_path, ["numpy", "inf"]), tmp_path / "o", workers=1)
    assert list(df["status"]) == ["ok", "ok"]
    assert df["x"].tolist() == [7.0, math.inf]
    assert df["y"].iloc[1] == -math.inf and math.isnan(df["z"].iloc[1])
    for f in (tmp_path / "o" / "points").glob("*.json"):
        _strict_load(f)
    _strict_load(tmp_path / "o" / "manifest.json")


def test_a_metric_named_like_a_grid_column_and_its_renamed_form_clash(tmp_path: Path) -> None:
    df = run_sweep(_odd_sweep(tmp_path, ["shadow", "renamed"]), tmp_path / "o", workers=1)
    assert df["status"].tolist() == ["ok", "failed"]
    assert df["metric.case"].iloc[0] == 1  # a metric named like the grid column: renamed
    assert "clashes with another column 'metric.case'" in df["error"].iloc[1]
    pd.read_parquet(tmp_path / "o" / "results.parquet")


# -- grid size ------------------------------------------------------------------------
def test_a_huge_grid_is_refused_before_it_is_made(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = _write(
        tmp_path,
        '[sweep]\nkind = "call"\nfunction = "sweep_helpers:echo"\n'
        '[grid]\na = "1..1000"\nb = "1..1000"\nc = "1..1000"\n',
    )
    assert grid_size(load_sweep(spec)) == 10**9
    t0 = time.perf_counter()
    assert main(["sweep", str(spec), "--out", str(tmp_path / "o")]) == 2
    assert time.perf_counter() - t0 < 5
    err = capsys.readouterr().err
    assert "grid" in err and "1e+09" in err and "--force" in err and err.count("\n") == 1


def test_force_runs_a_grid_above_the_limit(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(LIMITS, "grid", 3)
    spec = _write(
        tmp_path, '[sweep]\nkind = "call"\nfunction = "sweep_helpers:echo"\n[grid]\ni = "1..4"\n'
    )
    with pytest.raises(TooMuchWork, match="--force"):
        Sweep(spec, tmp_path / "o")
    assert len(run_sweep(spec, tmp_path / "o", workers=1, force=True)) == 4


@pytest.mark.parametrize("workers", ["2", 1.7, True, 0, -1])
def test_workers_must_be_an_integer_of_at_least_one(tmp_path: Path, workers: object) -> None:
    spec = _write(
        tmp_path, '[sweep]\nkind = "call"\nfunction = "sweep_helpers:echo"\n[grid]\ni = "1..2"\n'
    )
    with pytest.raises(InputError, match="workers"):
        run_sweep(spec, tmp_path / "o", workers=workers)  # type: ignore[arg-type]


def test_workers_accepts_a_numpy_integer(tmp_path: Path) -> None:
    spec = _write(
        tmp_path, '[sweep]\nkind = "call"\nfunction = "sweep_helpers:echo"\n[grid]\ni = "1..2"\n'
    )
    assert len(run_sweep(spec, tmp_path / "o", workers=np.int64(1))) == 2


# -- dead workers ---------------------------------------------------------------------
def _die_sweep(tmp_path: Path, die_at: int, once: Path | None, n: int = 6) -> Path:
    opts = f"die_at = {die_at}\nsleep = 0.05\n" + (f'once = "{once}"\n' if once else "")
    return _write(
        tmp_path,
        '[sweep]\nkind = "call"\nfunction = "sweep_helpers:die"\n'
        f'[sweep.options]\n{opts}[grid]\ni = "0..{n - 1}"\n',
    )


def test_a_point_that_kills_its_worker_is_recorded_failed_and_the_sweep_goes_on(
    tmp_path: Path,
) -> None:
    df = run_sweep(_die_sweep(tmp_path, 2, None), tmp_path / "o", workers=2)
    assert df["status"].tolist() == ["ok", "ok", "failed", "ok", "ok", "ok"]
    assert df["error"].iloc[2].startswith("WorkerDied: ")
    assert df["double"].tolist()[:2] == [0, 2] and df["double"].tolist()[3:] == [6, 8, 10]


def test_a_worker_that_dies_once_has_its_point_rerun(tmp_path: Path) -> None:
    df = run_sweep(_die_sweep(tmp_path, 3, tmp_path / "died"), tmp_path / "o", workers=2)
    assert (df["status"] == "ok").all() and (tmp_path / "died").exists()
    assert df["double"].tolist() == [0, 2, 4, 6, 8, 10]
    rec = json.loads(next((tmp_path / "o" / "points").glob("000003-*.json")).read_text())
    assert rec["attempts"] == 2  # the rerun is recorded


def test_cli_prints_no_traceback_when_a_worker_dies(tmp_path: Path) -> None:
    spec = _die_sweep(tmp_path, 1, None, n=8)
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "rtsim",
            "sweep",
            "--allow-code",
            str(spec),
            "--out",
            str(tmp_path / "o"),
            "--workers",
            "2",
            "--quiet",
        ],
        capture_output=True,
        text=True,
        env=os.environ | {"PYTHONPATH": str(HERE)},
        timeout=120,
    )
    assert r.returncode == 1, r.stderr
    assert "Traceback" not in r.stderr and "BrokenProcessPool" not in r.stderr
    df = pd.read_parquet(tmp_path / "o" / "results.parquet")
    assert df["status"].tolist().count("failed") == 1


def _children(pid: int) -> list[int]:
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                ppid = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            if ppid == pid:
                out.append(int(d.name))
    return out


def _alive(pid: int) -> bool:
    try:
        state = (Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
def test_workers_exit_when_the_sweep_process_is_killed(tmp_path: Path) -> None:
    spec = _write(
        tmp_path,
        '[sweep]\nkind = "call"\nfunction = "sweep_helpers:slow"\n'
        '[sweep.options]\nsleep = 0.5\n[grid]\ni = "0..40"\n',
    )
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "rtsim",
            "sweep",
            "--allow-code",
            str(spec),
            "--out",
            str(tmp_path / "o"),
            "--workers",
            "2",
            "--quiet",
        ],
        env=os.environ | {"PYTHONPATH": str(HERE)},
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 60
        workers: list[int] = []
        while time.monotonic() < deadline and len(workers) < 2:
            time.sleep(0.2)
            workers = _children(proc.pid)
        assert len(workers) >= 2, "the sweep did not start its workers"
        time.sleep(0.5)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and any(_alive(w) for w in workers):
            time.sleep(0.1)
        assert not any(_alive(w) for w in workers)
    finally:
        if proc.poll() is None:
            proc.kill()


# -- the directory lock ---------------------------------------------------------------
def test_a_second_sweep_into_a_locked_directory_is_refused_naming_the_holder(
    tmp_path: Path,
) -> None:
    spec = _write(
        tmp_path, '[sweep]\nkind = "call"\nfunction = "sweep_helpers:echo"\n[grid]\ni = "1..2"\n'
    )
    out = tmp_path / "o"
    with lock_directory(out, ["rtsim", "sweep", "first"]):
        with pytest.raises(
            DirectoryLocked,
            match=rf"in use by pid {os.getpid()} on .*"
            r"command: rtsim sweep first; since",
        ):
            run_sweep(spec, out, workers=1)
    assert len(run_sweep(spec, out, workers=1)) == 2  # released


def test_the_lock_dies_with_its_holder_and_a_second_cli_run_exits_2(tmp_path: Path) -> None:
    spec = _write(
        tmp_path, '[sweep]\nkind = "call"\nfunction = "sweep_helpers:echo"\n[grid]\ni = "1..2"\n'
    )
    out = tmp_path / "o"
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            (
                "import sys, time\nfrom rtsim.io.lock import lock_directory\n"
                f"with lock_directory({str(out)!r}):\n    print('held', flush=True)\n"
                "    time.sleep(60)\n"
            ),
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        r = subprocess.run(
            [
                sys.executable,
                "-m",
                "rtsim",
                "sweep",
                "--allow-code",
                str(spec),
                "--out",
                str(out),
                "--workers",
                "1",
                "--quiet",
            ],
            capture_output=True,
            text=True,
            env=os.environ | {"PYTHONPATH": str(HERE)},
            timeout=60,
        )
        assert r.returncode == 2
        assert f"in use by pid {holder.pid}" in r.stderr and r.stderr.count("\n") == 1
        holder.send_signal(signal.SIGKILL)
        holder.wait(timeout=10)
        r = subprocess.run(
            [
                sys.executable,
                "-m",
                "rtsim",
                "sweep",
                "--allow-code",
                str(spec),
                "--out",
                str(out),
                "--workers",
                "1",
                "--quiet",
            ],
            capture_output=True,
            text=True,
            env=os.environ | {"PYTHONPATH": str(HERE)},
            timeout=60,
        )
        assert r.returncode == 0, r.stderr
    finally:
        if holder.poll() is None:
            holder.kill()


# -- resume ---------------------------------------------------------------------------
def test_a_corrupt_manifest_is_reported_as_such(tmp_path: Path) -> None:
    spec = _write(
        tmp_path, '[sweep]\nkind = "call"\nfunction = "sweep_helpers:echo"\n[grid]\ni = "1..2"\n'
    )
    run_sweep(spec, tmp_path / "o", workers=1)
    (tmp_path / "o" / "manifest.json").write_text('{"fingerprint": "ab', encoding="utf-8")
    for restart in (False, True):  # not provably the sweep's: never removed, even by restart
        with pytest.raises(InputError, match=r"manifest.json that is not rtsim's") as exc:
            run_sweep(spec, tmp_path / "o", workers=1, restart=restart)
        assert "sweep file changed" not in str(exc.value)
    assert (tmp_path / "o" / "manifest.json").read_text("utf-8") == '{"fingerprint": "ab'
    for name in ("manifest.json", "results.parquet", "timings.csv"):
        (tmp_path / "o" / name).unlink()  # the user removes what is not provably rtsim's
    assert len(run_sweep(spec, tmp_path / "o", workers=1, restart=True)) == 2


def test_a_comment_only_change_to_the_base_file_keeps_the_resume(tmp_path: Path) -> None:
    base = tmp_path / "set.toml"
    text = (ROOT / "tasksets" / "barrel_robots.toml").read_text("utf-8")
    base.write_text(text, encoding="utf-8")
    spec = _write(tmp_path, '[sweep]\nkind = "bounds"\nbase = "set.toml"\n[grid]\nn = "1..2"\n')
    first = run_sweep(spec, tmp_path / "o", workers=1)
    base.write_text("# a new comment\n" + text.replace("\n[", "\n\n[", 3), encoding="utf-8")
    pd.testing.assert_frame_equal(first, run_sweep(spec, tmp_path / "o", workers=1))
    base.write_text(text.replace("r_H = 25", "r_H = 26"), encoding="utf-8")
    with pytest.raises(SweepError, match="the sweep file changed"):
        run_sweep(spec, tmp_path / "o", workers=1)


def test_histogram_files_of_tasks_with_unsafe_names_do_not_collide() -> None:
    from rtsim.validate.histogram import _safe

    names = ["a/b", "a_b", "a:b", "a b", "A_b", ".x", "window"]
    safe = [_safe(n) for n in names]
    assert len(set(safe)) == len(names)
    assert _safe("a_b") == "a_b" and _safe("window") == "window"
    assert all("/" not in s and ":" not in s and " " not in s for s in safe)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.text(min_size=1, max_size=6), min_size=2, max_size=8, unique=True))
def test_histogram_names_are_distinct_for_distinct_task_names(names: list[str]) -> None:
    from rtsim.validate.histogram import _safe

    safe = [_safe(n) for n in names]
    assert len(set(safe)) == len(names)


def test_validate_locks_its_output_directory(tmp_path: Path) -> None:
    from rtsim.validate.runner import QUICK, run_validation

    with lock_directory(tmp_path / "v", ["rtsim", "validate", "first"]):
        with pytest.raises(DirectoryLocked, match="command: rtsim validate first"):
            run_validation(tmp_path / "v", QUICK, workers=1)
    assert not (tmp_path / "v" / "sweeps").exists()


# -- temporary files of a write killed by kill -9 ------------------------------------------
def _killed_while_writing(target: Path) -> Path:
    """Kill -9 a process in the middle of an atomic write of ``target``; the temporary file
    it leaves (named by the writer itself, not by the test)."""
    code = (
        "import os, sys, time\nfrom rtsim.io.atomic import atomic_path\n"
        f"with atomic_path({str(target)!r}) as tmp:\n"
        "    tmp.write_bytes(b'half')\n    print(tmp, flush=True)\n    time.sleep(60)\n"
    )
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        assert p.stdout is not None
        left = Path(p.stdout.readline().strip())
        p.send_signal(signal.SIGKILL)
        p.wait(timeout=10)
    finally:
        if p.poll() is None:
            p.kill()
    assert left.is_file() and left.parent == target.parent
    return left


@pytest.mark.parametrize(
    "names", [["results.parquet"], ["timings.csv", "manifest.json"], ["points/"]]
)
@pytest.mark.parametrize("restart", [False, True])
def test_a_write_killed_by_kill_9_never_blocks_the_resume(
    tmp_path: Path, names: list[str], restart: bool
) -> None:
    """Issue 35 (7): a ``.results.parquet.*.tmp`` (or timings', manifest's) left by kill -9
    made every later sweep refuse the directory, --restart included, and point files'
    temporary files were never removed: they are the sweep's own, removed under the lock."""
    spec = _write(
        tmp_path, '[sweep]\nkind = "call"\nfunction = "sweep_helpers:echo"\n[grid]\ni = "1..3"\n'
    )
    out = tmp_path / "o"
    first = run_sweep(spec, out, workers=1)
    left = []
    for name in names:
        if name == "points/":
            point = next((out / "points").glob("*.json"))
            left.append(_killed_while_writing(point))
        else:
            left.append(_killed_while_writing(out / name))
    again = run_sweep(spec, out, workers=1, restart=restart)
    assert not any(f.exists() for f in left)
    pd.testing.assert_frame_equal(
        again.drop(columns=[c for c in again if "time" in c]),
        first.drop(columns=[c for c in first if "time" in c]),
    )


def test_temporary_files_of_what_the_sweep_does_not_make_are_still_refused(tmp_path: Path) -> None:
    spec = _write(
        tmp_path, '[sweep]\nkind = "call"\nfunction = "sweep_helpers:echo"\n[grid]\ni = "1..2"\n'
    )
    out = tmp_path / "o"
    run_sweep(spec, out, workers=1)
    for bad, kind in [
        (".notes.txt.abcd1234.tmp", "file"),
        (".results.parquet.abcd1234.tmp", "dir"),
    ]:
        p = out / bad
        p.mkdir() if kind == "dir" else p.write_text("mine")
        with pytest.raises(InputError, match="did not make"):
            run_sweep(spec, out, workers=1, restart=True)
        assert p.exists()
        p.rmdir() if kind == "dir" else p.unlink()


def test_cli_sweep_resumes_after_a_killed_write(tmp_path: Path) -> None:
    spec = _write(
        tmp_path, '[sweep]\nkind = "call"\nfunction = "sweep_helpers:echo"\n[grid]\ni = "1..2"\n'
    )
    out = tmp_path / "o"
    args = ["sweep", "--allow-code", str(spec), "--out", str(out), "--workers", "1", "--quiet"]
    assert main(args) == 0
    left = _killed_while_writing(out / "results.parquet")
    assert main(args) == 0 and not left.exists()
    left = _killed_while_writing(out / "manifest.json")
    assert main([*args, "--restart"]) == 0 and not left.exists()


def test_validate_directory_temporary_files_are_removed_under_the_lock(tmp_path: Path) -> None:
    """The same rule for ``validate``'s directory (its report, its summary)."""
    from rtsim.io.manifest import write_manifest
    from rtsim.io.outdir import check_resumable
    from rtsim.validate.runner import MADE

    out = tmp_path / "v"
    write_manifest(out, command="validate", seed=0, inputs={})
    left = [_killed_while_writing(out / n) for n in ("summary.json", "report.html")]
    check_resumable(out, "validate", MADE, before_manifest={"sweeps"})
    assert all(f.exists() for f in left)  # tolerated outside the lock
    check_resumable(out, "validate", MADE, before_manifest={"sweeps"}, clean=True)
    assert not any(f.exists() for f in left)
