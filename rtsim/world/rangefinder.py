"""The leader's laser scan as data: per beam, the nearest hit among the followers' discs
(docs/localization.md).

The rangefinder is the paper's: 361 beams over 180° at 0.5°, facing backward
(`BEAM_BEARINGS`: bearing 90° + 0.5°·j in the leader's frame). Beam j
meets the disc of radius r_F centred at (x, y) when the centre lies within r_F of the beam's
ray, at range

    r = p − √(r_F² − q²),   p = x·cos φ + y·sin φ,   q = x·sin φ − y·cos φ

(p the distance along the beam to the foot of the perpendicular, q the centre's distance
from the beam; the same geometry as [`beam_owners`][rtsim.world.laser.beam_owners]). Each beam
returns
its nearest hit only, so occlusion follows from the geometry; a beam whose nearest hit lies
beyond the maximum range returns nothing. The reading is that range plus range noise
(σ·z, z a standard normal drawn per beam); the scan point is the reading along the beam, in
the leader's frame at the scan instant. Only the followers are in the world: no walls, no
clutter.

`scan_points` is one plain function that numba compiles (`compiled`); the Python
path runs the same function and is the reference in the tests.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rtsim.model.window import LASER_POINTS
from rtsim.world.jit import build, kernel
from rtsim.world.kernels import built_entry
from rtsim.world.laser import BEAM_BEARINGS, BEAM_SPACING, FIRST_BEARING

__all__ = ["BEAM_COS", "BEAM_SIN", "Rangefinder", "beam_span", "compiled", "scan_points"]

#: cos and sin of every beam's bearing (the laser's fixed geometry).
BEAM_COS: NDArray[np.float64] = np.cos(BEAM_BEARINGS)
BEAM_SIN: NDArray[np.float64] = np.sin(BEAM_BEARINGS)

_COMPILED: Any = None


@kernel
def scan_points(
    xs: NDArray[np.float64],
    ys: NDArray[np.float64],
    r_F: float,
    max_range: float,
    range_sd: float,
    z: NDArray[np.float64],
    cos_b: NDArray[np.float64],
    sin_b: NDArray[np.float64],
    px: NDArray[np.float64],
    py: NDArray[np.float64],
    owner: NDArray[np.int64],
    counts: NDArray[np.int64],
) -> int:
    """Fill one scan (module docstring): for every beam j, ``owner[j]`` the index of the
    follower it hit (−1: nothing) and (``px[j]``, ``py[j]``) its point in the leader's frame
    (cm; NaN when nothing), the true range plus ``range_sd``·``z[j]``; ``counts[k]`` the beams
    follower k returned. ``xs``, ``ys``: the followers' centres in the leader's frame (cm).
    Returns the number of beams that hit.

    Each follower is tried on the beams of its span only (`beam_span`: every beam that can
    meet its disc, and a margin), the followers in their order, nearest hit kept (the first
    of equals): per beam the hits and the choice among them of trying every follower on
    every beam, with a tenth of the work. ``px`` and ``owner`` hold each beam's nearest hit
    and its follower until the beams are read."""
    n = xs.shape[0]
    r2 = r_F * r_F
    nb = cos_b.shape[0]
    for j in range(nb):
        px[j] = math.inf
        owner[j] = -1
    for k in range(n):
        x, y = xs[k], ys[k]
        lo, hi = beam_span(x, y, r_F, nb)
        for j in range(lo, hi):
            c = cos_b[j]
            s = sin_b[j]
            p = x * c + y * s
            q = x * s - y * c
            half2 = r2 - q * q
            if half2 >= 0.0 and p > 0.0:
                r = p - math.sqrt(half2)
                if r < 0.0:
                    r = 0.0
                if r < px[j]:
                    px[j] = r
                    owner[j] = k
    for k in range(n):
        counts[k] = 0
    hits = 0
    for j in range(nb):
        who = owner[j]
        best = px[j]
        if who >= 0 and best <= max_range:
            r = best + range_sd * z[j]
            counts[who] += 1
            px[j] = r * cos_b[j]
            py[j] = r * sin_b[j]
            hits += 1
        else:
            owner[j] = -1
            px[j] = math.nan
            py[j] = math.nan
    return hits


@kernel
def beam_span(x: float, y: float, r_F: float, nb: int) -> tuple[int, int]:
    """The beams [lo, hi) of the ``nb`` (bearings `FIRST_BEARING` + j·`BEAM_SPACING`, the
    laser's: `rtsim.world.laser`) that can meet the disc of
    radius ``r_F`` centred at (``x``, ``y``): those within arcsin(r_F/ρ) of its bearing, two
    beams of margin each side (so that the bounds' rounding never leaves one out); every beam
    when the disc is within 1 % of the leader (ρ ≤ 1.01·r_F: the arc's wrap-around is then
    less than the margin away from the scan's ends)."""
    rho = math.sqrt(x * x + y * y)
    if rho <= 1.01 * r_F:
        return 0, nb
    alpha = math.asin(r_F / rho)
    beta = math.atan2(y, x) % (2.0 * math.pi) - FIRST_BEARING
    lo = int(math.floor((beta - alpha) / BEAM_SPACING)) - 2
    hi = int(math.ceil((beta + alpha) / BEAM_SPACING)) + 3
    return max(lo, 0), min(hi, nb)


def compiled() -> Any:
    """`scan_points` compiled with numba (`rtsim.world.jit.build`: once per
    process, cached on disk by its source)."""
    global _COMPILED
    if _COMPILED is None:
        _COMPILED = build(scan_points)
    return _COMPILED


class Rangefinder:
    """The leader's laser: `scan` fills and returns its buffers (reused per scan).

    ``range_sd``: the range noise's standard deviation (cm); ``max_range`` (cm);
    ``fast``: run the compiled `scan_points` (else the Python one)."""

    def __init__(
        self, r_F: float, max_range: float, range_sd: float, fast: bool, n: int = 16
    ) -> None:
        self.r_F = float(r_F)
        self.max_range = float(max_range)
        self.range_sd = float(range_sd)
        self.px = np.empty(LASER_POINTS)
        self.py = np.empty(LASER_POINTS)
        self.owner = np.empty(LASER_POINTS, dtype=np.int64)
        self.counts = np.zeros(n, dtype=np.int64)
        # compiled at the first `scan` in ``fast`` (the compiled world scans in its own
        # kernel, `rtsim.world.scanstep`), then called directly (`rtsim.world.kernels.entry`):
        # the same types at every scan
        self._fn: Any = None if fast else scan_points

    def _compiled(self) -> Any:
        """`scan_points` compiled (or loaded) for this rangefinder's buffers' types."""
        none = np.zeros(0)
        z = np.zeros(LASER_POINTS)
        args: tuple[Any, ...] = (none, none, self.r_F, self.max_range, self.range_sd, z)
        args += (BEAM_COS, BEAM_SIN, self.px, self.py, self.owner, self.counts)
        return built_entry(compiled(), args)

    def scan(
        self, xs: NDArray[np.float64], ys: NDArray[np.float64], z: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
        """The scan of followers centred at (``xs``, ``ys``) (leader frame, cm) with the
        standard normals ``z`` (361): (px, py, owner), the buffers, valid until the next
        scan; `counts` holds the beams each follower returned."""
        if self.counts.shape[0] < xs.shape[0]:
            self.counts = np.zeros(xs.shape[0], dtype=np.int64)
        if self._fn is None:
            self._fn = self._compiled()
        self._fn(
            xs,
            ys,
            self.r_F,
            self.max_range,
            self.range_sd,
            z,
            BEAM_COS,
            BEAM_SIN,
            self.px,
            self.py,
            self.owner,
            self.counts,
        )
        return self.px, self.py, self.owner
