"""Task-set files: the generic shape, the paper's set, priorities, and every bad input."""

from __future__ import annotations

import json
import os
import re
import tomllib
from pathlib import Path

import pytest

from rtsim.config.taskset import load_taskset, parse_taskset, taskset_to_dict
from rtsim.errors import TaskSetError

REPO = Path(__file__).resolve().parents[2]

GENERIC = """
name = "example"
[[tasks]]
name = "tau1"
wcet = 5
period = 40
deadline = 40
priority = 1
offset = 0
bcet = 3
"""

TWO = """
[[tasks]]
name = "a"
wcet = 1
period = 10
{a}
[[tasks]]
name = "b"
wcet = 2
period = 20
{b}
"""


def test_generic_shape_is_accepted_exactly(tmp_toml):
    ts = load_taskset(tmp_toml(GENERIC))
    (t,) = ts.tasks
    assert ts.name == "example"
    assert (t.name, t.wcet, t.period, t.deadline, t.priority, t.offset, t.bcet) == (
        "tau1",
        5.0,
        40.0,
        40.0,
        1,
        0.0,
        3.0,
    )
    assert ts.window is None and ts.source == str(tmp_toml(GENERIC))


def test_defaults(tmp_toml):
    ts = load_taskset(tmp_toml('[[tasks]]\nname = "x"\nwcet = 1.5\nperiod = 7\n'))
    (t,) = ts.tasks
    assert (t.deadline, t.offset, t.bcet, t.overload, t.priority) == (
        7.0,
        0.0,
        None,
        "finish-late",
        1,
    )
    assert ts.name == ""


def test_packaged_set_is_table_1(paper_ts):
    with open(REPO / "tasksets" / "barrel_robots.toml", "rb") as fh:
        raw = tomllib.load(fh)
    w = paper_ts.window
    assert w is not None
    for key, value in raw["window"].items():
        assert getattr(w, key) == value
    assert [t.name for t in paper_ts.hp] == ["dead_reckoning"]
    assert [t.name for t in paper_ts.lp] == ["command"]
    cmd = paper_ts.task("command")
    assert cmd.per_window and cmd.period == 2.0 and cmd.deadline == 2.0
    assert cmd.at_window(100.0).period == 200.0
    assert set(paper_ts.assumptions) >= {"e_cal", "e_trans", "e_sched", "k"}


def test_shipped_copies_are_identical():
    a = (REPO / "tasksets" / "barrel_robots.toml").read_bytes()
    b = (REPO / "rtsim" / "data" / "barrel_robots.toml").read_bytes()
    assert a == b


def test_load_by_path_equals_packaged(paper_ts):
    ts = load_taskset(REPO / "tasksets" / "barrel_robots.toml")
    assert ts.tasks == paper_ts.tasks and ts.window == paper_ts.window


@pytest.mark.parametrize("text,mult", [("w", 1.0), ("2w", 2.0), ("1.5w", 1.5), (" 3 w ", 3.0)])
def test_window_multiples(tmp_toml, paper_ts, text, mult):
    data = taskset_to_dict(paper_ts)
    data["tasks"][1]["period"] = text
    del data["tasks"][1]["deadline"]
    cmd = parse_taskset(data, "f.toml").task("command")
    assert cmd.per_window and cmd.period == mult and cmd.deadline == mult


def test_deadline_monotonic_with_ties_in_file_order(tmp_toml):
    text = "".join(
        f'[[tasks]]\nname = "{n}"\nwcet = 1\nperiod = 100\ndeadline = {d}\n'
        for n, d in [("a", 50), ("b", 20), ("c", 50), ("d", 10)]
    )
    ts = load_taskset(tmp_toml(text))
    assert [(t.name, t.priority) for t in ts.tasks] == [("d", 1), ("b", 2), ("a", 3), ("c", 4)]


def test_explicit_priorities_are_kept(tmp_toml):
    ts = load_taskset(tmp_toml(TWO.format(a="priority = 7", b="priority = -2")))
    assert [(t.name, t.priority) for t in ts.tasks] == [("b", -2), ("a", 7)]


def test_round_trip_through_json(paper_ts, tmp_toml):
    for ts in (paper_ts, load_taskset(tmp_toml(GENERIC))):
        data = json.loads(json.dumps(taskset_to_dict(ts)))
        back = parse_taskset(data, "again")
        assert back.tasks == ts.tasks
        assert back.window == ts.window
        assert dict(back.assumptions) == dict(ts.assumptions)
        assert back.name == ts.name and back.source == "again"


def test_round_trip_non_integer_multiple(paper_ts):
    data = taskset_to_dict(paper_ts)
    data["tasks"][1]["period"] = data["tasks"][1]["deadline"] = "0.1w"
    ts = parse_taskset(data, "x")
    again = parse_taskset(json.loads(json.dumps(taskset_to_dict(ts))), "x")
    assert again.task("command").period == 0.1


