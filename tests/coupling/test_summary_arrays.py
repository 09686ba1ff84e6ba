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
from rtsim.coupling.physical import p95_max_rows
from rtsim.coupling.summary import _tally

RUNS = [
    ("test2", {"duration_s": 60, "seed": 3, "overrides": {"formation.followers": 4}}),
    ("test2", {"duration_s": 60, "seed": 1, "policy": "min-msb"}),
    ("test1", {"duration_s": 40, "seed": 2}),
]


@pytest.fixture(scope="module", params=range(len(RUNS)), ids=lambda i: f"run{i}")
def run(request: pytest.FixtureRequest) -> tuple[Any, Any]:
    """(the run's _Coupling after its loop, a copy, and its ScenarioResult)."""
    name, kw = RUNS[request.param]
    return _kept(name, kw)


def _kept(name: str, kw: dict[str, Any]) -> tuple[Any, Any]:
    """`run`'s pair for the scenario ``name`` run with ``kw``."""
    kept: list[Any] = []
    real = sr._Coupling.run

    def keep(self: Any) -> None:
        real(self)
        copy = object.__new__(sr._Coupling)  # (run_scenario drops the run's state after)
        copy.__dict__.update(vars(self))
        copy.world = object.__new__(type(self.world))  # (and the world's, for the same reason)
        copy.world.__dict__.update(vars(self.world))
        kept.append(copy)

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


def one(values: Any) -> dict[str, float] | None:
    """p95 and max of ``values`` by one call each, the plain way (None: no values)."""
    v = np.asarray(values, dtype=float)
    return {"p95": float(np.percentile(v, 95)), "max": float(v.max())} if v.size else None


def test_physical_stats_equal_per_follower_calls(run: tuple[Any, Any]) -> None:
    coupling, res = run
    log = coupling.phys
    for name, per in (("cross_track_cm", log.cross), ("separation_error_cm", log.sep)):
        assert res.summary[name] == one([c for v in per for c in v])
        for k, row in enumerate(res.summary["per_follower"]):
            assert row[name] == one(per[k])
    if coupling.world.follow_law is not None:
        assert res.summary["cross_track_cm"] is not None


def test_fix_errors_equal_per_follower_calls(run: tuple[Any, Any]) -> None:
    _, res = run
    df, n = res.windows, res.summary["n"]
    cols = [df[f"f{i}_fix_error_cm"].to_numpy() for i in range(1, n + 1)]
    fixes = [c[np.isfinite(c)] for c in cols]  # (inf: no fix)
    got = res.summary["localization_error_cm"]
    assert got == {**one(np.concatenate(fixes)), "per_follower": [one(f) for f in fixes]}  # type: ignore[dict-item]


def test_rows_of_unequal_lengths() -> None:
    rng = np.random.default_rng(5)
    per = [list(rng.random(7)), list(rng.random(3)), []]
    every, rows = p95_max_rows(per)
    assert every == one([c for v in per for c in v])
    assert rows == [one(v) for v in per] and rows[2] is None
    assert p95_max_rows([[], []]) == (None, [None, None])
    assert p95_max_rows([]) == (None, [])
    same = rng.random((4, 50)) * 1e3
    every, rows = p95_max_rows(list(same))
    assert every == one(same.ravel()) and rows == [one(r) for r in same]


def test_violation_ratios_equal_per_kind_arrays(run: tuple[Any, Any]) -> None:
    coupling, res = run
    recs = [r for r in coupling.rec.records if r.complete and r.changes is not None]
    ratios, beyond = coupling.violation_ratios()
    # (the summary's, folded from the records `_tables` picked as complete: the same)
    assert res.summary["max_violation_ratio"] == ratios
    assert res.summary["violations_beyond_5pct"] == beyond
    complete = [r for r in coupling.rec.records if r.complete]
    assert sr._closed(sr._Complete(complete)) == sr._closed(complete) == recs
    for kind, key, lim in coupling._limits:
        ratio = np.array([r.changes[key] for r in recs], dtype=float).reshape(len(recs), -1) / lim
        assert ratios[kind] == float(ratio.max())
        assert beyond[kind] == int((ratio > 1.0 + sr.VIOLATION_TOLERANCE).sum())


def _flags_read(recs: list[Any], n: int) -> np.ndarray:
    """The records' violation flags as they hold them, an (m, kinds, n) array."""
    from rtsim.analysis.kinematics import BOUND_KINDS

    return np.array([[list(r.viol[k]) for k in BOUND_KINDS] for r in recs], dtype=bool).reshape(
        len(recs), len(BOUND_KINDS), n
    )


def _check_flags(coupling: Any) -> None:
    """The flags the world makes of the complete records' changes are the records' own, and
    `_tables`' summary columns (made with them) the full table's."""
    from rtsim.coupling.recorder import changes_array, records_columns

    n = coupling.n
    recs = [r for r in coupling.rec.records if r.complete]
    flags = coupling.world.violations_of(changes_array(recs, n))
    assert flags.dtype == np.bool_ and flags.shape == (len(recs), 4, n)
    assert np.array_equal(flags, _flags_read(recs, n))
    _, table, kept, changes = sr._tables(coupling, None, False)
    assert kept == recs and changes.tobytes() == changes_array(recs, n).tobytes()
    full = records_columns(recs, n, coupling.rec.limits)
    for c, v in table.items():
        if isinstance(v, list):
            assert v == full[c]
        else:
            assert v.dtype == full[c].dtype and v.tobytes() == full[c].tobytes(), c


