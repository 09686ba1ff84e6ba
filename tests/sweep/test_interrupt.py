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


CASES = [
    ("2", signal.SIGINT, True),  # Ctrl-C in a terminal: the whole process group
    ("1", signal.SIGTERM, False),  # kill PID: the sweep process alone
    ("2", signal.SIGTERM, False),  # kill PID of a sweep with workers
    ("1", signal.SIGINT, True),
]
IDS = ["sigint-group-2-workers", "sigterm-serial", "sigterm-2-workers", "sigint-group-serial"]


@pytest.mark.parametrize(("workers", "sig", "group"), CASES, ids=IDS)
def test_interrupted_sweep_resumes_without_recomputing(
    tmp_path: Path,
    sweep_file: Path,
    reference: pd.DataFrame,
    workers: str,
    sig: signal.Signals,
    group: bool,
) -> None:
    """Ctrl-C: ``rtsim: interrupted``, exit 130; SIGTERM: ``rtsim: terminated``, exit 143
    (docs/reliability.md); no traceback, no other line; the rerun computes each missing
    point once."""
    _interrupt_and_resume(tmp_path, sweep_file, reference, (workers, sig, group))


def _interrupt_and_resume(
    tmp_path: Path,
    sweep_file: Path,
    reference: pd.DataFrame,
    case: tuple[str, signal.Signals, bool],
    timeout: float = 60,
) -> None:
    workers, sig, group = case
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
        _, err = proc.communicate(timeout=timeout)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    code, word = (143, b"terminated") if sig == signal.SIGTERM else (130, b"interrupted")
    assert proc.returncode == code, err
    assert err.strip().splitlines()[-1] == b"rtsim: " + word, err
    assert b"Traceback" not in err and b"Exception ignored" not in err, err
    assert [x for x in err.splitlines() if x.strip() and not x.startswith(b"rtsim: ")] == [], err
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


@pytest.mark.slow
def test_interrupts_in_a_loop_under_a_cpu_hog(
    tmp_path: Path, sweep_file: Path, reference: pd.DataFrame
) -> None:
    """Issue 35 (8): about one Ctrl-C in four of ``sweep --workers 2`` printed a traceback
    (``Exception ignored in: <module 'threading'> ... OSError: [Errno 9] Bad file
    descriptor``) and the exit could hang on the pool's manager thread. Every case above,
    three times over, with two processes spinning on the CPU; bounded: each run must end
    within 30 s of its signal, and the loop within 10 minutes."""
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
    start = time.monotonic()
    try:
        for round_ in range(3):
            for case, name in zip(CASES, IDS, strict=True):
                d = tmp_path / f"{round_}-{name}"
                d.mkdir()
                _interrupt_and_resume(d, sweep_file, reference, case, timeout=30)
                assert time.monotonic() - start < 600
    finally:
        for h in hogs:
            h.kill()
            h.wait()
