"""The Hough transform in a window (rtsim.world.hough): fix, votes, voters, cells, and a
neighbour that takes the peak."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtsim.world import kernels
from rtsim.world.hough import (
    EPOCHS,
    TURNS,
    WINDOW_ROW,
    Accumulator,
    ring,
    ring_steps,
    window_cells,
)
from rtsim.world.rangefinder import Rangefinder

R_F = 25.0


def _scan(centres, sd=0.0, seed=0):  # type: ignore[no-untyped-def]
    rf = Rangefinder(R_F, 8000.0, sd, False)
    xy = np.array(centres, dtype=float)
    z = np.random.default_rng(seed).standard_normal(361)
    return tuple(a.copy() for a in rf.scan(xy[:, 0].copy(), xy[:, 1].copy(), z))


def _locate(scan, centres, r_H, fast=False):  # type: ignore[no-untyped-def]
    c = np.array(centres, dtype=float)
    acc = Accumulator(len(centres), R_F, 100.0, fast)
    return acc.locate(*scan, c[:, 0].copy(), c[:, 1].copy(), r_H).copy()


def test_window_cells_is_the_gauss_circle_count() -> None:
    """Cells whose centres lie within r_H: 1, 5, 13 lattice points for r = 0, 1, 2 and about
    π·r_H² at 25 cm (1961 against 1963.5)."""
    assert [window_cells(r) for r in (0.0, 1.0, 2.0)] == [1, 5, 13]
    assert window_cells(25.0) == pytest.approx(math.pi * 625, rel=0.01)


@pytest.mark.parametrize("offset", [(0.0, 0.0), (3.3, -2.7), (-7.9, 5.2)])
def test_the_peak_is_the_follower_centre(offset: tuple[float, float]) -> None:
    """A lone disc 300 cm behind: every point it returns votes (they can all belong to a disc
    centred in the window) and all of them vote for the cell holding its centre: the fix is
    within a cell of the truth, its votes are its points."""
    truth = (-290.0, 60.0)
    scan = _scan([truth])
    beams = int((scan[2] >= 0).sum())
    centre = (truth[0] + offset[0], truth[1] + offset[1])
    out = _locate(scan, [centre], 25.0)[0]
    assert out["voters"] == beams
    assert out["votes"] == beams
    assert math.hypot(out["fix_x"] - truth[0], out["fix_y"] - truth[1]) <= math.sqrt(0.5)
    assert out["owner"] == 0
    assert out["cells"] == window_cells(25.0)


def test_a_follower_outside_its_window_gives_no_fix_there() -> None:
    """The window 60 cm from the follower (r_H = 10): its points cannot belong to a disc
    centred in the window, none votes."""
    truth = (-300.0, 0.0)
    out = _locate(_scan([truth]), [(truth[0], truth[1] + 60.0)], 10.0)[0]
    assert out["voters"] == 0 and out["votes"] == 0
    assert math.isnan(out["fix_x"])


def test_a_neighbour_in_the_window_takes_the_peak() -> None:
    """Two followers 55 cm apart; follower 0's window centred 10 cm from follower 1
    (r_H = 20): follower 1's points take the peak, and the owner says so."""
    a, b = (-325.0, 27.5), (-325.0, -27.5)
    scan = _scan([a, b])
    out = _locate(scan, [(b[0], b[1] + 10.0), b], 20.0)
    assert out[0]["owner"] == 1
    assert math.hypot(out[0]["fix_x"] - b[0], out[0]["fix_y"] - b[1]) <= 1.0
    assert out[1]["owner"] == 1


def test_fix_error_grows_with_range() -> None:
    """With range noise, a far follower (fewer points) is located less precisely: the mean
    fix error over 200 scans at 500 cm exceeds that at 150 cm."""
    err = {}
    for rho in (150.0, 500.0):
        e = []
        for seed in range(200):
            truth = (-rho, 0.0)
            out = _locate(_scan([truth], sd=1.0, seed=seed), [truth], 25.0)[0]
            e.append(math.hypot(out["fix_x"] - truth[0], out["fix_y"] - truth[1]))
        err[rho] = float(np.mean(e))
    assert err[500.0] > err[150.0]


