"""One front door for limits (the library refuses what the command line refuses, with
``force=True`` as ``--force``), one-line refusals of hostile inputs, and pool workers that
exit with their parent."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rtsim.cli import main
from rtsim.coupling import run_scenario
from rtsim.errors import InputError
from rtsim.io import work
from rtsim.io.work import TooMuchWork
from rtsim.model import Task
from rtsim.sim import simulate

ROOT = Path(__file__).resolve().parents[2]
BARREL = ROOT / "tasksets" / "barrel_robots.toml"
EXAMPLE = ROOT / "tasksets" / "example.toml"


def test_library_refuses_what_the_cli_refuses() -> None:
    with pytest.raises(InputError, match=r"duration_s: 1e\+300 s is outside"):
        run_scenario("test2", duration_s=1e300)
    with pytest.raises(TooMuchWork, match="processing windows.*--force"):
        run_scenario("test2", duration_s=1e6)
    with pytest.raises(TooMuchWork, match=r"1e\+12 jobs"):
        simulate([Task(name="a", wcet=1e-6, period=1e-3)], 1e9)
    for call in (
        lambda: simulate([Task(name="a", wcet=1, period=10)], 100, seed=2**80),
        lambda: run_scenario("test2", duration_s=1, seed=2**80),
    ):
        with pytest.raises(InputError, match=r"outside \[0, 2\*\*63 - 1\]"):
            call()


def test_force_is_the_clis_force(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(work.LIMITS, "jobs", 50)  # 100 jobs: above, but cheap to run
    tasks = [Task(name="a", wcet=1, period=10)]
    with pytest.raises(TooMuchWork):
        simulate(tasks, 1000)
    assert simulate(tasks, 1000, force=True).tasks["a"].released == 100
    monkeypatch.setitem(work.LIMITS, "windows", 5)
    with pytest.raises(TooMuchWork):
        run_scenario("test2", duration_s=2)
    assert run_scenario("test2", duration_s=2, force=True, record_jobs=False).summary["windows"]


def test_the_overload_backlog_is_counted(capsys: pytest.CaptureFixture[str]) -> None:
    """A window far below the chain's processing time overloads the CPU: every window's
    jobs queue (finish-late), so the estimate is the jobs released; refused up front."""
    assert main(["simulate", str(BARREL), "--window", "0.001", "--horizon", "30000"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "jobs waiting at once" in err
    from rtsim.config.taskset import load_taskset

    ts = load_taskset(BARREL)
    released = work.simulate_jobs(ts, 1000.0, 0.001)
    assert work.simulate_backlog(ts, 1000.0, 0.001) > 0.9 * released  # all but a few
    assert work.simulate_backlog(ts, 1e7, None) == 0  # at w_sch: schedulable
    from rtsim.model import TaskSet

    under = [
        Task(name="a", wcet=1, period=10, priority=1, overload="skip"),
        Task(name="b", wcet=10, period=10, priority=2),
    ]
    assert work.simulate_backlog(load_taskset(EXAMPLE), 1e6, None) == 0
    assert work.simulate_backlog(TaskSet(tuple(under)), 100.0, None) == 10  # b's jobs only


def test_example_taskset_in_a_scenario_is_not_the_papers(tmp_path: Path) -> None:
    text = (ROOT / "rtsim" / "data" / "scenarios" / "test2.toml").read_text("utf-8")
    p = tmp_path / "s.toml"
    p.write_text(text.replace('taskset = "barrel_robots"', 'taskset = "example"'), "utf-8")
    from rtsim.config.scenario import load_scenario

    with pytest.raises(InputError, match="'example' has no \\[window\\]"):
        load_scenario(p).load_taskset()


def test_a_fifo_input_is_refused_at_once(tmp_path: Path) -> None:
    fifo = tmp_path / "set.toml"
    os.mkfifo(fifo)
    proc = subprocess.run(
        [sys.executable, "-m", "rtsim", "analyze", str(fifo)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2 and "FIFO" in proc.stderr
    assert proc.stderr.count("\n") == 1


def test_a_socket_input_is_refused_at_once(tmp_path: Path) -> None:
    import socket

    path = tmp_path / "s.toml"
    with socket.socket(socket.AF_UNIX) as sock:
        sock.bind(str(path))
        proc = subprocess.run(
            [sys.executable, "-m", "rtsim", "analyze", str(path)],
            capture_output=True,
            text=True,
            timeout=60,
        )
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert proc.stderr.startswith(f"rtsim: {path}: ") and "Traceback" not in proc.stderr


_DEEP = 100_000


@pytest.mark.parametrize(
    ("argv", "body"),
    [
        (["analyze", "{f}"], "x = " + "[" * _DEEP + "]" * _DEEP + "\n"),
        (["analyze", "{f}"], "x = " + "{a = " * 5_000 + "1" + "}" * 5_000 + "\n"),
        (["scenario", "{f}", "--out", "{o}"], "x = " + "[" * _DEEP + "]" * _DEEP + "\n"),
        (
            ["sweep", "{f}", "--out", "{o}"],
            '[sweep]\nkind = "analyze"\n[grid]\nn = ' + "[" * _DEEP + "]" * _DEEP + "\n",
        ),
    ],
    ids=["taskset-arrays", "taskset-tables", "scenario", "sweep"],
)
def test_deeply_nested_toml_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], body: str
) -> None:
    """tomllib recurses once per level: a file nested 1e5 deep would end in a
    RecursionError; it is one line naming the file, exit 2, and nothing is written."""
    f = tmp_path / "deep.toml"
    f.write_text(body, "utf-8")
    out = tmp_path / "out"
    assert main([a.format(f=f, o=out) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"rtsim: {f}: nested too deeply"), err
    assert not out.exists()


def test_a_name_with_a_newline_stays_on_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    p = tmp_path / "t.toml"
    p.write_text('[[tasks]]\nname = "a\\nrtsim: fake"\nwcet = 1\nperiod = 10\n', "utf-8")
    assert main(["simulate", str(p), "--horizon", "100", "--exec", "uniform"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "a\\nrtsim: fake" in err


def test_an_abstract_scheduler_is_refused_up_front(capsys: pytest.CaptureFixture[str]) -> None:
    assert (
        main(
            [
                "simulate",
                str(EXAMPLE),
                "--horizon",
                "100",
                "--scheduler",
                "rtsim.sim.policy:SchedulingPolicy",
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "does not implement order" in err


def _children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(x) for x in text.split()]


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_reproduce_workers_exit_when_the_parent_is_killed(tmp_path: Path) -> None:
    """kill -9 of ``reproduce --workers 2``: its workers exit (releasing the staging
    directory's lock), and the next run's cleanup leaves no stray file."""
    out = tmp_path / "paper"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "rtsim",
            "reproduce",
            "--quick",
            "--workers",
            "2",
            "--quiet",
            "--out",
            str(out),
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 120
    while len(kids := _children(proc.pid)) < 2:
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.1)
    time.sleep(1.0)  # the workers are running scenarios
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    deadline = time.monotonic() + 30
    while any(_alive(k) for k in kids):
        assert time.monotonic() < deadline, "workers outlived their parent"
        time.sleep(0.1)
    from rtsim.io.outdir import clean_leftovers

    assert clean_leftovers(out)  # the killed run's staging directory, lock free
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("spec", [":", ".x:Y"])
def test_malformed_policy_strings_are_one_line(
    spec: str, capsys: pytest.CaptureFixture[str]
) -> None:
    for argv in (
        ["simulate", str(EXAMPLE), "--horizon", "100", "--scheduler", spec],
        ["scenario", "test2", "--duration", "1", "--policy", spec, "--out", "o"],
    ):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("rtsim: ") and spec in err
