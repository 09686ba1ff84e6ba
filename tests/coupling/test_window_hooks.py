"""The window hooks' shortcuts give the records the plain computation gives (issue 36).

The scan hook keeps each scan's Hough time and Eq 1 check by the scan's counts
(`_Coupling._hough_of`): a run that computes them at every scan has the same windows, bit
for bit. The records keep the scan's own lists and mappings (no copies): a record read after
the run still holds what its scan reported, which the run's later scans did not change.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd
import pytest

import rtsim.coupling.scenario_run as sr
from rtsim.coupling import run_scenario


class _Never(dict):  # type: ignore[type-arg]
    """A memo that never has the counts asked for (every scan computes its time)."""

    def get(self, key: Any, default: Any = None) -> Any:
        return None


@pytest.mark.parametrize(
    ("scenario", "overrides"),
    [("test2", None), ("test1", {"formation.followers": 6})],
)
def test_hough_time_kept_by_counts_is_the_computed_one(
    monkeypatch: pytest.MonkeyPatch, scenario: str, overrides: Any
) -> None:
    kw: dict[str, Any] = {"duration_s": 30.0, "record_jobs": False, "overrides": overrides}
    kept = run_scenario(scenario, **kw)
    hook = sr._Coupling._hook_window

    def computed(self: Any, where: str) -> None:
        hook(self, where)
        self._hough_memo = _Never()

    monkeypatch.setattr(sr._Coupling, "_hook_window", computed)
    every = run_scenario(scenario, **kw)
    a, b = kept.windows, every.windows
    assert a is not None and b is not None and len(a) > 10
    for c in ("hough_ms", "assumption_broken", "response", "finish"):
        assert a[c].to_numpy().tobytes() == b[c].to_numpy().tobytes(), c
    pd.testing.assert_frame_equal(a, b)
    assert kept.summary == every.summary


@pytest.mark.parametrize(
    ("scenario", "overrides"),
    [("test2", None), ("test1", {"world.backend": "python", "formation.followers": 3})],
)
def test_records_keep_what_their_scan_reported(
    monkeypatch: pytest.MonkeyPatch, scenario: str, overrides: Any
) -> None:
    """Each record's points, fix errors, neighbours, changes and violations are its scans'
    as they were made (copies taken in the hook), not changed by the scans after them: the
    compiled world's scans and the Python reference's."""
    fields: dict[int, Any] = {}
    closed: dict[int, Any] = {}
    on_scan = sr._Coupling._on_scan

    def watched(self: Any, job: Any, seg: Any) -> None:
        prev = self._last_scanned
        on_scan(self, job, seg)
        rec = self._open[job.index]
        fields[rec.window] = (list(rec.voted), list(rec.fix_error), list(rec.neighbour))
        if prev is not None:  # (its interval closed by this scan)
            closed[prev.window] = (
                {k: list(v) for k, v in prev.changes.items()},
                {k: list(v) for k, v in prev.viol.items()},
            )

    monkeypatch.setattr(sr._Coupling, "_on_scan", watched)
    res = run_scenario(scenario, duration_s=30.0, record_jobs=False, overrides=overrides)
    recs = res.__dict__["_windows"].recs
    assert len(recs) > 10 and len(closed) >= len(recs) - 1
    for r in recs:
        assert (list(r.voted), list(r.fix_error), list(r.neighbour)) == fields[r.window]
        if r.window in closed:  # (the last may be closed after the loop, by `run`)
            changes = {k: list(v) for k, v in r.changes.items()}
            viol = {k: list(v) for k, v in r.viol.items()}
            assert (changes, viol) == closed[r.window]
    w = res.windows
    assert w is not None
    assert np.isfinite(w["hough_ms"]).all()
