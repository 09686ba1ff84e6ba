"""[adjust] lower_bound: the window bound the robots use, and the experiment comparing them."""

from __future__ import annotations

import importlib.util
import math
from dataclasses import replace
from pathlib import Path

import pandas as pd
import pytest

from rtsim.analysis.bounds import lower_bound, w_txn, window_bounds
from rtsim.config.scenario import load_scenario
from rtsim.config.taskset import load_taskset
from rtsim.coupling import run_scenario
from rtsim.errors import InputError, ScenarioError

ROOT = Path(__file__).resolve().parents[2]
TEST2 = ROOT / "experiments" / "scenarios" / "test2.toml"


def test_lower_bound_values_and_model_checks():
    ts = load_taskset()
    b = window_bounds(ts)
    assert lower_bound(ts, "w_sch") == b.w_sch
    assert lower_bound(ts, "w_rta") == b.w_rta
    assert lower_bound(ts, "w_susp") == b.w_susp
    with pytest.raises(InputError, match="w_susp assumes the radio round trip leaves the CPU"):
        lower_bound(ts, "w_susp", suspension="cpu")
    with pytest.raises(InputError, match="fixed-priority bound, but the scheduler is 'edf'"):
        lower_bound(ts, "w_rta", scheduler="edf")
    with pytest.raises(
        InputError, match="lower_bound: must be one of w_sch, w_rta, w_susp, w_edf, w_txn"
    ):
        lower_bound(ts, "w_min")
    assert lower_bound(ts, "w_edf", scheduler="edf") == b.w_edf
    assert lower_bound(ts, "w_edf", scheduler="edf", suspension="cpu") == b.w_edf
    with pytest.raises(InputError, match="w_edf is an EDF bound, but the scheduler is 'fp'"):
        lower_bound(ts, "w_edf")


def test_w_txn_is_a_lower_bound_the_robots_can_use(tmp_path):
    """Issue 35 (5): w_txn, reachable only from Python, is ``[adjust] lower_bound = "w_txn"``:
    the offset-based bound under the suspension model asked for (the coupling's CPU: idle),
    a fixed-priority one; a 6 s Test 2 runs at or above it without a miss."""
    ts = load_taskset()
    assert lower_bound(ts, "w_txn") == w_txn(ts) <= window_bounds(ts).w_susp
    assert lower_bound(ts, "w_txn", suspension="cpu") == w_txn(ts, suspension="cpu")
    assert w_txn(ts, suspension="cpu") <= window_bounds(ts).w_rta
    with pytest.raises(InputError, match="w_txn is a fixed-priority bound, but the scheduler"):
        lower_bound(ts, "w_txn", scheduler="edf")
    f = tmp_path / "s.toml"
    f.write_text(TEST2.read_text().replace("[adjust]", '[adjust]\nlower_bound = "w_txn"'))
    sc = load_scenario(f)
    assert sc.adjust.lower_bound == "w_txn"
    res = run_scenario(sc, duration_s=6, record_jobs=False)
    assert res.summary["w_sch"] == w_txn(load_taskset())
    assert res.summary["missed"] == 0
    assert (res.windows["w"] >= res.summary["w_sch"]).all()


def test_scenario_key(tmp_path):
    text = TEST2.read_text()
    assert text.count("[adjust]") == 1
    f = tmp_path / "s.toml"
    f.write_text(text.replace("[adjust]", '[adjust]\nlower_bound = "w_susp"'))
    sc = load_scenario(f)
    assert sc.adjust.lower_bound == "w_susp"
    res = run_scenario(sc, duration_s=6, record_jobs=False)
    assert res.summary["w_sch"] == window_bounds(load_taskset()).w_susp
    assert res.summary["missed"] == 0
    assert (res.windows["w"] >= res.summary["w_sch"]).all()
    f.write_text(f.read_text().replace('"w_susp"', '"w_best"'))
    with pytest.raises(ScenarioError, match="adjust.lower_bound: must be one of"):
        load_scenario(f)