def test_violation_flags_of_the_changes_are_the_scans(run: tuple[Any, Any]) -> None:
    """The summary's violation flags, made from the records' changes with the world's
    thresholds (`World.violations_of`), are the flags each scan set."""
    _check_flags(run[0])


@pytest.mark.parametrize(
    "overrides",
    [
        {"sensing.r_H": 4, "thresholds.T_beta_deg": 0.5},
        {"world.backend": "python", "sensing.r_H": 6, "thresholds.T_beta_deg": 1},
    ],
    ids=["compiled", "python"],
)
def test_violation_flags_of_every_bound_kind(overrides: dict[str, Any]) -> None:
    """The same with every bound kind broken (small r_H and T_β; the adjust policy lets
    the separation and path bounds break), on both scan paths."""
    coupling, res = _kept("test2", {"duration_s": 20, "policy": "adjust", "overrides": overrides})
    assert all(res.summary["violations"][k] for k in ("localization", "separation", "bearing"))
    _check_flags(coupling)


def test_summary_columns_without_state_are_the_tables(run: tuple[Any, Any]) -> None:
    """The summary reads columns built without the followers' state, estimates and bounds
    (`records_columns(state=False)`; with ``summary=True``, the run's, just the columns
    summary.json reads): each of them the full table's array, dtype and bytes, and the
    summary of the full table is the run's."""
    from rtsim.coupling.recorder import records_columns, window_columns
    from rtsim.coupling.summary import summary_columns

    coupling, res = run
    n = coupling.n
    recs = [r for r in coupling.rec.records if r.complete]
    full = records_columns(recs, n, coupling.rec.limits)
    part = records_columns(recs, n, coupling.rec.limits, state=False)
    least = records_columns(recs, n, coupling.rec.limits, state=False, summary=True)
    assert set(summary_columns(n)) <= set(part) and set(part) < set(full)
    assert set(least) == set(summary_columns(n)) < set(part)
    assert list(part) == [c for c in window_columns(n) if c in part]  # (in the table's order)
    assert f"f{n}_x" not in part and "f1_msb_bearing_true" not in part
    for c, v in [*part.items(), *least.items()]:
        w = full[c]
        if isinstance(v, list):
            assert v == w
        else:
            assert v.dtype == w.dtype and v.tobytes() == w.tobytes(), c
    again = sr.summarize(
        full,
        mode=res.summary["mode"],
        w_sch=res.summary["w_sch"],
        duration_s=res.summary["duration_s"],
        seed=res.summary["seed"],
        scenario=res.summary["scenario"],
        n=n,
    )
    assert {k: again[k] for k in again if k in res.summary} == {
        k: res.summary[k] for k in again if k in res.summary
    }


def test_windows_frame_built_when_first_read(run: tuple[Any, Any]) -> None:
    """A result holds its records until ``windows`` is read, then the frame of the full
    columns, built once (the same object at every read)."""
    from rtsim.coupling.recorder import records_frame

    coupling, res = run
    held = res.__dict__["_windows"]
    if isinstance(held, sr._Records):  # (not read yet by an earlier test of this run)
        assert held.recs == [r for r in coupling.rec.records if r.complete]
    df = res.windows
    assert res.windows is df and isinstance(res.__dict__["_windows"], type(df))
    recs = [r for r in coupling.rec.records if r.complete]
    ref = records_frame(recs, coupling.n, coupling.rec.limits)
    assert list(df.columns) == list(ref.columns) and df.to_csv() == ref.to_csv()


def test_same_rows_repeat_one_object_and_read_any_other() -> None:
    """`_same_rows` repeats the numbers of one object every record shares, and reads each
    record's otherwise: the array `_rows` gives either way, writable."""
    from rtsim.coupling.recorder import _rows, _same_rows

    zero = (0, 0, 0, 0)
    one = (0, 1, 0, 2)
    for vals in ([zero] * 5, [zero, zero, one, zero], [one], [], [zero, (0, 0, 0, 0)]):
        got = _same_rows(list(vals), np.int64, 4)
        want = _rows(iter(vals), np.int64, len(vals), 4)
        assert got.dtype == want.dtype and got.shape == want.shape
        assert got.tobytes() == want.tobytes() and got.flags.writeable


def test_filled_flags_equal_in_every_record_are_the_rows() -> None:
    """`_filled`'s flags every record holds equal are repeated from the first record's: the
    array its rows give, whatever the flags' type (bools, numpy bools, 0 and 1)."""
    from types import SimpleNamespace

    from rtsim.coupling.recorder import _filled, _rows

    def recs(*vals: Any) -> list[Any]:
        return [SimpleNamespace(flags=v) for v in vals]

    f, t = [False, False], [True, False]
    cases = [
        [f, list(f), [False, False]],
        [t, list(t), [np.True_, np.False_], [1, 0]],
        [f, t, f],
        [[0, 0], [False, False]],
        [t],
        [],
    ]
    for vals in cases:
        got = _filled(recs(*vals), "flags", False, bool, 2)  # type: ignore[arg-type]
        want = _rows(iter(vals), bool, len(vals), 2)
        assert got.dtype == want.dtype and got.tobytes() == want.tobytes()
        assert got.flags.writeable and got.shape == (len(vals), 2)
