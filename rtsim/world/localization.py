"""Hough-window localization: the window check, lost tracks and their causes, the search
for a lost follower and re-acquisition, and what they cost (Eq 1 with counted points, plus
the searches); the window's centre is ``[localization] centre`` (docs/localization.md,
docs/model/lower-bound.md)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Protocol, overload

import numpy as np
from numpy.typing import NDArray

from rtsim.analysis.window import LASER_POINTS, e_hough
from rtsim.world.laser import count_beams_xy

__all__ = [
    "LOST_CAUSES",
    "ExpectedBeams",
    "locate",
    "locate_one",
    "lost_cause",
    "counted_time",
    "hough_time",
    "search_time",
]

#: Why a track is lost: the fix fell outside the Hough window; the follower returned too few
#: beams although the laser could reach it alone (hidden by a nearer follower, or its disc
#: covers too few beams); no beam reaches it (beyond the laser's range or outside its field);
#: another follower's points took the window's peak (``model = "hough"``: the window does no
#: data association).
LOST_CAUSES: tuple[str, ...] = ("outside_window", "occluded", "out_of_range", "neighbour")


class _ScanLike(Protocol):
    @property
    def n(self) -> int: ...
    @property
    def total_points(self) -> int: ...
    @property
    def n_lost(self) -> int: ...
    @property
    def n_searched(self) -> int: ...
    @property
    def hough_points(self) -> int: ...
    @property
    def cells(self) -> int | None: ...


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


def lost_cause(
    visible: bool, rel_xy: tuple[float, float], r_F: float, max_range: float, min_points: int
) -> str:
    """The cause (`LOST_CAUSES`) of a lost track: ``visible`` (at least ``min_points``
    beams returned) means the fix fell outside the window; otherwise the follower at
    ``rel_xy`` (leader frame, cm) alone would return no beam (``out_of_range``) or some
    (``occluded``: hidden by another follower or too few beams)."""
    if visible:
        return "outside_window"
    alone = count_beams_xy([rel_xy], r_F, max_range)[0]
    return "occluded" if alone > 0 else "out_of_range"


class ExpectedBeams(Sequence[int]):
    """The beams the leader expects of each follower at a scan (``search = "visible"``): the
    laser's count for discs at the window ``centres`` (leader frame, cm), shadowing included
    (`rtsim.world.laser.count_beams_xy`), counted on the first read — a model reads it only
    for a follower whose window has no fix, which most scans have none of."""

    __slots__ = ("_centres", "_r_F", "_max_range", "_counts")

    def __init__(self, centres: list[tuple[float, float]], r_F: float, max_range: float) -> None:
        self._centres, self._r_F, self._max_range = centres, r_F, max_range
        self._counts: list[int] | None = None

    def counts(self) -> list[int]:
        """Every follower's expected beams (a list; counted once)."""
        if self._counts is None:
            self._counts = count_beams_xy(self._centres, self._r_F, self._max_range)
        return self._counts

    @overload
    def __getitem__(self, i: int) -> int: ...
    @overload
    def __getitem__(self, i: slice) -> list[int]: ...
    def __getitem__(self, i: int | slice) -> int | list[int]:
        return self.counts()[i]

    def __len__(self) -> int:
        return len(self._centres)

    def __repr__(self) -> str:
        return f"ExpectedBeams({self.counts()!r})"


def locate(
    measured: NDArray[np.float64],
    centre: NDArray[np.float64],
    points: NDArray[np.int64],
    r_H: float,
    r_reacq: float,
    min_points: int,
) -> tuple[NDArray[np.bool_], NDArray[np.bool_], NDArray[np.bool_]]:
    """`locate_one` for (n, 2) arrays of fixes and centres: three (n,) bool arrays."""
    rows = [
        locate_one(tuple(m), tuple(c), int(p), r_H, r_reacq, min_points)
        for m, c, p in zip(measured.tolist(), centre.tolist(), points.tolist(), strict=True)
    ]
    out = np.array(rows, dtype=bool).reshape(-1, 3)
    return out[:, 0], out[:, 1], out[:, 2]


def hough_time(scan: _ScanLike, e_cal: float, e_trans: float, r_H: float, r_reacq: float) -> float:
    """Localization segment time (ms) for ``scan``: Eq 1 with its counted points, plus a
    search (π r_reacq² e_cal + 361 e_trans) per lost follower searched for.

    ``gaussian``: π·r_H²·n·e_cal + P·e_trans, P the beams the followers returned;
    ``hough``: C·e_cal + min(361, P)·e_trans with the scan's own counts, C the cells the
    windows' accumulators covered and P the points that voted in them."""
    cells = scan.cells
    points = scan.total_points if cells is None else scan.hough_points
    search_ms = search_time(e_cal, e_trans, r_reacq)
    return counted_time(scan.n, cells, points, scan.n_searched, e_cal, e_trans, r_H, search_ms)


def counted_time(
    n: int,
    cells: int | None,
    points: int,
    searched: int,
    e_cal: float,
    e_trans: float,
    r_H: float,
    search_ms: float,
) -> float:
    """`hough_time` from a scan's counts, for a caller that has them: ``n`` followers,
    the ``cells`` its windows' accumulators covered (None: ``gaussian``), its ``points``
    (``Scan.hough_points``; with ``gaussian``, ``Scan.total_points``: the same count), and
    ``searched`` searches (``Scan.n_searched``) of ``search_ms`` each (`search_time`)."""
    if cells is None:
        base = e_hough(n, r_H, e_cal, e_trans, k=0.0, points=points)
    else:
        base = cells * e_cal + min(LASER_POINTS, points) * e_trans
    return base + searched * search_ms


def search_time(e_cal: float, e_trans: float, r_reacq: float) -> float:
    """One re-acquisition search (ms): an accumulator of radius r_reacq and all 361 points,
    π·r_reacq²·e_cal + 361·e_trans."""
    return math.pi * r_reacq**2 * e_cal + LASER_POINTS * e_trans
