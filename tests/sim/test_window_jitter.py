"""The processing window's own release jitter and offset: files, analyses, simulator."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from rtsim.analysis.bounds import w_edf, w_rta, w_sch_of, w_susp
from rtsim.analysis.edf import analyze_edf
from rtsim.analysis.rta import analyze
from rtsim.cli import main
from rtsim.config.taskset import load_taskset, parse_taskset, taskset_to_dict
from rtsim.errors import TaskSetError
from rtsim.sim import simulate

PAPER = Path(__file__).resolve().parents[2] / "tasksets" / "barrel_robots.toml"


def _paper(**window: float):
    ts = load_taskset(PAPER)
    return ts.with_window(**window) if window else ts


def test_keys_in_files_round_trip_and_bad_values_are_one_line_errors():
    data = taskset_to_dict(load_taskset(PAPER))
    assert "jitter" not in data["window"] and "offset" not in data["window"]  # unchanged
    data["window"].update(jitter=3.5, offset=12)
    ts = parse_taskset(data, "f.toml")
    assert (ts.window.jitter, ts.window.offset) == (3.5, 12.0)
    back = parse_taskset(taskset_to_dict(ts), "g.toml")
    assert (back.window.jitter, back.window.offset) == (3.5, 12.0)
    chain = ts.window_task(240.0)
    assert (chain.jitter, chain.offset) == (3.5, 12.0)
    for key in ("jitter", "offset"):
        for bad, msg in [(-1, "non-negative"), ("x", "number"), (math.inf, "finite")]:
            d = taskset_to_dict(load_taskset(PAPER))
            d["window"][key] = bad
            with pytest.raises(
                TaskSetError,
                match=rf"f.toml: \[window\]: {key}: must be"
                rf".*{msg}",
            ):
                parse_taskset(d, "f.toml")


@pytest.mark.parametrize("j", [1.0, 5.0, 20.0])
def test_jitter_raises_w_rta_by_half_of_it_on_the_paper_set(j: float):
    """By hand: the command task (D = 2w) binds w_rta; its busy window R = 470.454 ms holds
    two window jobs, ⌈(R + J)/w⌉ = 2, so w_rta(J) = (R + J)/2 = w_rta(0) + J/2 (the chain's
    own J + 222.727 ≤ w stays slack for these J)."""
    base = w_rta(_paper())
    r_cmd = 2 * base
    assert w_rta(_paper(jitter=j)) == pytest.approx((r_cmd + j) / 2, abs=1e-9)
    ana = analyze(_paper(jitter=j), (r_cmd + j) / 2)
    win = next(t for t in ana.tasks if t.name == "window")
    assert ana.schedulable and win.wcrt == pytest.approx(j + 222.72699081698724, abs=1e-9)
    assert not analyze(_paper(jitter=j), (r_cmd + j) / 2 - 1e-6).schedulable
    assert (
        w_sch_of(_paper(jitter=j))
        >= w_rta(_paper(jitter=j))
        > w_susp(_paper(jitter=j))
        > w_susp(_paper())
    )


def test_worst_jitter_reaches_the_bound_at_w_rta_and_misses_below():
    ts = _paper(jitter=5.0)
    w = w_rta(ts)
    ana = {t.name: t.wcrt for t in analyze(ts, w).tasks}
    res = simulate(ts, 100 * w, window=w, jitter="worst")
    assert res.misses == 0
    for name in ("window", "command"):  # the critical instant is built: equal to the bound
        assert res.tasks[name].max_response == pytest.approx(ana[name], abs=1e-9)
    # at the jitter-free w_rta the command task misses
    assert simulate(ts, 100 * w, window=w_rta(_paper()), jitter="worst").tasks["command"].misses > 0
    for seed in range(3):  # random delays in [0, J]: never above the bound
        res = simulate(ts, 300 * w, window=w, jitter="random", seed=seed, record_jobs=True)
        jobs = res.jobs[res.jobs["task"] == "window"]
        delay = (jobs["release"] - jobs["arrival"]).to_numpy()
        assert (delay >= 0).all() and (delay <= 5.0).all() and (delay > 0).any()
        assert res.misses == 0
        for name, r in ana.items():
            assert res.tasks[name].max_response <= r + 1e-9


@pytest.mark.slow
def test_suspension_aware_and_edf_bounds_with_window_jitter_hold_in_simulation():
    ts = _paper(jitter=8.0)
    w = w_susp(ts)
    idle = analyze(ts, w, suspension="idle")
    for mode in ("worst", "random"):
        res = simulate(ts, 100 * w, window=w, suspension="idle", jitter=mode, seed=2)
        assert res.misses == 0
        for t in idle.tasks:
            assert res.tasks[t.name].max_response <= t.wcrt + 1e-9
    # near U = 1 with jitter the demand check is long (w_edf takes seconds)
    we = w_edf(ts)
    assert w_edf(_paper()) < we < w_rta(ts)
    assert analyze_edf(ts, we).schedulable and not analyze_edf(ts, we * (1 - 1e-9)).schedulable
    for mode in ("worst", "random"):
        assert simulate(ts, 100 * we, window=we, scheduler="edf", jitter=mode, seed=2).misses == 0


def test_w_sch_with_jitter_is_sound():
    ts = _paper(jitter=5.0)
    w = w_sch_of(ts)
    assert analyze(ts, w).schedulable
    assert simulate(ts, 50 * w, window=w, jitter="worst").misses == 0


def test_offset_delays_the_window_and_the_per_window_tasks():
    ts = _paper(offset=7.0)
    w = 240.0
    jobs = simulate(ts, 20 * w, window=w, record_jobs=True).jobs
    win = jobs[jobs["task"] == "window"].sort_values("job")
    cmd = jobs[jobs["task"] == "command"].sort_values("job")
    dr = jobs[jobs["task"] == "dead_reckoning"].sort_values("job")
    assert np.array_equal(win["arrival"], 7.0 + np.arange(len(win)) * w)
    assert np.array_equal(cmd["arrival"], 7.0 + np.arange(len(cmd)) * 2 * w)
    assert dr["arrival"].iloc[0] == 0.0  # a fixed-period task keeps its own offset
    assert analyze(ts, w).offsets_ignored  # the analyses ignore offsets (sound)


@pytest.mark.slow
def test_cli_bounds_and_simulate_report_the_raised_w_rta(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
):
    text = PAPER.read_text().replace("e_sched = 1 ", "jitter = 5\ne_sched = 1 ", 1)
    f = tmp_path / "jittered.toml"
    f.write_text(text)
    assert main(["bounds", str(PAPER), "--json"]) == 0
    plain = json.loads(capsys.readouterr().out)
    assert main(["bounds", str(f), "--json"]) == 0
    jit = json.loads(capsys.readouterr().out)
    assert jit["w_rta"] == pytest.approx(plain["w_rta"] + 2.5, abs=1e-9)
    assert jit["inputs"]["jitter"] == 5.0
    assert main(["simulate", str(f), "--horizon", "5000", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["window"]["w_rta"] == jit["w_rta"]
    assert out["window"]["w_edf"] == jit["w_edf"] > plain["w_edf"]


def _jittered(cmd: float = 0.0, dr: float = 0.0, cmd_offset: float = 0.0, **window: float):
    ts = _paper(**window)
    tasks = []
    for t in ts.tasks:
        if t.name == "command":
            t = replace(t, jitter=cmd, offset=cmd_offset)
        elif t.name == "dead_reckoning":
            t = replace(t, jitter=dr)
        tasks.append(t)
    return replace(ts, tasks=tuple(tasks))


@pytest.mark.parametrize(
    ("cmd", "win", "dr", "cmd_offset"),
    [
        (3.0, 0.0, 0.0, 0.0),  # issue 35's reproducer
        (0.5, 0.0, 0.0, 0.0),
        (50.0, 2.0, 7.0, 0.0),
        (3.0, 5.0, 0.0, 0.0),  # the window more jittered: the command task is movable
        (4.0, 4.0, 1.0, 0.0),
        (6.0, 1.0, 0.0, 10.0),  # its own offset absorbs the shift
        (6.0, 1.0, 0.0, 2.0),  # only part of it
    ],
)
def test_worst_jitter_moves_every_task_it_can(cmd: float, win: float, dr: float, cmd_offset: float):
    """Issue 35 (4): the critical instant t0 = max J; every task arrives t0 - J_i (plus its
    offset) and is first released at t0 + offset; a per-window task cannot arrive before the
    window's first arrival t0 - J_w + (its offset), so there it arrives. By hand from the
    jitters, against the job records; the responses stay within the analysis."""
    from rtsim.sim.run import worst_jitter_shifts

    ts = _jittered(cmd, dr, cmd_offset, jitter=win)
    t0 = max(cmd, win, dr)
    w = 270.0  # command: 470.45 + J ≤ 2w for every J here
    res = simulate(ts, 12 * w, window=w, jitter="worst", record_jobs=True)
    first = res.jobs[res.jobs["job"] == 0].set_index("task")
    assert first.loc["window", "arrival"] == t0 - win
    assert first.loc["window", "release"] == t0
    assert first.loc["dead_reckoning", "release"] == t0
    movable = cmd_offset + win - cmd >= 0
    arrival = t0 - cmd + cmd_offset if movable else t0 - win
    assert first.loc["command", "arrival"] == pytest.approx(arrival, abs=1e-12)
    assert first.loc["command", "release"] == pytest.approx(arrival + cmd, abs=1e-12)
    cmd_jobs = res.jobs[res.jobs["task"] == "command"]
    assert np.allclose(np.diff(cmd_jobs["arrival"].to_numpy()), 2 * w)  # still aligned
    assert worst_jitter_shifts(ts)[1] == ([] if movable else ["command"])
    bound = {t.name: t.wcrt for t in analyze(ts, w).tasks}
    assert all(b is not None for b in bound.values())
    for name, st in res.tasks.items():
        assert st.max_response <= bound[name] + 1e-9, name


@pytest.mark.parametrize("scheduler", ["fp", "edf"])
def test_cli_worst_jitter_on_the_papers_set_with_a_jittered_command_task(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], scheduler: str
):
    """Issue 35 (4): `simulate --jitter worst` with jitter = 3 on the command task ended in a
    traceback; it runs (exit 0) and says in one line which task it could not move."""
    text = PAPER.read_text().replace('period = "2w"', 'period = "2w"\njitter = 3', 1)
    f = tmp_path / "j3.toml"
    f.write_text(text)
    args = ["simulate", str(f), "--jitter", "worst", "--horizon", "3000", "--json"]
    if scheduler == "edf":
        args += ["--scheduler", "edf"]
    assert main(args) == 0
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rtsim: --jitter worst: 'command'")
    assert json.loads(cap.out)["misses"] == 0
    if scheduler == "edf":
        return
    assert main([*args, "-q"]) == 0
    assert capsys.readouterr().err == ""
    # a set whose jittered tasks can all be moved says nothing
    f.write_text(text.replace("jitter = 3", "jitter = 3\noffset = 3", 1))
    assert main(args) == 0
    assert capsys.readouterr().err == ""
