"""w_edf: the smallest window the EDF demand criterion accepts, in bounds, the CLI and sweeps.

With Δt counted as CPU time EDF is optimal on one processor, so whatever fixed priority
schedules, EDF schedules too: w_edf ≤ w_rta, and the EDF analysis accepts the set at w_rta.
The criterion passes at w_edf and fails one ulp below, and the simulator under EDF (Δt as
CPU time, WCET, synchronous release) meets every deadline at w_edf and misses below it.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest

from rtsim.analysis.bounds import w_edf, w_rta, w_sch_of, window_bounds
from rtsim.analysis.edf import analyze_edf
from rtsim.cli import main
from rtsim.config.taskset import load_taskset
from rtsim.model.task import Task
from rtsim.model.taskset import TaskSet
from rtsim.sim import simulate

sys.path.insert(0, str(Path(__file__).parents[1]))
from window_sets import random_window_sets  # noqa: E402


@pytest.fixture(scope="module")
def paper():
    return load_taskset()


def test_w_edf_at_most_w_rta_on_the_paper_grid(paper):
    for n in range(1, 11):
        for r in (10.0, 50.0):
            ts = paper.with_window(n=n, r_H=r)
            edf, rta = w_edf(ts), w_rta(ts)
            assert edf <= rta <= w_sch_of(ts)
            assert analyze_edf(ts, rta).schedulable  # exact: EDF accepts what FP does
            assert analyze_edf(ts, edf).schedulable
            assert not analyze_edf(ts, math.nextafter(edf, 0.0)).schedulable
            # implicit deadlines: the bound is where U(w) = 1, (g + e_cmd/2)/(1 − 5/40)
            g = ts.window.g()
            assert edf == pytest.approx((g + 12.5) / (1 - 5 / 40), rel=1e-14)


def test_w_edf_on_random_window_sets():
    finite = 0
    for ts in random_window_sets(seed=5, count=20):
        edf, rta = w_edf(ts), w_rta(ts)
        assert edf <= rta * (1 + 1e-12)
        if not math.isfinite(edf):
            continue
        finite += 1
        assert analyze_edf(ts, edf).schedulable
        assert not analyze_edf(ts, edf * (1 - 1e-9)).schedulable
        if math.isfinite(rta):
            assert analyze_edf(ts, rta).schedulable
    assert finite >= 12


def test_constrained_deadline_set_is_bisected_and_checked():
    # the command task due at 0.8w (period 2w): U = 1 no longer binds. By hand, at t = w the
    # window job, the command job and ⌊w/40⌋ dead-reckoning jobs are due:
    # h(w) = g + 25 + 5·⌊w/40⌋ ≤ w, with ⌊w/40⌋ = 6 near w = 248: w ≥ g + 55
    base = load_taskset()
    cmd = base.task("command")
    ts = TaskSet(
        (
            base.task("dead_reckoning"),
            Task("command", cmd.wcet, 2.0, 0.8, priority=cmd.priority, per_window=True),
        ),
        window=base.window,
    )
    w = w_edf(ts)
    g = ts.window.g()
    assert w == pytest.approx(g + 55.0, abs=2e-9)  # the criterion's 1e-9 ms tolerance
    assert analyze_edf(ts, w).schedulable
    assert not analyze_edf(ts, w - 1e-6).schedulable
    assert w <= w_rta(ts)


@pytest.mark.parametrize("n", [1, 2, 6])
def test_simulation_under_edf_at_and_below_w_edf(paper, n):
    ts = paper.with_window(n=n)
    w = w_edf(ts)
    at = simulate(ts, 400 * w, window=w, scheduler="edf", suspension="cpu")
    assert at.misses == 0
    below = simulate(ts, 400 * w, window=w * 0.99, scheduler="edf", suspension="cpu")
    assert below.misses > 0  # U > 1: the backlog grows until jobs miss


def test_bounds_json_and_table(capsys):
    assert main(["bounds", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["w_edf"] == window_bounds(load_taskset()).w_edf
    assert d["w_edf"] <= d["w_rta"]
    assert main(["bounds", "--followers", "1..2"]) == 0
    out = capsys.readouterr().out
    assert "w_edf" in out.splitlines()[3] and len(out.splitlines()) == 7


def test_analyze_cli_under_edf(tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text(
        '[[tasks]]\nname = "a"\nwcet = 2\nperiod = 5\ndeadline = 4\n'
        '[[tasks]]\nname = "b"\nwcet = 4\nperiod = 7\ndeadline = 6\n'
    )
    assert main(["analyze", str(f), "--scheduler", "edf", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["scheduler"] == "edf" and d["schedulable"] and d["limit_kind"] == "L_b"
    assert [t["wcrt"] for t in d["tasks"]] == [4.0, 6.0]  # a arriving at 2: b (d 6) first
    assert main(["analyze", str(f), "--scheduler", "edf"]) == 0
    text = capsys.readouterr().out
    assert (
        "Spuri" in text and "schedulable (processor-demand criterion, the whole set): yes" in text
    )
    # under FP (a above b) b misses: FP and EDF disagree, and --check says so
    assert main(["analyze", str(f), "--check"]) == 1
    capsys.readouterr()
    assert main(["analyze", str(f), "--check", "--scheduler", "edf"]) == 0
    capsys.readouterr()
    f.write_text(f.read_text().replace("deadline = 6", "deadline = 5"))  # h(5) = 6 > 5
    assert main(["analyze", str(f), "--check", "--scheduler", "edf"]) == 1
    assert "demand exceeds the time at t = " in capsys.readouterr().out
    assert main(["analyze", str(f), "--scheduler", "edf", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    from rtsim.analysis.edf import demand

    t = d["failed_at"]
    assert demand(t, [(2.0, 5.0, 4.0, 0.0), (4.0, 7.0, 5.0, 0.0)]) > t
    # the file's policy is the default
    f.write_text('[scheduler]\npolicy = "edf"\n' + f.read_text())
    assert main(["analyze", str(f), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["scheduler"] == "edf"


def test_sweep_option_scheduler(tmp_path):
    from rtsim.sweep import run_sweep

    ts = tmp_path / "t.toml"
    ts.write_text(
        '[[tasks]]\nname = "a"\nwcet = 2\nperiod = 5\n[[tasks]]\nname = "b"\nwcet = 4\nperiod = 7\n'
    )
    sw = tmp_path / "s.toml"
    sw.write_text(
        f'[sweep]\nkind = "simulate"\nbase = "{ts}"\n'
        "[sweep.options]\nhorizon = 350\n"
        '[grid]\nscheduler = ["fp", "edf"]\n'
    )
    res = run_sweep(sw, tmp_path / "out")
    df = res.frame if hasattr(res, "frame") else res
    rows = {r["scheduler"]: r for r in df.to_dict("records")}
    assert rows["fp"]["misses"] > 0 and rows["edf"]["misses"] == 0
    sw.write_text(sw.read_text().replace('["fp", "edf"]', '["fp", "rm"]'))
    from rtsim.errors import SweepError

    with pytest.raises(
        SweepError, match="scheduler: must be one of fp, edf, rr or 'package.module:Name', got 'rm'"
    ):
        run_sweep(sw, tmp_path / "out2")