@pytest.mark.skipif(not kernels.available(), reason="numba not installed")
def test_compiled_hough_is_the_python_hough() -> None:
    centres = [(-150.0, 40.0), (-320.0, -84.0), (-330.0, 90.0)]
    scan = _scan(centres, sd=1.0, seed=2)
    win = [(x + 4.2, y - 3.1) for x, y in centres]
    acc = [Accumulator(3, R_F, 100.0, f) for f in (False, True)]
    s = [a.search(*scan, -300.0, 0.0, 100.0).copy() for a in acc]
    for rows in ((_locate(scan, win, 25.0), _locate(scan, win, 25.0, fast=True)), s):
        for field in WINDOW_ROW.names:  # (NaN fixes compare equal field by field)
            np.testing.assert_array_equal(rows[0][field], rows[1][field])


def _plain(scan, cx, cy, r_H, cell, n):  # type: ignore[no-untyped-def]
    """The window's row by the module docstring's definition, straight: every voting point's
    whole ring (all of `ring`'s directions, no arc, no skipping), the set of window cells it
    enters, one vote each; the peak, the tied cells' mean and the owner's tally."""
    px, py, owner = scan
    c, s = ring(R_F, cell)
    h = math.floor(r_H / cell)
    lim = (r_H / cell) ** 2
    votes: dict[tuple[int, int], int] = {}
    voters = 0
    for x, y in zip(px, py, strict=True):
        if math.isnan(x):
            continue
        d = math.sqrt((x - cx) * (x - cx) + (y - cy) * (y - cy))
        if d < R_F - r_H or d > R_F + r_H:
            continue
        voters += 1
        i = np.floor((x + R_F * c - cx) / cell + 0.5).astype(np.int64)
        j = np.floor((y + R_F * s - cy) / cell + 0.5).astype(np.int64)
        for ij in {(a, b) for a, b in zip(i.tolist(), j.tolist(), strict=True)}:
            if ij[0] ** 2 + ij[1] ** 2 <= lim:
                votes[ij] = votes.get(ij, 0) + 1
    row = {"voters": voters, "votes": max(votes.values(), default=0), "owner": -1}
    row["cells"] = window_cells(r_H, cell)
    row["fix_x"] = row["fix_y"] = math.nan
    if not votes:
        return row
    bi, bj = min(ij for ij, v in votes.items() if v == row["votes"])
    tied = [
        (a + h, b + h)
        for (a, b), v in votes.items()
        if v == row["votes"] and abs(a - bi) <= 2 and abs(b - bj) <= 2
    ]
    si = sj = 0.0
    for a, b in sorted(tied):  # (the kernel sums them in row-major order)
        si += a
        sj += b
    fx = cx + (si / len(tied) - h) * cell
    fy = cy + (sj / len(tied) - h) * cell
    row["fix_x"], row["fix_y"] = fx, fy
    tally = np.zeros(n, dtype=np.int64)
    for x, y, k in zip(px, py, owner, strict=True):
        if k >= 0 and abs(math.sqrt((x - fx) * (x - fx) + (y - fy) * (y - fy)) - R_F) <= cell:
            tally[k] += 1
    if tally.max() > 0:
        row["owner"] = int(np.argmax(tally))
    return row


def _random_case(rng: np.random.Generator):  # type: ignore[no-untyped-def]
    """A random scan and windows: 1–4 followers behind the leader (range noise 0–2 cm) with
    windows off their centres by up to r_H, or scattered points with random owners around
    the windows (some of them NaN); r_H from 2 to 60 cm, cells of 0.5, 1 or 2 cm, and now
    and then a point at the window centre (its whole ring)."""
    n = int(rng.integers(1, 5))
    r_H = float(rng.choice([float(rng.uniform(2.0, 60.0)), 25.0, 10.0]))
    cell = float(rng.choice([1.0, 1.0, 0.5, 2.0]))
    centres = np.column_stack([-rng.uniform(60.0, 600.0, n), rng.uniform(-150.0, 150.0, n)])
    off = rng.uniform(-1.0, 1.0, (n, 2)) * r_H / math.sqrt(2.0)
    win = centres + off
    if rng.random() < 0.5:
        scan = _scan(
            centres.tolist(), sd=float(rng.uniform(0.0, 2.0)), seed=int(rng.integers(1 << 30))
        )
    else:
        k = rng.integers(0, n, 361)
        ang = rng.uniform(0.0, 2.0 * math.pi, 361)
        rad = rng.uniform(0.0, R_F + r_H + 5.0, 361)
        px = win[k, 0] + rad * np.cos(ang)
        py = win[k, 1] + rad * np.sin(ang)
        px[rng.random(361) < 0.3] = np.nan
        px[: int(rng.integers(0, 3))] = win[0, 0]  # (at the window centre: d = 0)
        py[: int(rng.integers(0, 3))] = win[0, 1]
        owner = np.where(rng.random(361) < 0.8, k, -1).astype(np.int64)
        scan = (px, np.where(np.isnan(px), np.nan, py), owner)
    return scan, win, r_H, cell, n


