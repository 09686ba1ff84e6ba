"""Follow-the-leader without error: where each follower would be, over one lap, if it sat
exactly on its reference (docs/followers.md, docs/model/world.md).

The follow-the-leader law (`rtsim.world.ftl`) gives every follower a reference: the
first point P_k(σ) of its offset trace behind the point it follows (the leader, or the
reference of the follower ahead of it) at its spacing, moving at the speed (FTL-1). Played
over a lap of the leader's arc length s on a grid of ``step`` cm, this gives, exactly from
the path and the law (no noise, no windows, no control error):

* each follower's place (x, y) and so the least distance between any two robots, the
  geometry a formation must fit before it runs (`check_clearance`);
* each follower's speed per unit of leader speed g_k(s) = V_F/V_L (FTL-1 chained) and its
  bearing β_k(s) in the leader's frame, from which the fastest lap that keeps the bounds
  follows (`rtsim.control.oracle`).

Everything is cached per (path, formation, start, step): a run pays for it once per process.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from rtsim.errors import ScenarioError
from rtsim.world.formation import CLEARANCE_MARGIN, Formation, follower_model
from rtsim.world.ftl import TraceFollower
from rtsim.world.path import LeaderPath

__all__ = [
    "IDEAL_STEP",
    "START_ON",
    "IdealLap",
    "check_clearance",
    "ideal_lap",
    "settled_start",
    "tightest_radius",
]

#: Grid step (cm) of the leader's arc length in `ideal_lap`.
IDEAL_STEP = 2.0

#: Tolerance (cm) of `check_clearance` on the sampled lap (the samples' interpolation
#: is exact on straights, within about 0.01 cm in turns).
IDEAL_TOL = 0.05

Array = NDArray[np.float64]


@dataclass(frozen=True)
class IdealLap:
    """One lap of error-free follow-the-leader (module docstring).

    ``s``: the leader's arc length (N,); ``leader``: its (x, y, heading) (N, 3);
    ``xy``: the followers' places (n, N, 2); ``ratio``: g_k = V_F/V_L (n, N); ``bearing``:
    β_k in the leader's frame, unwrapped (n, N); ``curvature``: the leader's κ(s) (N,)."""

    s: Array
    leader: Array
    xy: Array
    ratio: Array
    bearing: Array
    curvature: Array

    def closest(self) -> tuple[float, int, int, int]:
        """(least centre distance, index i, robots a < b) over the lap; robot 0 is the leader,
        follower k is robot k."""
        pts = np.concatenate((self.leader[None, :, :2], self.xy), axis=0)
        best = (math.inf, 0, 0, 0)
        for a in range(pts.shape[0]):
            for b in range(a + 1, pts.shape[0]):
                d = np.hypot(*(pts[a] - pts[b]).T)
                i = int(np.argmin(d))
                if d[i] < best[0]:
                    best = (float(d[i]), i, a, b)
        return best


def _poses(path: LeaderPath, s: Array) -> Array:
    return np.array([path.pose(float(u)) for u in s], dtype=float).reshape(len(s), 3)


def _offset(poses: Array, o: float) -> Array:
    return np.column_stack(
        (poses[:, 0] - o * np.sin(poses[:, 2]), poses[:, 1] + o * np.cos(poses[:, 2]))
    )


def _references(
    trace: Array, tangent: Array, target: Array, spacing: float, j0: int
) -> tuple[Array, Array]:
    """For each target point, the first point of ``trace`` behind it at distance ``spacing``
    (linear interpolation between samples): (points (N, 2), unit tangents (N, 2)). ``j0``:
    the trace index at or ahead of the first target (the search goes back from there)."""
    tx, ty = trace[:, 0].tolist(), trace[:, 1].tolist()
    hyp = math.hypot
    last = len(tx) - 2
    j = min(j0, last)
    x0, y0 = float(target[0, 0]), float(target[0, 1])
    while j > 0 and hyp(tx[j] - x0, ty[j] - y0) < spacing:
        j -= 1
    idx: list[int] = []
    frac: list[float] = []
    for x, y in target.tolist():
        # the crossing moves forward with the target: j is the last sample at or beyond
        # the spacing with the next one inside it
        while j < last and hyp(tx[j + 1] - x, ty[j + 1] - y) >= spacing:
            j += 1
        while j > 0 and hyp(tx[j] - x, ty[j] - y) < spacing:
            j -= 1
        d0, d1 = hyp(tx[j] - x, ty[j] - y), hyp(tx[j + 1] - x, ty[j + 1] - y)
        idx.append(j)
        frac.append(0.0 if d0 == d1 else min(1.0, max(0.0, (d0 - spacing) / (d0 - d1))))
    k = np.asarray(idx)
    f = np.asarray(frac)[:, None]
    pts = trace[k] + f * (trace[k + 1] - trace[k])
    tan = tangent[k] + f * (tangent[k + 1] - tangent[k])
    tan /= np.hypot(tan[:, 0], tan[:, 1])[:, None]
    return pts, tan


@lru_cache(maxsize=64)
def _ideal(
    segments: tuple[object, ...],
    start: tuple[float, float, float],
    rho_d: tuple[float, ...],
    lateral: tuple[float, ...],
    start_s: float,
    step: float,
) -> IdealLap:
    path = LeaderPath(segments, start)  # type: ignore[arg-type]
    law = TraceFollower(path, rho_d, lateral, 0.0, 1.0)  # whom each follows, at what spacing
    lap = path.lap_length
    n_s = max(2, int(math.ceil(lap / step)) + 1)
    s = start_s + np.linspace(0.0, lap, n_s)
    leader = _poses(path, s)
    back = min(lap, 2.0 * max(law.spacing) + 2.0 * max(abs(o) for o in lateral) + 200.0)
    sig = np.arange(start_s - back, start_s + lap + step, step / 2.0)
    tr_poses = _poses(path, sig)
    tangent = np.column_stack((np.cos(tr_poses[:, 2]), np.sin(tr_poses[:, 2])))
    j0 = int(np.searchsorted(sig, start_s))
    n = len(rho_d)
    xy = np.empty((n, n_s, 2))
    tans = np.empty((n, n_s, 2))
    ratio = np.empty((n, n_s))
    lt = np.column_stack((np.cos(leader[:, 2]), np.sin(leader[:, 2])))
    for k in range(n):
        j = law.ahead[k]
        tgt, tgt_t, tgt_g = (
            (leader[:, :2], lt, np.ones(n_s)) if j < 0 else (xy[j], tans[j], ratio[j])
        )
        trace = _offset(tr_poses, lateral[k])
        pts, tan = _references(trace, tangent, tgt, law.spacing[k], j0)
        xy[k], tans[k] = pts, tan
        dx, dy = tgt[:, 0] - pts[:, 0], tgt[:, 1] - pts[:, 1]
        num = dx * tgt_t[:, 0] + dy * tgt_t[:, 1]
        den = dx * tan[:, 0] + dy * tan[:, 1]
        # (FTL-1); the law's own fallback where the tangent is nearly across the line
        ok = den > 0.1 * np.hypot(dx, dy)
        ratio[k] = tgt_g * np.where(ok, num / np.where(ok, den, 1.0), 1.0)
    rel = xy - leader[None, :, :2]
    bearing = np.unwrap(np.arctan2(rel[..., 1], rel[..., 0]) - leader[None, :, 2], axis=1)
    kappa = np.array([path.curvature(float(u)) for u in s])
    for arr in (s, leader, xy, ratio, bearing, kappa):
        arr.setflags(write=False)
    return IdealLap(s, leader, xy, ratio, bearing, kappa)


def ideal_lap(
    path: LeaderPath, formation: Formation, start_s: float = 0.0, step: float = IDEAL_STEP
) -> IdealLap:
    """One lap of error-free follow-the-leader from the leader at ``start_s`` (module
    docstring; cached). Only for follow-the-leader formations (on-trace followers)."""
    if not follower_model(formation.model).on_trace:
        raise ValueError(f"ideal_lap: {formation.model!r} followers do not track the trace")
    return _ideal(
        tuple(path.segments),
        tuple(path.start),
        tuple(formation.rho_d),
        tuple(formation.lateral),
        float(start_s),
        float(step),
    )


def tightest_radius(path: LeaderPath) -> float:
    """The radius (cm) of the path's tightest turn (inf for a path without turns)."""
    kappas = [abs(g.curvature) for g in path.segments]
    return 1.0 / max(kappas) if max(kappas) > 0 else math.inf


