"""The contact bound's report (issue 33): windows.csv's contact columns against the truth
recomputed from the table's own positions, the breaks counted in summary.json, and the
plan's prediction of the closest approach against what the world did."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from rtsim.coupling.recorder import WindowRecord, records_columns
from rtsim.coupling.scenario_run import run_scenario
from rtsim.coupling.summary import summarize
from rtsim.world.contact import closest_to, contact_bound, contact_distance

N = 4


@pytest.fixture(scope="module")
def run() -> object:
    return run_scenario(
        "test2", seed=21, duration_s=60.0, overrides={"formation.followers": N}, record_jobs=False
    )


def test_true_closest_approach_is_the_tables_own_geometry(run) -> None:  # type: ignore[no-untyped-def]
    """f{i}_contact_cm_true = the smaller, at this window's scan and the next, of follower
    i's distance to the nearest other robot, from the truth columns (np.hypot, pairwise)."""
    w = run.windows
    pts = [np.column_stack([w["leader_x"], w["leader_y"]])]
    pts += [np.column_stack([w[f"f{i}_x"], w[f"f{i}_y"]]) for i in range(1, N + 1)]
    for i in range(1, N + 1):
        d = np.min(
            [np.hypot(*(pts[i] - pts[j]).T) for j in range(N + 1) if j != i], axis=0
        )  # at each scan
        want = np.minimum(d[:-1], d[1:])
        got = w[f"f{i}_contact_cm_true"].to_numpy()[:-1]
        np.testing.assert_allclose(got, want, rtol=1e-12)
        assert (w[f"f{i}_viol_contact"] == (w[f"f{i}_contact_cm_true"] < 60.0)).all()
    every = w[[f"f{i}_contact_cm_true" for i in range(1, N + 1)]].to_numpy()
    assert run.summary["min_robot_distance_cm"] <= every.min() + 1e-9
    broke = sum(int(w[f"f{i}_viol_contact"].sum()) for i in range(1, N + 1))
    assert run.summary["violations"]["contact"] == broke == 0
    assert every.min() >= 60.0  # the layout's 65 cm, kept


def test_plan_predicts_the_closest_approach(run) -> None:  # type: ignore[no-untyped-def]
    """The rollout's closest approach is a prediction from estimates a few windows old: within
    a few cm of the truth in every window (the robots' tracking error is about 4 cm)."""
    w = run.windows
    for i in range(1, N + 1):
        err = (w[f"f{i}_contact_cm_pred"] - w[f"f{i}_contact_cm_true"]).abs()
        assert err.iloc[1:].max() < 8.0, (i, err.max())
        assert err.median() < 3.0


def test_summary_counts_contact_breaks() -> None:
    """violations.contact counts the (window, follower) pairs flagged, like the four."""
    recs = []
    for k, flags in enumerate([(False, True), (True, True), (False, False)]):
        r = WindowRecord(k, 100.0 * k, 100.0, 100.0, 200.0, "none", 30.0, 30.0, 30.0,
                         "none", True, "straight", 0.0, est=((0.0,) * 7,) * 2)  # fmt: skip
        r.truth, r.pred, r.finish = ((0.0,) * 7,) * 2, ((math.inf,) * 4,) * 2, 100.0 * k + 50
        r.lost = np.zeros(2, dtype=bool)
        r.viol = {k2: np.zeros(2, dtype=bool) for k2 in
                  ("localization", "separation", "path_diversion", "bearing")}  # fmt: skip
        r.changes = {k2: np.zeros(2) for k2 in ("displacement", "d_rho", "travel", "d_beta")}
        r.near_true, r.near_pred, r.viol_contact = (55.0, 70.0), (61.0, 72.0), flags
        recs.append(r)
    lim = ((25.0,) * 2, (1.0,) * 2, (1.0,) * 2, (0.1,) * 2)
    df = pd.DataFrame(records_columns(recs, 2, lim))
    assert list(df["f2_viol_contact"]) == [True, True, False]
    s = summarize(df, mode="plan", w_sch=100.0, duration_s=1.0, seed=0, scenario="x", n=2)
    assert s["violations"]["contact"] == 3


def test_one_distance_for_both_backends() -> None:
    """closest_to is the nearest other robot, leader included; the bound reads ≥ w exactly
    when the distance keeps d_c = 2·r_F + clearance."""
    xs, ys = [3.0, 0.0, 30.0], [4.0, 10.0, 0.0]
    assert closest_to(xs, ys, 0, 0.0, 0.0) == 5.0  # the leader
    assert closest_to(xs, ys, 1, 0.0, 0.0) == pytest.approx(math.hypot(3.0, 6.0))
    assert closest_to(xs, ys, 2, 0.0, 0.0) == pytest.approx(math.hypot(27.0, 4.0))
    d_c = contact_distance(25.0, 10.0)
    assert d_c == 60.0
    assert contact_bound(240.0, 60.0, d_c) == 240.0
    assert contact_bound(240.0, 59.9, d_c) < 240.0 < contact_bound(240.0, 60.1, d_c)


def test_contact_is_plans_own_key() -> None:
    """``[adjust] contact`` is a bool of the policy plan (default true); another policy's file
    naming it is an error that says whose key it is."""
    from rtsim.control.policy import PlanPolicy, make_policy
    from rtsim.errors import InputError

    assert PlanPolicy.params["contact"] is True and PlanPolicy().contact is True
    assert make_policy("plan", {"contact": False}).contact is False
    with pytest.raises(InputError, match="contact: must be true or false"):
        make_policy("plan", {"contact": 1})
    with pytest.raises(InputError, match="a key of policy 'plan'"):
        make_policy("adjust", {"contact": False})


def test_breaks_flagged_per_follower_and_none_shared(monkeypatch: pytest.MonkeyPatch) -> None:
    """A record's contact flags are x < d_c of its true closest approaches; a record without
    a break (and without a lost track) holds the run's one tuple of n False, no list of its
    own, read as the same columns."""
    import rtsim.coupling.scenario_run as sr

    def records() -> list[WindowRecord]:
        res = run_scenario("test2", seed=3, duration_s=20.0, record_jobs=False)
        return res.__dict__["_windows"].recs  # type: ignore[no-any-return]

    recs = records()
    assert len({id(r.viol_contact) for r in recs} | {id(r.lost) for r in recs}) == 1
    assert recs[0].viol_contact == (False, False)
    d_c = float(np.median([x for r in recs for x in r.near_true]))  # (about half break)
    monkeypatch.setattr(sr, "contact_distance", lambda r_f, clearance: d_c)
    recs = records()
    flags = [list(r.viol_contact) for r in recs]
    assert flags == [[x < d_c for x in r.near_true] for r in recs]
    assert any(True in f for f in flags) and any(True not in f for f in flags)
    lim = ((25.0,) * 2, (1.0,) * 2, (1.0,) * 2, (0.1,) * 2)
    df = pd.DataFrame(records_columns(recs, 2, lim))
    assert df["f1_viol_contact"].tolist() == [f[0] for f in flags]
