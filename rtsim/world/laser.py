"""The leader's laser rangefinder: which of the 361 backward beams hit which follower
(docs/model/index.md, docs/model/lower-bound.md).

361 beams over 180°, 0.5° apart, facing backward: beam j has bearing 90° + 0.5°·j in the
leader's frame (counter-clockwise from the heading, the same convention as β), so the
scan covers the left side (90°), straight behind (180°) and the right side (270°). The
laser sits at the leader's reference point (the origin of its frame).

A beam of bearing φ hits the disc of radius r_F centred at (ρ, β) when its angular
distance to β is at most arcsin(r_F/ρ) (docs/model/lower-bound.md), at range ρ cos(φ−β) − √(r_F² −
ρ² sin²(φ−β)).
Each beam returns only its nearest hit, so a nearer follower shadows a farther one.
Only follower returns are counted (the paper's k points per follower); walls and clutter
are not modelled.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from rtsim.analysis.window import LASER_POINTS

__all__ = [
    "BEAM_BEARINGS",
    "FIRST_BEARING",
    "BEAM_SPACING",
    "count_beams",
    "count_beams_xy",
    "beam_owners",
    "max_points",
]

#: Angular spacing of the beams (rad): 0.5°.
BEAM_SPACING = math.radians(0.5)
#: Bearing of every beam in the leader frame (rad), 90° … 270°.
BEAM_BEARINGS: NDArray[np.float64] = np.radians(90.0 + 0.5 * np.arange(LASER_POINTS))
#: Bearing of the first beam (rad): 90°.
FIRST_BEARING = math.pi / 2
_COS = np.cos(BEAM_BEARINGS)
_SIN = np.sin(BEAM_BEARINGS)


def beam_owners(
    rel_xy: NDArray[np.float64], r_F: float, max_range: float = math.inf
) -> NDArray[np.intp]:
    """Index of the follower each beam returns from (−1: no follower), nearest hit wins.

    ``rel_xy`` is an (n, 2) array of follower centres in the leader frame (cm).
    """
    rel = np.asarray(rel_xy, dtype=float).reshape(-1, 2)
    if rel.shape[0] == 0:
        return np.full(LASER_POINTS, -1, dtype=np.intp)
    x = rel[:, 0:1]
    y = rel[:, 1:2]
    proj = x * _COS + y * _SIN  # (n, 361) distance along the beam to the foot
    perp = x * _SIN - y * _COS  # signed distance of the centre from the beam
    half2 = r_F * r_F - perp * perp
    hit = (half2 >= 0.0) & (proj > 0.0)
    rng = np.where(hit, proj - np.sqrt(np.where(hit, half2, 0.0)), np.inf)
    rng = np.maximum(rng, 0.0)
    rng[rng > max_range] = np.inf
    owner = np.argmin(rng, axis=0)
    nearest = rng[owner, np.arange(LASER_POINTS)]
    return np.where(np.isfinite(nearest), owner, -1)


def count_beams(
    rel_xy: NDArray[np.float64], r_F: float, max_range: float = math.inf
) -> NDArray[np.int64]:
    """Beams returned by each follower's disc, with shadowing: an (n,) integer array.

    Fast path: when no two discs' beam intervals overlap (no shadowing possible) and every
    disc is wholly inside or beyond the range, each count is the number of beams within
    arcsin(r_F/ρ) of the disc's bearing; otherwise [`beam_owners`][rtsim.world.laser.beam_owners]
    resolves every beam.
    """
    rel = np.asarray(rel_xy, dtype=float).reshape(-1, 2)
    return np.array(count_beams_xy(rel.tolist(), r_F, max_range), dtype=np.int64)


def count_beams_xy(
    rel_xy: Sequence[Sequence[float]], r_F: float, max_range: float = math.inf
) -> list[int]:
    """[`count_beams`][rtsim.world.laser.count_beams] on a list of (x, y) pairs (floats), returning
    a list of ints
    (the world's per-scan path: no arrays unless a shadowing check needs every beam)."""
    n = len(rel_xy)
    spans: list[tuple[int, int, int]] = []
    counts = [0] * n
    for k, (x, y) in enumerate(rel_xy):
        rho = math.hypot(x, y)
        if rho <= r_F or (rho - r_F <= max_range < rho + r_F):
            spans = []
            break
        if rho - r_F > max_range:
            continue
        alpha = math.asin(r_F / rho)
        beta = math.atan2(y, x) % (2 * math.pi)
        lo = max(0, math.ceil((beta - alpha - FIRST_BEARING) / BEAM_SPACING))
        hi = min(LASER_POINTS - 1, math.floor((beta + alpha - FIRST_BEARING) / BEAM_SPACING))
        if hi >= lo:
            spans.append((lo, hi, k))
    else:
        spans.sort()
        if all(spans[j][1] < spans[j + 1][0] for j in range(len(spans) - 1)):
            for lo, hi, k in spans:
                counts[k] = hi - lo + 1
            return counts
    owners = beam_owners(np.array(rel_xy, dtype=float).reshape(-1, 2), r_F, max_range)
    return [int(c) for c in np.bincount(owners[owners >= 0], minlength=n)]


def max_points(rho: float, r_F: float) -> int:
    """Largest number of beams a lone disc of radius ``r_F`` at distance ``rho`` can return,
    over all bearings in the scan (the geometric k of Eq 2; the paper takes 34 at 150 cm).

    The disc subtends 2·arcsin(r_F/ρ); a window of that width holds at most
    ⌊2·arcsin(r_F/ρ) / 0.5°⌋ + 1 beams (the worst case places a beam on one edge).
    """
    if rho <= r_F:
        return LASER_POINTS
    width = 2.0 * math.asin(r_F / rho)
    return min(LASER_POINTS, int(math.floor(width / BEAM_SPACING + 1e-12)) + 1)