def check_clearance(
    path: LeaderPath, formation: Formation, r_F: float, start_s: float = 0.0
) -> float:
    """Refuse a follow-the-leader formation that cannot keep ``formation.clearance`` plus
    `CLEARANCE_MARGIN` (cm) between any two robots' discs
    (radius ``r_F``) over a lap without error, or whose
    offset trace folds inside a turn (a lateral offset on the turn's inner side at least its
    radius): `ScenarioError` in one line naming the follower count, the tightest turn's
    radius and the clearance. Returns the least centre distance (cm) over the lap."""
    n, c = formation.n, formation.clearance
    radius = tightest_radius(path)
    head = (
        f"formation.followers: {n} followers do not fit this path (tightest turn radius "
        f"{radius:g} cm) with clearance {c:g} cm"
    )
    need = 2.0 * r_F + c + CLEARANCE_MARGIN
    for k, o in enumerate(formation.lateral):
        for g in path.segments:
            if g.curvature * o >= 1.0 - r_F * abs(g.curvature):
                raise ScenarioError(
                    f"{head}: follower {k + 1} is {abs(o):.4g} cm off the trace on the inner "
                    f"side of a turn of radius {1.0 / abs(g.curvature):g} cm; use fewer "
                    f"followers or a smaller clearance"
                )
    d, i, a, b = ideal_lap(path, formation, start_s).closest()
    if d < need - IDEAL_TOL:
        who = f"the leader and follower {b}" if a == 0 else f"followers {a} and {b}"
        raise ScenarioError(
            f"{head}: {who} would come {d:.4g} cm apart (centres; need 2*r_F + clearance + "
            f"margin = {need:g} cm); use fewer followers, a larger separation or a smaller "
            f"clearance"
        )
    return d


