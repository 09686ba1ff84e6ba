"""``rtsim analyze`` refuses, in one line and before any work, an EDF analysis whose
response-time search (Spuri's bound) would examine more than the limit of arrivals; the
estimate is an upper bound of what the search examines, and ``--force`` runs it."""

from __future__ import annotations

from pathlib import Path

import pytest

from rtsim.analysis.edf import edf_arrivals
from rtsim.cli import main
from rtsim.io import work
from rtsim.io.taskset import load_taskset

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
