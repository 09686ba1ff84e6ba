"""Which followers the laser can see along a path: the occlusion share of a formation.

A formation is drawn on the leader's path with every follower exactly on its place — its
slot in the leader's frame for l-ψ, its follow-the-leader reference on the leader's trace
(`TraceFollower`) otherwise — at leader arc lengths ``step`` cm
apart (about one processing window of travel). At each sample the laser's beams are counted
with shadowing (`count_beams_xy`); a follower is

- **occluded** when it returns fewer than ``min_points`` beams although, alone, some beam
  would reach it (a nearer follower hides it, or its disc covers too few beams);
- **out of range** when, alone, no beam reaches it (beyond the laser's range, or outside its
  180° backward field: beside or ahead of the leader, as far followers are after a U-turn).

Each share is the fraction of samples in which that happened: the world's own losses by
those causes (``tracks_lost_by_cause``) with the controllers' errors and noise taken out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rtsim.world.formation import Formation, follower_model
from rtsim.world.ftl import TraceFollower
from rtsim.world.laser import count_beams_xy
from rtsim.world.path import LeaderPath

__all__ = ["OcclusionShare", "occlusion_share"]


@dataclass(frozen=True)
class OcclusionShare:
    """Per follower (index i − 1): the share of samples in which it was occluded and out of
    range, and the number of samples."""

    occluded: tuple[float, ...]
    out_of_range: tuple[float, ...]
    samples: int

    @property
    def worst(self) -> float:
        """The largest share of samples in which any one follower could not be seen."""
        return max(a + b for a, b in zip(self.occluded, self.out_of_range, strict=True))


def occlusion_share(
    path: LeaderPath,
    formation: Formation,
    r_F: float,
    *,
    step: float = 6.0,
    start_s: float = 0.0,
    length: float | None = None,
    min_points: int = 3,
    max_range: float = math.inf,
) -> OcclusionShare:
    """The occlusion share of ``formation`` over ``length`` cm of ``path`` (default one lap)
    from the leader's arc length ``start_s``, sampled every ``step`` cm (module docstring)."""
    if not step > 0:
        raise ValueError(f"step must be positive, got {step!r}")
    length = path.lap_length if length is None else float(length)
    n = formation.n
    ftl = None
    if follower_model(formation.model).on_trace:
        ftl = TraceFollower(path, formation.rho_d, formation.lateral, 0.0, 1.0)
    slots = formation.xy().tolist()
    m = max(1, int(math.floor(length / step)) + 1)
    occ = [0] * n
    out = [0] * n
    for j in range(m):
        s = start_s + j * step
        lp = path.pose(s)
        if ftl is None:
            rel = [(float(a), float(b)) for a, b in slots]
        else:
            xl, yl, hl = lp
            c, sn = math.cos(hl), math.sin(hl)
            rel = []
            for k in range(n):
                s_ref, _ = ftl.reference(k, s, lp, 1.0)
                x, y, _ = ftl.point(k, s_ref)
                rel.append((c * (x - xl) + sn * (y - yl), -sn * (x - xl) + c * (y - yl)))
        pts = count_beams_xy(rel, r_F, max_range)
        for k in range(n):
            if pts[k] >= min_points:
                continue
            if count_beams_xy([rel[k]], r_F, max_range)[0] > 0:
                occ[k] += 1
            else:
                out[k] += 1
    return OcclusionShare(tuple(c / m for c in occ), tuple(c / m for c in out), m)
