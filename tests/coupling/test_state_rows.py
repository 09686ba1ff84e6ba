"""The window record's follower rows made when read (`StateRows`) are the rows made at once.

The windows table's truth and est columns hold (x, y, θ, ρ, β, θ_L − θ_F, V_F) per
follower; the relative state is computed when the table (or a policy's `FollowerEstimate`)
first reads them, from copies of the poses taken in the window. These tests check the rows
against hand-derived geometry, against the eager formula on a run's own records, and that a
change to the world's lists after the window does not reach them.
"""

from __future__ import annotations

import math

import pytest

from rtsim.analysis.kinematics import relative_state
from rtsim.coupling import scenario_run
from rtsim.coupling.recorder import StateRows


def test_rows_match_hand_geometry() -> None:
    # leader at the origin heading +x; follower 1 straight behind at 10 cm heading +x,
    # follower 2 at 5 cm to its left heading +y (θ_L − θ_F = −π/2)
    rows = StateRows((0.0, 0.0, 0.0), [(-10.0, 0.0, 0.0), (0.0, 5.0, math.pi / 2)], [3.0, 4.0])
    (r1, r2) = rows
    assert r1 == (-10.0, 0.0, 0.0, 10.0, math.pi, 0.0, 3.0)
    assert r2[:3] == (0.0, 5.0, math.pi / 2) and r2[6] == 4.0
    assert r2[3] == pytest.approx(5.0) and r2[4] == pytest.approx(math.pi / 2)
    assert r2[5] == pytest.approx(-math.pi / 2)
    assert len(rows) == 2 and rows[1] == r2 and rows == (r1, r2)


def test_rows_are_the_copies_taken() -> None:
    xs, ys, ths, vs = [1.0, 2.0], [3.0, 4.0], [0.1, 0.2], [5.0, 6.0]
    rows = StateRows((0.0, 0.0, 0.3), list(zip(xs, ys, ths, strict=True)), list(vs))
    want = tuple(
        (x, y, th, *relative_state((0.0, 0.0, 0.3), (x, y, th)), v)
        for x, y, th, v in zip(xs, ys, ths, vs, strict=True)
    )
    xs[0], vs[1] = 99.0, 99.0  # the world's lists move on after the window
    assert tuple(rows) == want


def test_run_records_equal_eager_rows(monkeypatch: pytest.MonkeyPatch) -> None:
    """A short Test 2 run: every record's truth and est rows, read after the run, are the
    eager formula on the poses of their window (captured when the rows were made)."""
    made: list[tuple[StateRows, tuple[tuple[float, ...], ...]]] = []
    real = scenario_run.StateRows

    def capture(lp, poses, speeds):  # type: ignore[no-untyped-def]
        out = real(lp, poses, speeds)
        if type(speeds) is int:  # (a copy of the scan's float rows: x, y, θ, v at a row)
            x, y, th, speeds = poses[speeds : speeds + 4].tolist()
            poses = list(zip(x, y, th, strict=True))
        elif speeds is None:  # (the estimates' rows: x, y, θ, v first)
            poses, speeds = [tuple(r[:3]) for r in poses], [r[3] for r in poses]
        else:
            poses, speeds = list(poses), list(speeds)
            out = real(lp, poses, speeds)  # (the truth's poses come as a zip)
        eager = tuple((*p, *relative_state(lp, p), v) for p, v in zip(poses, speeds, strict=True))
        made.append((out, eager))
        return out

    monkeypatch.setattr(scenario_run, "StateRows", capture)
    res = scenario_run.run_scenario(
        "test2", record_jobs=False, overrides={"formation.followers": 3}, duration_s=20.0
    )
    assert len(res.windows) > 10 and len(made) > 2 * len(res.windows)
    for rows, eager in made:
        assert rows.rows() == eager
    assert res.windows["f3_rho_est"].notna().all()


def _bits(rows: object) -> bytes:
    import numpy as np

    return np.asarray(rows, dtype=float).tobytes()


