"""``rtsim analyze`` refuses, in one line and before any work, an EDF analysis whose
response-time search (Spuri's bound) would examine more than the limit of arrivals; the
estimate is an upper bound of what the search examines, and ``--force`` runs it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from rtsim.analysis.edf import edf_arrivals
from rtsim.cli import main
from rtsim.config.taskset import load_taskset
from rtsim.io import work

ROOT = Path(__file__).resolve().parents[2]

#: U = 0.9995: the synchronous busy period (~1e6 ms) holds ~1e9 arrivals of the 1 µs task
SLOW = """[scheduler]
policy = "edf"
[[tasks]]
name = "a"
wcet = 0.0004995
period = 0.001
[[tasks]]
name = "b"
wcet = 500
period = 1000
deadline = 1000000
"""

#: a busy period of some hundred arrivals
SMALL = """[scheduler]
policy = "edf"
[[tasks]]
name = "a"
wcet = 0.45
period = 1
[[tasks]]
name = "b"
wcet = 40
period = 100
deadline = 1000
[[tasks]]
name = "c"
wcet = 7
period = 70
"""


def test_a_hopeless_edf_analysis_is_refused_up_front(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    f = tmp_path / "slow.toml"
    f.write_text(SLOW, "utf-8")
    assert main(["analyze", str(f)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"rtsim: {f}: about ")
    assert "arrivals" in err and "above the limit of 1e+06" in err and "--force" in err
    # the paper's set and the example are far below the limit
    for name in ("barrel_robots", "example"):
        assert edf_arrivals(load_taskset(ROOT / "tasksets" / f"{name}.toml"), None, None) < 1000


def test_the_estimate_bounds_the_arrivals_examined(tmp_path: Path, monkeypatch) -> None:
    """Counted in the search itself: it sorts each task's candidate arrivals once."""
    import rtsim.analysis.edf as edf

    f = tmp_path / "small.toml"
    f.write_text(SMALL, "utf-8")
    ts = load_taskset(f)
    seen: list[int] = []

    def counting(xs: object, *a: object, **k: object) -> list:
        out = sorted(xs, *a, **k)  # type: ignore[call-overload]
        seen.append(len(out))
        return out

    monkeypatch.setattr(edf, "sorted", counting, raising=False)
    edf.analyze_edf(ts)
    examined = sum(seen[-3:])  # one sort per task, the last three calls
    est = edf_arrivals(ts, None, None)
    assert examined > 100
    assert examined <= est <= 3 * examined + 10


def test_force_runs_what_the_limit_refuses(
    tmp_path: Path, monkeypatch, capsys: pytest.CaptureFixture[str]
) -> None:
    f = tmp_path / "small.toml"
    f.write_text(SMALL, "utf-8")
    monkeypatch.setitem(work.LIMITS, "arrivals", 50.0)
    assert main(["analyze", str(f)]) == 2
    assert "above the limit of 50" in capsys.readouterr().err
    assert main(["analyze", str(f), "--force", "--json"]) == 0
    assert '"schedulable"' in capsys.readouterr().out


# -- the offset-based (transaction) analysis (issue 35, item 6) ------------------------------
def _many(tmp_path: Path, n: int, seed: int = 3, periods: str = "loguniform:10..1000") -> Path:
    out = tmp_path / f"gen{n}-{seed}"
    argv = ["generate", "--tasks", str(n), "--utilization", "0.7", "--periods", periods]
    assert main([*argv, "--seed", str(seed), "--out", str(out), "-q"]) == 0
    return out / "set_0000.toml"


class _Counting:
    """Counts the interference terms the analysis evaluates (no limit)."""

    def __init__(self, limit: object, where: str) -> None:
        self.n = 0

    def spend(self, n: int) -> None:
        self.n += n


@pytest.mark.parametrize(
    ("n", "periods"), [(30, "loguniform:10..1000"), (60, "loguniform:1..100000")]
)
def test_the_transaction_estimate_is_a_least_work(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, n: int, periods: str
) -> None:
    """Counted in the analysis itself: the estimate checked up front is at most what it
    evaluates (the paper's set too)."""
    import rtsim.analysis.transaction as tx

    for f in (_many(tmp_path, n, periods=periods), ROOT / "tasksets" / "barrel_robots.toml"):
        ts = load_taskset(f)
        w = None if ts.window is None else 240.0
        counter = _Counting(None, "")
        monkeypatch.setattr(tx, "_Budget", lambda *a, c=counter: c)
        tx.transaction_bounds(ts, w)
        monkeypatch.undo()
        assert 0 < tx.transaction_work(ts, w) <= counter.n