BASE = '[[tasks]]\nname = "tau1"\n'


@pytest.mark.parametrize(
    "text,pattern",
    [
        ("[[tasks]\nname=1", r": malformed TOML: "),
        (
            BASE + "wcet = 5\nperod = 40\n",
            r": task 'tau1': unknown key 'perod' \(did you mean 'period'\?\)$",
        ),
        (BASE + "wcet = 5\n", r": task 'tau1': period: missing \(required\)$"),
        ("[[tasks]]\nwcet = 5\nperiod = 4\n", r": \[\[tasks\]\] #1: name: missing"),
        (
            BASE + "wcet = 5\nperiod = 40\n[[tasks]]\nwcet = 1\nperiod = 3\n",
            r": \[\[tasks\]\] #2: name: missing",
        ),
        (BASE + "wcet = 0\nperiod = 40\n", r": task 'tau1': wcet: must be positive, got 0$"),
        (BASE + "wcet = -1\nperiod = 40\n", r": task 'tau1': wcet: must be positive"),
        (BASE + "wcet = 1\nperiod = inf\n", r": task 'tau1': period: must be finite"),
        (BASE + "wcet = nan\nperiod = 4\n", r": task 'tau1': wcet: must be finite"),
        (
            BASE + "wcet = 1\nperiod = 4\ndeadline = 0\n",
            r": task 'tau1': deadline: must be positive",
        ),
        (BASE + 'wcet = "5"\nperiod = 40\n', r": task 'tau1': wcet: must be a number, got '5'"),
        (BASE + "wcet = true\nperiod = 40\n", r": task 'tau1': wcet: must be a number, got True"),
        (
            BASE + "wcet = 1\nperiod = 40\npriority = 1.0\n",
            r": task 'tau1': priority: must be an integer",
        ),
        (
            BASE + "wcet = 1\nperiod = 40\npriority = true\n",
            r": task 'tau1': priority: must be an integer",
        ),
        (BASE + "wcet = 1\nperiod = [40]\n", r": task 'tau1': period: must be a number"),
        (BASE + 'wcet = 1\nperiod = "2x"\n', r": task 'tau1': period: must be a number \(ms\) or"),
        (BASE + "wcet = 3\nperiod = 40\nbcet = 4\n", r": task 'tau1': bcet: 4 is above wcet 3$"),
        (
            BASE + "wcet = 3\nperiod = 40\noffset = -1\n",
            r": task 'tau1': offset: must be non-negative",
        ),
        (BASE + 'wcet = 3\nperiod = 40\noverload = "drop"\n', r": task 'tau1': overload: must"),
        (BASE + 'wcet = 3\nperiod = "2w"\n', r": task 'tau1': period: '2w' is a multiple of"),
        (
            BASE + 'wcet = 3\nperiod = 40\n[[tasks]]\nname = "tau1"\nwcet = 1\nperiod = 3\n',
            r": task 'tau1': name: duplicate of \[\[tasks\]\] #1$",
        ),
        (
            TWO.format(a="priority = 1", b="priority = 1"),
            r": task 'b': priority: 1 is already used by task 'a' \(tasks share a priority "
            r"only under a time-sliced policy: \[scheduler\] policy = \"rr\" with a quantum\)$",
        ),
        (TWO.format(a="priority = 1", b=""), r": task 'b': priority: missing, but task 'a'"),
        (TWO.format(a="", b="priority = 1"), r": task 'a': priority: missing, but task 'b'"),
        ('name = "empty"\n', r": tasks: no \[\[tasks\]\] in the file$"),
        ("tasks = []\n", r": tasks: no \[\[tasks\]\]"),
        ("tasks = 3\n", r": tasks: must be an array of tables"),
        ('nmae = "x"\n' + BASE, r": unknown key 'nmae' \(did you mean 'name'\?\)$"),
        (
            BASE + "wcet = 3\nperiod = 40\n[assumptions]\ne_cal = 1\n",
            r": \[assumptions\]: e_cal: must be a string",
        ),
    ],
)
def test_bad_input_names_file_task_and_field(tmp_toml, text, pattern):
    path = tmp_toml(text)
    with pytest.raises(TaskSetError) as info:
        load_taskset(path)
    # every problem of the file at once, one line each, each naming the file
    lines = str(info.value).split("\n")
    assert all(line.startswith(str(path) + ": ") for line in lines), lines
    assert any(re.search(pattern, line) for line in lines), (pattern, lines)


def test_unknown_key_is_reported_before_missing_key(tmp_toml):
    # 'perod' is unknown and 'period' is missing: the typo wins.
    with pytest.raises(TaskSetError, match="unknown key 'perod'"):
        load_taskset(tmp_toml(BASE + "perod = 40\n"))