def test_relative_states_is_relative_state_pair_by_pair() -> None:
    """The table's one-pass form (`relative_states`) gives `relative_state`'s floats, bit
    for bit: random poses, a follower on the leader (ρ = 0), headings at the wraps, NaN."""
    import numpy as np

    from rtsim.analysis.kinematics import relative_states

    rng = np.random.default_rng(7)
    lps = [tuple(v) for v in rng.normal(0, 300, (400, 3)).tolist()]
    fps = [tuple(v) for v in rng.normal(0, 300, (400, 3)).tolist()]
    lps += [(1.0, 2.0, 0.5), (0.0, 0.0, math.pi), (3.0, 4.0, -math.pi), (0.0, 0.0, 0.0)]
    fps += [(1.0, 2.0, 0.1), (-1.0, 0.0, -math.pi), (3.0, 5.0, math.pi), (math.nan, 1.0, 0.0)]
    tau = 2.0 * math.pi  # (signed zeros: β of a follower dead ahead, θ at multiples of 2π)
    lps += [(0.0, 0.0, 0.0), (0.0, 0.0, tau), (0.0, 0.0, -tau), (0.0, 0.0, -0.0), (0, 0, 4 * tau)]
    fps += [(1.0, -0.0, 0.0), (1.0, 0.0, -tau), (1.0, -0.0, tau), (1.0, 0.0, 0.0), (1, 0, -0.0)]
    want = [relative_state(lp, fp) for lp, fp in zip(lps, fps, strict=True)]
    got = list(zip(*relative_states(lps, fps), strict=True))
    assert _bits(got) == _bits(want)
    assert relative_states([], []) == ([], [], [])


def test_table_states_are_the_rows() -> None:
    """The windows table's truth and est columns made in one pass from records not read yet
    (`recorder._states`) are those of their rows made one by one (`StateRows.rows`)."""
    import numpy as np

    from rtsim.coupling.recorder import _flat, _states

    res = scenario_run.run_scenario(
        "test2", record_jobs=False, overrides={"formation.followers": 3}, duration_s=20.0
    )
    held = res.__dict__["_windows"]  # (the records, the frame not built yet: `_Frame`)
    recs, n = held.recs, held.n
    for name in ("truth", "est"):
        objs = [getattr(r, name) for r in recs]
        # (a copy of the scan's rows; the decision's pack transposed, x its first row)
        assert {type(o._speeds) for o in objs} == {int}
        assert {o._speeds for o in objs} == ({scenario_run.TRUTH_ROW} if name == "truth" else {0})
        # (each form: as the run made them, as poses and speeds, and as rows of x, y, θ,
        # V_F and more, a decision's rows read as lists)
        forms = [[StateRows(o._lp, o._poses, o._speeds) for o in objs]]
        forms.append([StateRows(o._lp, *_poses_speeds(o)) for o in objs])
        forms.append([StateRows(o._lp, o._poses[o._speeds :].T.tolist(), None) for o in objs])
        forms.append(  # (mixed: every other record as poses and speeds)
            [
                StateRows(o._lp, *(_poses_speeds(o) if k % 2 else (o._poses, o._speeds)))
                for k, o in enumerate(objs)
            ]
        )
        for k, fresh in enumerate(forms):
            a = _states(iter(fresh), len(fresh), n)
            # (one form: not made, one pass over the poses; mixed: row by row)
            assert all(o._rows is None for o in fresh) or k == 3
            b = _flat(iter(fresh), float, len(fresh) * n * 7).reshape(len(fresh), n, 7)
            assert a.tobytes() == b.tobytes() and a.dtype == np.float64
            assert _states(iter(fresh), len(fresh), n).tobytes() == b.tobytes()  # (rows made)