#: ``[leader] start_on``: ``straight`` — the leader's start is moved forward from ``start_s``
#: to the first place where the whole group stands settled on one straight
#: (`settled_start`); ``given`` — ``start_s`` as given (before 0.x: the group could
#: start in the middle of a turn).
START_ON: tuple[str, ...] = ("straight", "given")


def settled_start(path: LeaderPath, formation: Formation, r_F: float, start_s: float) -> float:
    """The first leader arc length s ≥ ``start_s`` (cm) at which the leader and every
    follower's place on straights (its along-track depth behind the leader, ρ_d·|cos β_d|,
    plus one disc radius) lie on one straight segment: the group starts settled, its
    followers where the law holds them on straights. When no straight of the path is long
    enough, the end of its longest straight (``start_s`` on a path without one)."""
    depth = max(
        abs(r * math.cos(b)) for r, b in zip(formation.rho_d, formation.beta_d, strict=True)
    )
    need = depth + r_F
    lap = path.lap_length
    s0 = 0.0
    firsts = []
    for g in path.segments:
        firsts.append((s0, g))
        s0 += g.length
    u = start_s % lap
    base = start_s - u
    for wrap in (0.0, lap):
        for a, g in firsts:
            if g.kind != "straight" or g.length < need:
                continue
            lo = base + wrap + a + need  # the earliest settled place on this straight
            hi = base + wrap + a + g.length
            if hi < start_s:
                continue
            s = max(lo, start_s)
            return s - lap if s >= lap else s
    # no straight holds the whole group: the end of the longest one (the most settled place
    # this path has), or the start as given on a path without straights
    ends = [(g.length, a + g.length) for a, g in firsts if g.kind == "straight"]
    if not ends:
        return start_s
    s = base + max(ends, key=lambda e: (e[0], -e[1]))[1]  # the first of the longest
    s = s + lap if s < start_s else s
    return s - lap if s >= lap else s