def test_a_transaction_analysis_above_the_limit_is_refused_in_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Up front when its least work is above the limit (nothing evaluated), as it runs when
    its fixed points take it there; --force (force=True) runs it, with the same bounds as
    without a limit; the CLI and the library refuse alike."""
    from rtsim.analysis.transaction import transaction_bounds, transaction_work
    from rtsim.io.work import TooMuchWork

    f = _many(tmp_path, 40)
    ts = load_taskset(f)
    least = transaction_work(ts, None)
    free = transaction_bounds(ts, None)
    monkeypatch.setitem(work.LIMITS, "interference", least / 2)  # refused up front
    with pytest.raises(TooMuchWork, match="above the limit"):
        transaction_bounds(ts, None)
    assert main(["analyze", str(f)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"rtsim: {f}: ") and "--force" in err
    assert "offset-based (transaction) analysis: about" in err
    monkeypatch.setitem(work.LIMITS, "interference", least * 1.5)  # stopped as it runs
    with pytest.raises(TooMuchWork, match="more than"):
        transaction_bounds(ts, None)
    assert main(["analyze", str(f)]) == 2
    assert "more than" in capsys.readouterr().err
    assert transaction_bounds(ts, None, force=True) == free
    assert main(["analyze", str(f), "--force", "--json"]) == 0
    out = capsys.readouterr().out
    import json

    got = {t["name"]: t["wcrt_transaction"] for t in json.loads(out)["tasks"]}
    assert got == free


def test_simulate_leaves_the_transaction_bound_out_above_the_limit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``simulate`` ran the analysis unbounded for its report; above the limit the report
    goes without ``wcrt_transaction`` (one line says so), with --force it has it."""
    import json

    f = _many(tmp_path, 40)
    monkeypatch.setitem(work.LIMITS, "interference", 10.0)
    assert main(["simulate", str(f), "--horizon", "1000", "--json"]) == 0
    cap = capsys.readouterr()
    assert cap.err.count("\n") == 1 and "wcrt_transaction left out" in cap.err
    assert all(t["wcrt_transaction"] is None for t in json.loads(cap.out)["tasks"])
    assert main(["simulate", str(f), "--horizon", "1000", "--json", "--force"]) == 0
    tasks = json.loads(capsys.readouterr().out)["tasks"]
    assert all(t["wcrt_transaction"] is not None for t in tasks)


@pytest.mark.slow
def test_a_thousand_tasks_are_analysed_within_the_limit(tmp_path: Path) -> None:
    """Issue 35's 1,000 distinct periods took over 11 minutes (O(n³)); now seconds, under the
    default limit, every task bounded."""
    import time

    from rtsim.analysis.transaction import transaction_bounds

    ts = load_taskset(_many(tmp_path, 1000))
    t0 = time.monotonic()
    got = transaction_bounds(ts, None)
    assert time.monotonic() - t0 < 120
    assert len(got) == 1000 and all(r is not None for r in got.values())


def test_every_route_to_w_txn_has_the_limit_and_force(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """docs/reliability.md: `bounds`' w_txn, ``[adjust] lower_bound = "w_txn"`` and `w_txn`
    in Python refuse above the limit in one line and run with --force (force=True). Before
    this test ``run_scenario(..., force=True)`` did not reach w_txn: a scenario with
    ``lower_bound = "w_txn"`` above the limit could not be run at all."""
    from rtsim.analysis.bounds import w_txn
    from rtsim.coupling import prepared, run_scenario
    from rtsim.io.work import TooMuchWork

    paper = load_taskset()
    free = w_txn(paper)
    monkeypatch.setitem(work.LIMITS, "interference", 1)  # the paper's set evaluates ~45
    with pytest.raises(TooMuchWork, match="above the limit of 1"):
        w_txn(paper)
    assert w_txn(paper, force=True) == free
    capsys.readouterr()
    assert main(["bounds", "--json"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "transaction" in err and "--force" in err
    assert main(["bounds", "--json", "--force"]) == 0
    assert json.loads(capsys.readouterr().out)["w_txn"] == free
    # the robots' lower bound: the run's w_sch is w_txn, computed past the limit when forced
    scenario = ROOT / "experiments" / "scenarios" / "test2.toml"
    over = {"adjust.lower_bound": "w_txn"}
    prepared.clear()  # (a bound computed earlier in this process would be reused)
    with pytest.raises(TooMuchWork, match="above the limit of 1"):
        run_scenario(scenario, overrides=over, duration_s=1, record_jobs=False)
    prepared.clear()
    res = run_scenario(scenario, overrides=over, duration_s=1, record_jobs=False, force=True)
    assert res.summary["w_sch"] == free
    prepared.clear()
    out = tmp_path / "run"
    argv = ["scenario", str(scenario), "--duration", "1", "--no-figures", "--out", str(out)]
    assert main([*argv, "--set", "adjust.lower_bound=w_txn"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--force" in err and not out.exists()
    prepared.clear()
    assert main([*argv, "--set", "adjust.lower_bound=w_txn", "--force", "-q"]) == 0
    assert json.loads((out / "summary.json").read_text())["w_sch"] == free
