"""Sweep points reuse a worker's prepared scenarios, and summaries come from columns: the
results are those of a plain ``run_scenario`` of the same file."""

from __future__ import annotations

from pathlib import Path

import pytest

import rtsim.sweep.kinds as kinds
from rtsim.coupling import run_scenario, summarize
from rtsim.coupling.recorder import records_columns
from rtsim.sweep.kinds import PointInput
from rtsim.sweep.spec import BaseFile

ROOT = Path(__file__).resolve().parents[2]
TEST2 = ROOT / "experiments" / "scenarios" / "test2.toml"


@pytest.mark.parametrize("mode", ["adjust", "min-msb"])
def test_summary_from_columns_equals_summary_from_the_table(mode: str) -> None:
    res = run_scenario(TEST2, policy=mode, duration_s=120, seed=2, record_jobs=False)
    df = res.windows
    assert df is not None
    kw = dict(mode=mode, w_sch=1.0, duration_s=1.0, seed=0, scenario="x", n=2)
    cols = {c: df[c].to_numpy() for c in df.columns}
    assert summarize(cols, **kw) == summarize(df, **kw)
    lean = run_scenario(
        TEST2, policy=mode, duration_s=120, seed=2, record_jobs=False, windows=False
    )
    assert lean.windows is None and lean.summary == res.summary
    if mode == "min-msb":
        assert res.summary["missed"] > 0  # the comparison covers missed windows too
    assert records_columns([], 2, ((1.0,) * 2,) * 4)["window"].dtype.kind == "i"


def test_points_share_prepared_inputs(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(kinds, "_PREPARED", type(kinds._PREPARED)())
    base = BaseFile(str(TEST2), TEST2.read_text(encoding="utf-8"))
    parsed = []
    real = kinds._need("rtsim.config.scenario", "scenario").parse_scenario

    def counting(*a: object, **k: object) -> object:
        parsed.append(1)
        return real(*a, **k)

    monkeypatch.setattr("rtsim.config.scenario.parse_scenario", counting)
    out = []
    for seed in (3, 4, 3):
        p = PointInput(
            index=seed, kind="scenario", params={}, options={"duration": 30}, seed=seed, base=base
        )
        out.append(kinds._scenario(p))
    assert len(parsed) == 1  # one parse for three points of the same content
    assert out[0] == out[2] and out[0] != out[1]
    direct = run_scenario(TEST2, duration_s=30, seed=4, record_jobs=False).summary
    assert out[1]["windows"] == direct["windows"] and out[1]["missed"] == direct["missed"]
    assert out[1]["critical_share"] == direct["critical_share"]