def _poses_speeds(o: StateRows) -> tuple[list[tuple[float, ...]], list[float]]:
    """A `StateRows`' poses and speeds as lists, from any of its forms."""
    poses, speeds = o._poses, o._speeds
    if type(speeds) is int:
        x, y, th, v = poses[speeds : speeds + 4].tolist()
        return list(zip(x, y, th, strict=True)), v
    return [tuple(r[:3]) for r in poses], [r[3] for r in poses]


def test_scan_changes_read_as_the_scans_lists(monkeypatch: pytest.MonkeyPatch) -> None:
    """A run's records keep their changes as `ScanChanges` over a copy of the fused scan's
    float rows (the one closed after the loop too): each reads as the scan's mapping (a run
    that keeps the lists), and `changes_array` gives the same floats whichever form a
    record holds, all of one or mixed."""
    import numpy as np

    from rtsim.coupling.recorder import CHANGE_KEYS, ScanChanges, changes_array

    def run() -> list[scenario_run.WindowRecord]:
        res = scenario_run.run_scenario(
            "test2", record_jobs=False, overrides={"formation.followers": 3}, duration_s=20.0
        )
        return res.__dict__["_windows"].recs  # type: ignore[no-any-return]

    recs = run()
    close = scenario_run._Coupling._close
    monkeypatch.setattr(
        scenario_run._Coupling, "_close", lambda self, *a: close(self, *a[:3])
    )  # (no rows: the scan's lists)
    plain = run()
    assert len(recs) == len(plain) > 10
    assert all(type(r.changes) is ScanChanges for r in recs)
    assert not any(type(r.changes) is ScanChanges for r in plain)
    for r, p in zip(recs, plain, strict=True):
        got, want_map = r.changes, p.changes
        assert list(got) == list(CHANGE_KEYS) == list(want_map) and len(got) == 4
        assert [list(map(float, got[k])) for k in CHANGE_KEYS] == [want_map[k] for k in CHANGE_KEYS]
        assert "other" not in got and got.get("other") is None
    want = np.array([[p.changes[k] for k in CHANGE_KEYS] for p in plain], dtype=float)
    mixed = [*recs[:-1], plain[-1]]  # (a record holding the scan's lists among copies)
    for part, w in ((mixed, want), (recs[:-1], want[:-1]), (plain, want), ([], want[:0])):
        got_a = changes_array(part, 3)
        assert got_a.dtype == np.float64 and got_a.tobytes() == w.tobytes()


def test_changes_array_of_copies_in_any_layout() -> None:
    """`changes_array` joins the copies' bytes when they are C-contiguous float arrays, and
    concatenates them otherwise (Fortran order, a strided view, another dtype): the same
    values either way, as a writable array of its own."""
    import numpy as np

    from rtsim.coupling.recorder import CHANGE_KEYS, ScanChanges, changes_array
    from rtsim.world.scanstep import FLOAT_COUNT

    rng = np.random.default_rng(5)
    n, m = 3, 7
    base = [rng.random((FLOAT_COUNT, n)) for _ in range(m)]
    at = ScanChanges.AT
    want = np.array([b[at : at + len(CHANGE_KEYS)] for b in base])

    def of(arrays: list[np.ndarray]) -> list[object]:
        out = []
        for a in arrays:
            rec = scenario_run.WindowRecord.__new__(scenario_run.WindowRecord)
            rec.changes = ScanChanges(a)
            out.append(rec)
        return out

    wide = [np.repeat(b, 2, axis=1)[:, ::2] for b in base]  # (strided views, same values)
    for arrays in (base, [np.asfortranarray(b) for b in base], wide, [*base[:3], *wide[3:]]):
        got = changes_array(of(arrays), n)  # type: ignore[arg-type]
        assert got.flags.writeable and got.tobytes() == want.tobytes()
    as32 = [b.astype(np.float32) for b in base]
    got = changes_array(of([*base[:2], *as32[2:]]), n)  # type: ignore[arg-type]
    mixed = np.array([b[at : at + 4] for b in [*base[:2], *as32[2:]]], dtype=np.float64)
    assert got.tobytes() == mixed.tobytes()
