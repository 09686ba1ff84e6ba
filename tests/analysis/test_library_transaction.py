"""``rtsim.analyze`` reports the offset-based (transaction) bound as ``rtsim analyze`` does
(issue 35, finding 6: the library did not run it, so the two disagreed), with the same
work limit and ``force``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import rtsim
from rtsim.analysis.transaction import transaction_bounds
from rtsim.cli import main
from rtsim.config.taskset import load_taskset
from rtsim.io import work
from rtsim.io.work import TooMuchWork

# two tasks of one period with offsets 0 and 10 ms, and a lower-priority one
OFFSETS = """name = "offsets"
[[tasks]]
name = "a"
wcet = 4
period = 20
offset = 0
[[tasks]]
name = "b"
wcet = 4
period = 20
offset = 10
[[tasks]]
name = "c"
wcet = 6
period = 40
"""


@pytest.fixture
def offsets(tmp_path: Path) -> Path:
    f = tmp_path / "offsets.toml"
    f.write_text(OFFSETS)
    return f


@pytest.mark.parametrize("suspension", ["cpu", "idle"])
def test_the_library_reports_the_clis_transaction_bounds(
    offsets: Path, capsys: pytest.CaptureFixture[str], suspension: str
) -> None:
    assert main(["analyze", str(offsets), "--json", "--suspension", suspension]) == 0
    cli = json.loads(capsys.readouterr().out)
    lib = rtsim.analyze(str(offsets), suspension=suspension)
    assert lib.transaction is not None
    got = {t["name"]: t["wcrt_transaction"] for t in lib.as_dict()["tasks"]}
    want = {t["name"]: t["wcrt_transaction"] for t in cli["tasks"]}
    assert got == want
    # the analysis's own entry point agrees, every task has a bound, and none is above
    # the offset-free analysis's (the offset-based one is the lesser of the two)
    ts = load_taskset(offsets)
    assert got == transaction_bounds(ts, None, suspension=suspension)
    plain = {t.name: t.wcrt for t in lib.tasks}
    assert all(got[k] is not None and got[k] <= plain[k] for k in plain)


def test_the_library_keeps_the_work_limit_and_force(
    offsets: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    free = rtsim.analyze(str(offsets)).transaction
    monkeypatch.setitem(work.LIMITS, "interference", 1e-9)
    with pytest.raises(TooMuchWork):
        rtsim.analyze(str(offsets))
    assert main(["analyze", str(offsets)]) == 2  # the CLI refuses alike
    assert rtsim.analyze(str(offsets), force=True).transaction == free
