"""Hough-window localization: window check, lost tracks, re-acquisition, and its cost
(docs/model/lower-bound.md, docs/model/world.md).

At a scan the leader measures each follower's position in its own frame (true position plus
noise). The Hough transform for follower i searches a window of radius r_H centred on the
follower's estimated position in the leader frame at the previous scan (the paper's Fig 5).
The fix counts when the follower returned at least ``min_points`` beams and the measured
centre lies within r_H of the window centre. Otherwise the track is **lost**: the event is
recorded and the leader re-runs the Hough transform over the full scan, with an accumulator
for a search window of radius r_reacq around the same centre; the follower is
**re-acquired** when it is visible and within r_reacq.

Cost (Eq 1 with counted points, plus the re-acquisitions):

    e_hough = π r_H² n e_cal + P e_trans + L (π r_reacq² e_cal + 361 e_trans),

P = scan points returned by the followers, L = lost followers in this scan.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from rtsim.analysis.window import LASER_POINTS, e_hough

__all__ = ["locate", "locate_one", "hough_time"]


class _ScanLike(Protocol):
    @property
    def n(self) -> int: ...
    @property
    def total_points(self) -> int: ...
    @property
    def n_lost(self) -> int: ...


def locate_one(
    measured: tuple[float, float],
    centre: tuple[float, float],
    points: int,
    r_H: float,
    r_reacq: float,
    min_points: int,
) -> tuple[bool, bool, bool]:
    """(in_window, lost, reacquired) for one follower's fix and Hough window centre."""
    dist = math.hypot(measured[0] - centre[0], measured[1] - centre[1])
    visible = points >= min_points
    in_window = visible and dist <= r_H
    return in_window, not in_window, (not in_window) and visible and dist <= r_reacq


def locate(
    measured: NDArray[np.float64],
    centre: NDArray[np.float64],
    points: NDArray[np.int64],
    r_H: float,
    r_reacq: float,
    min_points: int,
) -> tuple[NDArray[np.bool_], NDArray[np.bool_], NDArray[np.bool_]]:
    """:func:`locate_one` for (n, 2) arrays of fixes and centres: three (n,) bool arrays."""
    rows = [locate_one(tuple(m), tuple(c), int(p), r_H, r_reacq, min_points)
            for m, c, p in zip(measured.tolist(), centre.tolist(), points.tolist(),
                               strict=True)]
    out = np.array(rows, dtype=bool).reshape(-1, 3)
    return out[:, 0], out[:, 1], out[:, 2]


def hough_time(scan: _ScanLike, e_cal: float, e_trans: float, r_H: float, r_reacq: float) -> float:
    """Localization segment time (ms) for ``scan``: Eq 1 with its counted points, plus a
    re-acquisition (π r_reacq² e_cal + 361 e_trans) per lost follower."""
    base = e_hough(scan.n, r_H, e_cal, e_trans, k=0.0, points=scan.total_points)
    return base + scan.n_lost * (math.pi * r_reacq**2 * e_cal + LASER_POINTS * e_trans)