@pytest.mark.parametrize("fast", [False, True])
def test_the_accumulator_is_the_plain_accumulator(fast: bool) -> None:
    """On random scans (`_random_case`), every window's row (fix to the bit, votes, voters,
    owner, cells) is the straightforward accumulator's (`_plain`: all directions of the
    ring, each cell a point's ring enters counted once), for the Python kernel and the
    compiled one: the arc, the ring's steps formed once, the skipped repeats and the flat
    cells change nothing."""
    if fast and not kernels.available():
        pytest.skip("numba not installed")
    rng = np.random.default_rng(36)
    windows = 0
    for _ in range(60 if fast else 12):
        scan, win, r_H, cell, n = _random_case(rng)
        acc = Accumulator(n, R_F, 100.0, fast, cell)
        rows = acc.locate(*scan, win[:, 0].copy(), win[:, 1].copy(), r_H).copy()
        for k in range(n):
            want = _plain(scan, win[k, 0], win[k, 1], r_H, cell, n)
            got = {f: rows[k][f].item() for f in WINDOW_ROW.names}
            for f in ("fix_x", "fix_y"):  # (bit for bit; NaN when no point voted)
                assert np.float64(got[f]).tobytes() == np.float64(want[f]).tobytes(), (f, got, want)
            assert {f: got[f] for f in ("votes", "voters", "owner", "cells")} == {
                f: want[f] for f in ("votes", "voters", "owner", "cells")
            }
            windows += 1
    assert windows > 30


def test_ring_steps_are_the_ring_times_r_F() -> None:
    """`ring_steps` is r_F·cos and r_F·sin of `ring`'s directions, `TURNS` turns over."""
    c, s = ring(R_F, 1.0)
    rx, ry = ring_steps(R_F, 1.0)
    a = np.arange(-2 * c.size, 3 * c.size)
    assert rx.size == TURNS * c.size
    np.testing.assert_array_equal(rx[a + 2 * c.size], R_F * c[a % c.size])
    np.testing.assert_array_equal(ry[a + 2 * c.size], R_F * s[a % c.size])


@pytest.mark.parametrize("fast", [False, True])
def test_the_epochs_running_out_change_no_record(fast: bool) -> None:
    """An accumulator whose epoch counter is about to pass `EPOCHS` (the stamps would no
    longer fit a cell's word) clears its words and starts again: the records of its next
    calls are a fresh accumulator's, bit for bit, and the counter is back near 0."""
    if fast and not kernels.available():
        pytest.skip("numba not installed")
    rng = np.random.default_rng(7)
    old = Accumulator(4, R_F, 100.0, fast)
    new = Accumulator(4, R_F, 100.0, fast)
    for _ in range(3):  # (dirty the old one's words with votes of past epochs)
        scan, win, r_H, _, n = _random_case(rng)
        old.locate(*scan, win[:, 0].copy(), win[:, 1].copy(), r_H)
    old.state[0] = EPOCHS - 400
    for _ in range(4):
        scan, win, r_H, cell, n = _random_case(rng)
        if cell != 1.0:
            continue
        args = (*scan, win[:, 0].copy(), win[:, 1].copy(), r_H)
        a, b = old.locate(*args)[:n].copy(), new.locate(*args)[:n].copy()
        assert a.tobytes() == b.tobytes()
    assert old.state[0] < 4 * 400


def test_rings_and_cells_kept_per_process_are_fresh_arrays() -> None:
    """`ring_steps` kept per r_F and cell gives each caller its own writable copy of the
    same numbers (a world's buffers), and `window_cells` the Gauss count it computes."""
    from rtsim.world.hough import ring, ring_steps, window_cells

    a, b = ring_steps(25.0, 1.0), ring_steps(25.0, 1.0)
    assert a[0] is not b[0] and a[0].flags.writeable and np.array_equal(a[0], b[0])
    c, s = ring(25.0, 1.0)
    assert np.array_equal(a[0], np.tile(25.0 * c, 5)) and np.array_equal(a[1], np.tile(25.0 * s, 5))
    a[0][:] = 0.0  # (a copy: the next caller's is untouched)
    assert np.array_equal(ring_steps(25.0, 1.0)[0], b[0])
    i = np.arange(-20, 21)
    assert window_cells(20.0) == int(((i[:, None] ** 2 + i[None, :] ** 2) <= 400.0).sum())