WINDOW = """
[window]
priority = 2
n = 2
r_H = 25
e_cal = 0.001
e_trans = 0.1
k = 34
e_scan = 106
e_estimate = 1
e_send = 2
e_recv = 1
delta_t = 67
e_sched = 1
"""


@pytest.mark.parametrize(
    "window,tasks,pattern",
    [
        (WINDOW, TWO.format(a="", b=""), r": task 'a': priority: missing \(required when"),
        (
            WINDOW.replace("priority = 2\n", ""),
            TWO.format(a="priority = 1", b="priority = 3"),
            r": \[window\]: priority: missing \(required\)$",
        ),
        (
            WINDOW,
            TWO.format(a="priority = 1", b="priority = 2"),
            r": task 'b': priority: 2 is already used by \[window\] 'window' \(tasks share",
        ),
        (
            WINDOW.replace("n = 2", "n = 0"),
            TWO.format(a="priority = 1", b="priority = 3"),
            r": \[window\]: n: must be an integer >= 1, got 0$",
        ),
        (
            WINDOW.replace("n = 2", "n = 2.5"),
            TWO.format(a="priority = 1", b="priority = 3"),
            r": \[window\]: n: must be an integer",
        ),
        (
            WINDOW.replace("r_H = 25", "r_H = -25"),
            TWO.format(a="priority = 1", b="priority = 3"),
            r": \[window\]: r_H: must be positive",
        ),
        (
            WINDOW.replace("delta_t = 67", "dleta_t = 67"),
            TWO.format(a="priority = 1", b="priority = 3"),
            r": \[window\]: unknown key 'dleta_t' \(did you mean 'delta_t'\?\)$",
        ),
        (
            WINDOW,
            TWO.format(a="priority = 1", b='priority = 3\nname2 = "x"'),
            r": task 'b': unknown key 'name2'",
        ),
        (
            WINDOW,
            TWO.format(a="priority = 1", b='priority = 3\ndeadline = "2w"'),
            r": task 'b': deadline: '2w' and period 20 must both be",
        ),
        (
            WINDOW,
            TWO.format(a="priority = 1", b="priority = 3").replace('"b"', '"window"'),
            r": task 'window': name: duplicate of the \[window\]$",
        ),
    ],
)
def test_bad_window_sets(tmp_toml, window, tasks, pattern):
    with pytest.raises(TaskSetError, match=pattern):
        load_taskset(tmp_toml(window + tasks))


def test_window_set_with_per_window_lp(tmp_toml):
    text = WINDOW + TWO.format(a="priority = 1", b="priority = 3").replace(
        "period = 20", 'period = "2w"'
    )
    ts = load_taskset(tmp_toml(text))
    assert [t.name for t in ts.hp] == ["a"] and [t.name for t in ts.lp] == ["b"]


def test_missing_file(tmp_path):
    path = tmp_path / "nope.toml"
    with pytest.raises(TaskSetError, match=r"nope\.toml: no such file$"):
        load_taskset(path)


def test_directory(tmp_path):
    with pytest.raises(TaskSetError, match=r": is a directory"):
        load_taskset(tmp_path)


def test_unreadable_file(tmp_toml, monkeypatch):
    path = tmp_toml(GENERIC)
    if os.name == "posix" and os.geteuid() != 0:
        path.chmod(0)
    else:  # root reads anything: make open() fail the way chmod 0 would
        import rtsim.io.limits as mod  # (task-set files are read by read_input)

        def deny(*args, **kwargs):
            raise PermissionError(13, "Permission denied")

        monkeypatch.setattr(mod, "open", deny, raising=False)
    try:
        with pytest.raises(TaskSetError, match=r"set\.toml: cannot read: Permission denied$"):
            load_taskset(path)
    finally:
        path.chmod(0o644)


@pytest.mark.parametrize("data", [b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", b'name = "\xff\xfe"\n'])
def test_binary_file(tmp_toml, data):
    with pytest.raises(TaskSetError, match=r": not a text file"):
        load_taskset(tmp_toml(data))


def test_deadline_above_period_is_accepted_and_analysed(tmp_toml):
    from rtsim.analysis.rta import analyze

    text = (
        '[[tasks]]\nname = "a"\nwcet = 2\nperiod = 5\n'
        '[[tasks]]\nname = "b"\nwcet = 4\nperiod = 7\ndeadline = 20\n'
    )
    ts = load_taskset(tmp_toml(text))
    assert ts.task("b").deadline == 20.0
    # By hand (level-i busy period): job 0 ends at w = 4 + 2⌈w/5⌉ = 8 (> 7: the busy period
    # goes on), job 1 at w = 8 + 2⌈w/5⌉ = 14 (response 7), 14 ≤ 2·7 closes it: WCRT 8.
    res = analyze(ts)
    assert res.tasks[1].wcrt == 8.0 and res.schedulable
