"""The Hough transform in a window (rtsim.world.hough): fix, votes, voters, cells, and a
neighbour that takes the peak."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtsim.world import kernels
from rtsim.world.hough import WINDOW_ROW, Accumulator, window_cells
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