def test_default_stays_w_sch_bit_identical():
    sc = load_scenario(TEST2)
    a = run_scenario(sc, duration_s=6, record_jobs=False)
    b = run_scenario(
        replace(sc, adjust=sc.adjust.model_copy(update={"lower_bound": "w_sch"})),
        duration_s=6,
        record_jobs=False,
    )
    pd.testing.assert_frame_equal(a.windows, b.windows)


def test_experiment_quick(tmp_path):
    spec = importlib.util.spec_from_file_location(
        "lower_bounds", ROOT / "experiments" / "lower_bounds.py"
    )
    mod = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(mod)
    assert mod.main(["--quick", "--out", str(tmp_path)]) == 0
    df = pd.read_csv(tmp_path / "lower_bounds.csv")
    assert len(df) == 10
    assert set(df["lower_bound"]) == {"w_sch", "w_rta", "w_susp", "w_edf", "w_txn"}
    assert set(df[df["lower_bound"] == "w_edf"]["scheduler"]) == {"edf"}
    assert set(df[df["lower_bound"] != "w_edf"]["scheduler"]) == {"fp"}
    for _, g in df.groupby("test"):
        bounds = g.set_index("lower_bound")["bound_ms"]
        assert bounds["w_susp"] < bounds["w_rta"] < bounds["w_sch"]
        assert bounds["w_txn"] <= bounds["w_susp"]
        assert bounds["w_susp"] < bounds["w_edf"] <= bounds["w_rta"]
    assert (df["missed"] == 0).all() and df["mean_speed_ratio"].between(0, 1).all()
    assert (tmp_path / "manifest.json").exists() and (tmp_path / "lower_bounds.md").exists()
    assert not math.isnan(df["lap_time_s"].iloc[0])


def test_scenario_under_edf_with_w_edf(tmp_path, monkeypatch):
    from rtsim.sim import CPU

    policies = []
    orig = CPU.__init__

    def spy(self, *args, **kwargs):  # noqa: ANN001, ANN202
        orig(self, *args, **kwargs)
        policies.append(self.policy.name)

    monkeypatch.setattr(CPU, "__init__", spy)
    text = TEST2.read_text()
    f = tmp_path / "s.toml"
    f.write_text(
        text.replace("[adjust]", '[scheduler]\npolicy = "edf"\n\n[adjust]\nlower_bound = "w_edf"')
    )
    sc = load_scenario(f)
    assert sc.scheduler == "edf" and sc.load_taskset().scheduler == "edf"
    res = run_scenario(sc, duration_s=6, record_jobs=True)
    assert res.summary["w_sch"] == window_bounds(load_taskset()).w_edf
    assert res.summary["missed"] == 0
    assert (res.windows["w"] >= res.summary["w_sch"]).all()
    assert policies == ["edf"]  # the leader's CPU ran EDF
    assert res.inputs.resolved["taskset"]["scheduler"] == {"policy": "edf"}
    # a bound of the other scheduler is a one-line error naming the file and key
    f.write_text(
        text.replace("[adjust]", '[scheduler]\npolicy = "edf"\n\n[adjust]\nlower_bound = "w_rta"')
    )
    with pytest.raises(
        ScenarioError,
        match=r"s.toml: adjust.lower_bound: w_rta assumes the "
        r"fp scheduler, but \[scheduler\] policy is 'edf'",
    ):
        load_scenario(f)
    f.write_text(text.replace("[adjust]", '[adjust]\nlower_bound = "w_edf"'))
    with pytest.raises(InputError, match="w_edf is an EDF bound, but the scheduler is 'fp'"):
        run_scenario(load_scenario(f), duration_s=1)
    f.write_text(text.replace("[adjust]", '[scheduler]\npolicy = "edd"\n\n[adjust]'))
    with pytest.raises(ScenarioError, match="scheduler.policy: must be one of fp, edf"):
        load_scenario(f)
