"""A sweep stopped by a real signal to a real ``python -m rtsim sweep`` resumes exactly."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from rtsim.sweep import run_sweep

# the sweep files here name their helper functions (code): the user opts in
pytestmark = pytest.mark.usefixtures("allow_code")

HERE = Path(__file__).resolve().parents[1]
N = 8


def _env(log: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(HERE), *filter(None, [env.get("PYTHONPATH")])])
    env["RTSIM_SWEEP_TEST_LOG"] = str(log)
    # points from sweep_helpers.GATE_FROM on wait for this file: the first run cannot finish
    # before it is interrupted, however loaded the machine; the rerun finds it
    env["RTSIM_SWEEP_TEST_GATE"] = str(log.parent / "gate")
    return env


def _calls(log: Path) -> list[int]:
    return [int(x) for x in log.read_text().split()] if log.exists() else []


@pytest.fixture(scope="module")
def sweep_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("spec") / "slow.toml"
    path.write_text(
        '[sweep]\nkind = "call"\nfunction = "sweep_helpers:slow"\nseed = 5\n'
        f'[sweep.options]\nsleep = 0.15\n[grid]\ni = "0..{N - 1}"\n'
    )
    return path


@pytest.fixture(scope="module")
def reference(sweep_file: Path, tmp_path_factory: pytest.TempPathFactory) -> pd.DataFrame:
    sys.path.insert(0, str(HERE))
    try:
        return run_sweep(sweep_file, tmp_path_factory.mktemp("ref"), workers=1, allow_code=True)
    finally:
        sys.path.remove(str(HERE))


@pytest.mark.parametrize(
    ("workers", "sig", "group"),
    [
        ("2", signal.SIGINT, True),  # Ctrl-C in a terminal: the whole process group
        ("1", signal.SIGTERM, False),  # kill PID: the sweep process alone
    ],
    ids=["sigint-group-2-workers", "sigterm-serial"],
)
def test_interrupted_sweep_resumes_without_recomputing(
    tmp_path: Path,
    sweep_file: Path,
    reference: pd.DataFrame,
    workers: str,
    sig: signal.Signals,
    group: bool,
) -> None:
    out = tmp_path / "out"
    cmd = [
        sys.executable,
        "-m",
        "rtsim",
        "sweep",
        "--allow-code",
        str(sweep_file),
        "--out",
        str(out),
        "--workers",
        workers,
    ]
    log1 = tmp_path / "run1.log"
    proc = subprocess.Popen(
        cmd, env=_env(log1), stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True
    )
    try:
        deadline = time.monotonic() + 60
        while len(list((out / "points").glob("*.json"))) < 3:
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, "sweep made no progress"
            time.sleep(0.02)
        if group:
            os.killpg(proc.pid, sig)
        else:
            proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130, err
    assert b"interrupted" in err and b"Traceback" not in err
    finished = {f.name: f.stat().st_mtime_ns for f in (out / "points").glob("*.json")}
    done = {int(name.split("-")[0]) for name in finished}
    assert 3 <= len(done) < N
    assert not (out / "results.parquet").exists()
    # Stopped workers do not go on computing after the sweep exited.
    calls_at_exit = _calls(log1)
    time.sleep(0.4)
    assert _calls(log1) == calls_at_exit

    log2 = tmp_path / "run2.log"
    (tmp_path / "gate").touch()
    rerun = subprocess.run(cmd, env=_env(log2), capture_output=True, timeout=120)
    assert rerun.returncode == 0, rerun.stderr
    recomputed = set(_calls(log2))
    assert recomputed.isdisjoint(done)
    assert recomputed | done == set(range(N))
    assert len(_calls(log2)) == len(recomputed)  # each missing point exactly once
    for name, mtime in finished.items():
        assert (out / "points" / name).stat().st_mtime_ns == mtime
    pd.testing.assert_frame_equal(pd.read_parquet(out / "results.parquet"), reference)
