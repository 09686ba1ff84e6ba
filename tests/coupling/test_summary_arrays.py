"""The summary's counts and statistics computed in bulk — the methods and the binding bounds
counted per distinct label, one percentile call per statistic for every follower together —
equal the row-by-row computations they replace, on real runs (recomputed here the plain way,
from the window table or the run's physical log); the violation ratios, from the records,
are checked against their definition too."""

from __future__ import annotations

from collections import Counter
from typing import Any

import numpy as np
import pytest

from rtsim.coupling import run_scenario
from rtsim.coupling import scenario_run as sr
from rtsim.coupling.physical import PhysicalLog
from rtsim.coupling.summary import _tally

RUNS = [
    ("test2", {"duration_s": 60, "seed": 3, "overrides": {"formation.followers": 4}}),
    ("test2", {"duration_s": 60, "seed": 1, "policy": "min-msb"}),
    ("test1", {"duration_s": 40, "seed": 2}),
]


@pytest.fixture(scope="module", params=range(len(RUNS)), ids=lambda i: f"run{i}")
def run(request: pytest.FixtureRequest) -> tuple[Any, Any]:
    """(the run's _Coupling after its loop, its ScenarioResult)."""
    name, kw = RUNS[request.param]
    kept: list[Any] = []
    real = sr._Coupling.run

    def keep(self: Any) -> None:
        real(self)
        kept.append(self)

    mp = pytest.MonkeyPatch()
    mp.setattr(sr._Coupling, "run", keep)
    try:
        res = run_scenario(name, record_jobs=False, **kw)
    finally:
        mp.undo()
    return kept[0], res


def test_methods_and_binding_counted_as_row_by_row(run: tuple[Any, Any]) -> None:
    _, res = run
    df = res.windows
    methods = Counter(str(m) for m in df["method"])
    binding = Counter(str(b).split(":")[0] for b in df.loc[df["critical"], "binding"])
    assert res.summary["methods"] == dict(sorted(methods.items()))
    assert res.summary["binding_critical"] == dict(sorted(binding.items()))
    assert sum(res.summary["methods"].values()) == len(df) > 0


def test_tally_of_mixed_labels() -> None:
    into: dict[str, int] = {"a": 1}
    labels = np.array(["a:x", "b", "a:y", float("nan"), "b"], dtype=object)
    _tally(into, labels, lambda b: b.split(":")[0])
    assert into == {"a": 3, "b": 2, "nan": 1}
    _tally(into, np.array([], dtype=object))
    assert into == {"a": 3, "b": 2, "nan": 1}


def test_physical_stats_equal_per_follower_calls(run: tuple[Any, Any]) -> None:
    coupling, res = run
    log = coupling.phys
    for name, per in (("cross_track_cm", log.cross), ("separation_error_cm", log.sep)):
        every = PhysicalLog._stats([c for v in per for c in v])
        assert res.summary[name] == every
        for k, row in enumerate(res.summary["per_follower"]):
            assert row[name] == PhysicalLog._stats(per[k])  # one np.percentile per follower
    if coupling.world.follow_law is not None:
        assert res.summary["cross_track_cm"] is not None


def test_physical_stats_of_unequal_counts() -> None:
    rng = np.random.default_rng(5)
    per = [list(rng.random(7)), list(rng.random(3)), []]
    every, rows = PhysicalLog._stats_all(per)
    assert every == PhysicalLog._stats([c for v in per for c in v])
    assert rows == [PhysicalLog._stats(v) for v in per] and rows[2] is None
    assert PhysicalLog._stats_all([[], []]) == (None, [None, None])


def test_violation_ratios_equal_per_kind_arrays(run: tuple[Any, Any]) -> None:
    coupling, _ = run
    recs = [r for r in coupling.rec.records if r.complete and r.changes is not None]
    ratios, beyond = coupling.violation_ratios()
    for kind, key, lim in coupling._limits:
        ratio = np.array([r.changes[key] for r in recs], dtype=float).reshape(len(recs), -1) / lim
        assert ratios[kind] == float(ratio.max())
        assert beyond[kind] == int((ratio > 1.0 + sr.VIOLATION_TOLERANCE).sum())
