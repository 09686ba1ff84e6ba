"""``rtsim analyze`` and ``rtsim bounds``: output shapes, exit codes, one-line input errors."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from rtsim.analysis.bounds import window_bounds
from rtsim.cli import main
from rtsim.config.taskset import load_taskset

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = str(REPO / "tasksets" / "example.toml")
PAPER = str(REPO / "tasksets" / "barrel_robots.toml")


def strict_json(text: str):
    """json.loads that refuses NaN / Infinity tokens."""

    def bad(token: str):
        raise AssertionError(f"non-finite JSON token {token}")

    return json.loads(text, parse_constant=bad)


def run(capsys, *argv: str) -> tuple[int, str, str]:
    rc = main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def test_analyze_table(capsys):
    rc, out, err = run(capsys, "analyze", EXAMPLE)
    assert rc == 0 and err == ""
    rows = {
        line.split()[1]: line.split()
        for line in out.splitlines()
        if line.split() and line.split()[0].isdigit()
    }
    assert rows["tau1"][6] == "5.000" and rows["tau2"][6] == "230.000"
    assert rows["tau3"][6] == "490.000" and all(r[7] == "yes" for r in rows.values())
    assert "Liu-Layland" in out and "hyperbolic" in out
    assert out.rstrip().endswith("schedulable (exact response-time analysis): yes")


def test_analyze_window_set_says_which_w(capsys):
    rc, out, _ = run(capsys, "analyze", PAPER)
    assert rc == 0 and "w = 237.402 ms (w_sch)" in out
    rc, out, _ = run(capsys, "analyze", PAPER, "--window", "250")
    assert rc == 0 and "w = 250.000 ms (--window)" in out


def test_analyze_json_shape(capsys):
    rc, out, _ = run(capsys, "analyze", PAPER, "--json", "--window", "230")
    assert rc == 0
    d = strict_json(out)
    assert d["schedulable"] is False and d["w"] == 230.0 and d["w_from"] == "--window"
    names = [t["name"] for t in d["tasks"]]
    assert names == ["dead_reckoning", "window", "command"]
    for t in d["tasks"]:
        assert {"name", "priority", "wcet", "period", "deadline", "wcrt", "schedulable"} <= set(t)
    cmd = d["tasks"][2]
    assert cmd["wcrt"] is None and cmd["schedulable"] is False and cmd["period"] == 460.0
    assert d["tasks"][1]["wcrt"] == pytest.approx(d["tasks"][1]["wcet"] + 30)


OVERLOADED = (
    '[[tasks]]\nname = "a"\nwcet = 6\nperiod = 10\n[[tasks]]\nname = "b"\nwcet = 6\nperiod = 12\n'
)


def test_check_exit_status(capsys, tmp_toml):
    path = str(tmp_toml(OVERLOADED))
    assert run(capsys, "analyze", path)[0] == 0
    assert run(capsys, "analyze", path, "--check")[0] == 1
    assert run(capsys, "analyze", path, "--check", "--json")[0] == 1
    assert run(capsys, "analyze", EXAMPLE, "--check")[0] == 0


def test_bounds_default_single(capsys):
    rc, out, _ = run(capsys, "bounds", "--json")
    assert rc == 0
    d = strict_json(out)
    want = window_bounds(load_taskset()).as_dict()
    from rtsim.analysis.bounds import w_txn

    assert d == json.loads(json.dumps({**want, "w_txn": w_txn(load_taskset())}))
    assert {
        "n",
        "r_H",
        "e_cal",
        "e_trans",
        "k",
        "e_scan",
        "e_estimate",
        "e_send",
        "e_recv",
        "delta_t",
        "e_sched",
        "hp",
        "lp",
    } <= set(d["inputs"])
    assert {"e_hough", "g", "w_eq7", "w_eq11", "w_sch", "w_rta"} <= set(d)
    assert d["inputs"]["hp"][0] == {"name": "dead_reckoning", "e": 5, "p": 40, "priority": 1}
    rc, out, _ = run(capsys, "bounds")
    assert rc == 0 and "w_sch" in out and "237.402" in out and "235.227" in out


def test_bounds_lists_and_ranges(capsys):
    rc, out, _ = run(
        capsys, "bounds", PAPER, "--followers", "1..3", "--hough-radius", "10,20", "--json"
    )
    assert rc == 0
    rows = strict_json(out)
    assert [(r["inputs"]["n"], r["inputs"]["r_H"]) for r in rows] == [
        (1, 10),
        (1, 20),
        (2, 10),
        (2, 20),
        (3, 10),
        (3, 20),
    ]
    ts = load_taskset(PAPER)
    for r in rows:
        b = window_bounds(ts, n=r["inputs"]["n"], r_H=r["inputs"]["r_H"])
        assert r["w_rta"] == b.w_rta and r["w_sch"] == b.w_sch
    rc, out, _ = run(capsys, "bounds", "--followers", "2..2", "--json")
    assert isinstance(strict_json(out), list)  # a range gives a list even of one
    rc, out, _ = run(capsys, "bounds", "--hough-radius", "10..50:10")
    table = [line for line in out.splitlines() if line.split() and line.split()[0] == "2"]
    assert rc == 0 and [float(line.split()[1]) for line in table] == [10, 20, 30, 40, 50]


def test_bounds_json_without_lp_has_null_not_infinity(capsys, tmp_toml):
    text = (REPO / "tasksets" / "barrel_robots.toml").read_text()
    text = text.split('[[tasks]]\nname = "command"')[0].replace("[assumptions]", "")
    text = text.split("[assumptions]")[0]
    rc, out, _ = run(capsys, "bounds", str(tmp_toml(text)), "--json")
    assert rc == 0
    d = strict_json(out)
    assert d["w_eq11"] is None and d["inputs"]["lp"] == [] and d["w_sch"] == d["w_eq7"]


@pytest.mark.parametrize(
    "argv,needle",
    [
        (["bounds", "--followers", "1..x"], "--followers: cannot parse range '1..x'"),
        (["bounds", "--followers", "0"], "--followers: must be at least 1"),
        (["bounds", "--followers", "2.5"], "--followers: 2.5 is not an integer"),
        (["bounds", "--followers", "5..1"], "--followers: range end is below its start"),
        (["bounds", "--hough-radius", "-5"], "--hough-radius: must be positive"),
        (["bounds", "--hough-radius", "ten"], "--hough-radius: cannot parse 'ten'"),
        (["bounds", "--hough-radius", "10..50:0"], "--hough-radius: range step must be positive"),
        (["bounds", EXAMPLE], "example.toml: has no [window]"),
        (["analyze", EXAMPLE, "--window", "100"], "--window: the task set has no [window]"),
        (["analyze", PAPER, "--window", "-3"], "--window: must be a positive number"),
        (["analyze", PAPER, "--window", "abc"], "--window: cannot parse 'abc'"),
    ],
)
def test_bad_options_exit_2_one_line(capsys, argv, needle):
    rc, out, err = run(capsys, *argv)
    assert rc == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("rtsim: ") and needle in err
    assert "Traceback" not in err


BASE = '[[tasks]]\nname = "tau1"\n'
BAD_FILES = [
    ("[[tasks]\nname=1", None, "malformed TOML"),
    (b"\x00\x01\x02binary", None, "not a text file"),
    (BASE + "wcet = 5\nperod = 40\n", "tau1", "unknown key 'perod' (did you mean 'period'?)"),
    (BASE + "wcet = 5\n", "tau1", "period: missing"),
    (BASE + "wcet = 0\nperiod = 40\n", "tau1", "wcet: must be positive"),
    (BASE + "wcet = 1\nperiod = nan\n", "tau1", "period: must be finite"),
    (BASE + "wcet = 1\nperiod = 40\ndeadline = -4\n", "tau1", "deadline: must be positive"),
    (BASE + 'wcet = "fast"\nperiod = 40\n', "tau1", "wcet: must be a number"),
    (BASE + "wcet = 3\nperiod = 40\nbcet = 5\n", "tau1", "bcet: 5 is above wcet 3"),
    (BASE + "wcet = 3\nperiod = 40\n" + BASE + "wcet = 1\nperiod = 9\n", "tau1", "name: duplicate"),
    (
        BASE + 'wcet = 3\nperiod = 40\npriority = 1\n[[tasks]]\nname = "b"\nwcet = 1\n'
        "period = 9\npriority = 1\n",
        "b",
        "priority: 1 is already used by task 'tau1'",
    ),
    (
        BASE + 'wcet = 3\nperiod = 40\npriority = 1\n[[tasks]]\nname = "b"\nwcet = 1\nperiod = 9\n',
        "b",
        "priority: missing, but task 'tau1' gives one",
    ),
    ('name = "nothing"\n', None, "no [[tasks]]"),
]


@pytest.mark.parametrize("command", ["analyze", "bounds"])
@pytest.mark.parametrize("text,task,needle", BAD_FILES)
def test_bad_files_exit_2_one_line(capsys, tmp_toml, command, text, task, needle):
    path = str(tmp_toml(text))
    rc, out, err = run(capsys, command, path)
    assert rc == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith(f"rtsim: {path}: ")
    assert needle in err and "Traceback" not in err
    if task is not None:
        assert f"task '{task}'" in err


@pytest.mark.parametrize("command", ["analyze", "bounds"])
def test_missing_file_exit_2(capsys, tmp_path, command):
    path = str(tmp_path / "absent.toml")
    rc, out, err = run(capsys, command, path)
    assert rc == 2 and err == f"rtsim: {path}: no such file\n"


def test_console_script_exit_code(tmp_path):
    script = shutil.which("rtsim", path=str(Path(sys.executable).parent))
    cmd = [script] if script else [sys.executable, "-m", "rtsim"]
    path = tmp_path / "typo.toml"
    path.write_text(BASE + "wcet = 5\nperod = 40\n")
    proc = subprocess.run([*cmd, "analyze", str(path)], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr == (
        f"rtsim: {path}: task 'tau1': unknown key 'perod' (did you mean 'period'?)\n"
    )


@pytest.mark.parametrize(
    "argv",
    [
        ["scenario", "test1", "--duration", "1", "--no-figures", "--out", "{file}"],
        ["generate", "--tasks", "3", "--utilization", "0.5", "--count", "1", "--out", "{file}"],
        ["simulate", "{taskset}", "--horizon", "100", "--jobs", "{file}/jobs.csv"],
    ],
)
def test_unwritable_output_is_one_line_exit_2(argv, tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    """An output path that is an existing file: one line naming it, exit 2, no traceback."""
    from pathlib import Path

    from rtsim.cli import main

    blocker = tmp_path / "taken"
    blocker.write_text("x")
    taskset = Path(__file__).resolve().parents[2] / "tasksets" / "example.toml"
    args = [a.format(file=blocker, taskset=taskset) for a in argv]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rtsim: ") and "taken" in err[0], err
    assert blocker.read_text() == "x"
