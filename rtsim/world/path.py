"""The leader's closed path, built from the paper's remote-control commands (docs/model/world.md).

The remote-control station commands "move in a straight line, turn, turn direction, turn
radius and desired speed" (the paper's §4). A path is a closed sequence of
[`Straight`][rtsim.world.path.Straight] and [`Turn`][rtsim.world.path.Turn] segments from a start
pose; the speed lives with the
leader (`rtsim.world.leader`). Everything is a function of the arc length ``s`` (cm),
so the leader's pose is exact whatever the time step: on a turn of signed curvature κ
(+1/r left, −1/r right) starting at (x0, y0, h0),

    h(s) = h0 + κ s,  x(s) = x0 + (sin h − sin h0)/κ,  y(s) = y0 − (cos h − cos h0)/κ.

Lengths in cm, angles in rad; ``s`` beyond one lap wraps around.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from rtsim.errors import ScenarioError
from rtsim.world._check import number, positive
from rtsim.world.jit import kernel

__all__ = [
    "Straight",
    "Turn",
    "Segment",
    "LeaderPath",
    "rounded_rectangle",
    "geometry_arrays",
    "CLOSURE_TOL",
]

#: Largest gap (cm) between a closed path's end and its start.
CLOSURE_TOL = 1e-6
_HEADING_TOL = 1e-9


@dataclass(frozen=True)
class Straight:
    """Drive straight for ``length`` cm."""

    length: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "length", positive("straight", self.length))

    @property
    def kind(self) -> Literal["straight"]:
        return "straight"

    @property
    def curvature(self) -> float:
        return 0.0


@dataclass(frozen=True)
class Turn:
    """Turn ``direction`` ("left": counter-clockwise) on a ``radius`` cm circle by ``angle`` rad."""

    direction: Literal["left", "right"]
    radius: float
    angle: float

    def __post_init__(self) -> None:
        if self.direction not in ("left", "right"):
            raise ScenarioError(f"turn: must be 'left' or 'right', got {self.direction!r}")
        object.__setattr__(self, "radius", positive("radius", self.radius))
        angle = number("angle", self.angle)
        if angle <= 0:
            raise ScenarioError(f"angle: must be positive, got {self.angle!r}")
        object.__setattr__(self, "angle", angle)

    @property
    def kind(self) -> Literal["turn"]:
        return "turn"

    @property
    def length(self) -> float:
        return self.radius * self.angle

    @property
    def curvature(self) -> float:
        """Signed curvature κ (1/cm): +1/r for a left turn, −1/r for a right turn."""
        return (1.0 if self.direction == "left" else -1.0) / self.radius


Segment = Straight | Turn


#: a pose and its heading's cosine and sine: (x, y, h, cos h, sin h)
Frame = tuple[float, float, float, float, float]


@kernel
def along(x0: float, y0: float, h0: float, c0: float, s0: float, kappa: float, s: float) -> Frame:
    """The frame after arc length ``s`` along curvature ``kappa`` from the frame (x0, y0, h0,
    c0 = cos h0, s0 = sin h0) (exact; the compiled kernels call it too): a segment's start
    frame is computed once, with its path, and on a straight the heading's cosine and sine
    are its start's, the doubles ``math.cos``/``math.sin`` give there."""
    if kappa == 0.0:
        return (x0 + s * c0, y0 + s * s0, h0, c0, s0)
    h = h0 + kappa * s
    c, sn = math.cos(h), math.sin(h)
    return (x0 + (sn - s0) / kappa, y0 - (c - c0) / kappa, h, c, sn)


class LeaderPath:
    """A closed path of segments from a start pose (x, y, heading); immutable after construction.

    Raises `ScenarioError` if the path is empty or does not close: the end must be
    within `CLOSURE_TOL` cm of the start and the total turning a multiple of 2π.
    """

    def __init__(
        self,
        segments: tuple[Segment, ...] | list[Segment],
        start: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> None:
        segs = tuple(segments)
        if not segs:
            raise ScenarioError("path has no segments")
        for k, seg in enumerate(segs):
            if not isinstance(seg, Straight | Turn):
                raise ScenarioError(f"path[{k}] is not a Straight or Turn: {seg!r}")
        x0 = number("start.x", start[0])
        y0 = number("start.y", start[1])
        h0 = number("start.heading", start[2])
        self._segments = segs
        self._start = (x0, y0, h0)
        # memo of the last index / pose asked for (pure functions of s)
        self._memo_s: float = math.nan
        self._memo_k = 0
        self._memo_pose_s: float = math.nan
        self._memo_pose: tuple[float, float, float] = (math.nan, math.nan, math.nan)
        self._kappa = tuple(seg.curvature for seg in segs)
        # each segment's start frame (`along`): its pose and its heading's cosine and sine
        poses: list[Frame] = [(x0, y0, h0, math.cos(h0), math.sin(h0))]
        s0 = [0.0]
        for seg, kappa in zip(segs, self._kappa, strict=True):
            poses.append(along(*poses[-1], kappa, seg.length))
            s0.append(s0[-1] + seg.length)
        self._poses = tuple(poses[:-1])
        self._s0 = tuple(s0[:-1])
        self._lap = s0[-1]
        xe, ye, he, _, _ = poses[-1]
        gap = math.hypot(xe - x0, ye - y0)
        turns = (he - h0) / (2 * math.pi)
        if gap > CLOSURE_TOL or abs(turns - round(turns)) * 2 * math.pi > _HEADING_TOL:
            raise ScenarioError(
                f"path does not close: it ends at ({xe:.6g}, {ye:.6g}) heading "
                f"{math.degrees(he):.6g} deg, {gap:.3g} cm from its start"
            )

    # -- structure -------------------------------------------------------------------
    @property
    def segments(self) -> tuple[Segment, ...]:
        return self._segments

    @property
    def start(self) -> tuple[float, float, float]:
        """Start pose (x cm, y cm, heading rad)."""
        return self._start

    @property
    def lap_length(self) -> float:
        """Arc length of one lap (cm)."""
        return self._lap

    def lap_time(self, speed: float) -> float:
        """Seconds for one lap at ``speed`` cm/s."""
        return self._lap / speed

    def index(self, s: float) -> int:
        """Index of the segment at arc length ``s`` (boundaries go to the next segment)."""
        if s == self._memo_s and s.__class__ is float:  # the leader asks about one s often
            return self._memo_k
        u = s % self._lap
        k = bisect.bisect_right(self._s0, u) - 1
        self._memo_s, self._memo_k = s, k
        return k

    # -- geometry at arc length s ----------------------------------------------------
    def segment_at(self, s: float) -> tuple[Literal["straight", "turn"], float]:
        """("straight" | "turn", signed curvature κ in 1/cm) at arc length ``s``."""
        k = self.index(s)
        return self._segments[k].kind, self._kappa[k]

    def curvature(self, s: float) -> float:
        """Signed curvature κ (1/cm) at arc length ``s``; the leader turns at ω_L = κ·V_L."""
        return self._kappa[self.index(s)]

    def pose(self, s: float) -> tuple[float, float, float]:
        """Exact pose (x, y, heading) at arc length ``s``; heading is unwrapped within a lap."""
        if s == self._memo_pose_s and s.__class__ is float:
            return self._memo_pose
        u = s % self._lap
        k = bisect.bisect_right(self._s0, u) - 1
        x, y, h, _, _ = along(*self._poses[k], self._kappa[k], u - self._s0[k])
        pose = (x, y, h)
        self._memo_pose_s, self._memo_pose = s, pose
        return pose

    def remember(self, s: float, pose: tuple[float, float, float]) -> None:
        """Take ``pose`` as `pose` (``s``) from now on (`pose`'s memo): the pose at ``s`` a
        compiled kernel computed (`rtsim.world.ftl.path_pose` on `arrays`, bit for bit)."""
        self._memo_pose_s, self._memo_pose = s, pose

    def geometry(self) -> tuple[Any, ...]:
        """The path as the kernels read it (`rtsim.world.ftl.path_pose`), Python tuples: the
        segments' starts (cm); per segment its start frame (x, y, heading, the heading's cosine
        and sine: `along`) and its curvature, six a segment, flat; the lap length (the head
        of the follow-the-leader law's geometry, `rtsim.world.ftl.TraceFollower.geometry`;
        made once per path: its segments are fixed)."""
        got = self.__dict__.get("_geometry")
        if got is None:
            frames = zip(self._poses, self._kappa, strict=True)
            got = (self._s0, tuple(c for f, kappa in frames for c in (*f, kappa)), self._lap)
            self._geometry = got
        return got  # type: ignore[no-any-return]

    def arrays(self) -> tuple[Any, ...]:
        """`geometry` as the kernels' arrays, in the shape of the law's (`geometry_arrays`:
        compiled kernels share one build of `rtsim.world.ftl.path_pose`)."""
        return geometry_arrays(self.geometry())

    def __repr__(self) -> str:
        return f"LeaderPath({len(self._segments)} segments, lap {self._lap:.6g} cm)"


def rounded_rectangle(
    length: float,
    width: float,
    radius: float,
    *,
    direction: Literal["left", "right"] = "left",
    start: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> LeaderPath:
    """Four straights and four 90° turns: straights of ``length`` and ``width`` cm (a straight
    of 0 is left out, so ``width=0`` gives a stadium), turns of ``radius`` cm.

    Driven counter-clockwise for ``direction="left"``. The default path shape of
    docs/model/world.md.
    """
    length = number("length", length)
    width = number("width", width)
    for key, val in (("length", length), ("width", width)):
        if val < 0:
            raise ScenarioError(f"{key}: must be non-negative, got {val!r}")
    turn = Turn(direction, radius, math.pi / 2)
    segs: list[Segment] = []
    for side in (length, width, length, width):
        if side > 0:
            segs.append(Straight(side))
        segs.append(turn)
    return LeaderPath(segs, start)


def geometry_arrays(G: tuple[Any, ...]) -> tuple[Any, ...]:
    """A geometry (`LeaderPath.geometry`, then per follower its lateral offset, the follower
    it keeps its spacing from and that spacing, three a follower, flat, as
    `rtsim.world.ftl.TraceFollower.geometry`) as the kernels read it: float arrays and the
    lap a float (three arrays: each is unboxed at a call from Python and reference-counted
    at a call between kernels); a path alone gets one placeholder follower (no offset, none
    ahead, spacing 1)."""
    s0, seg, lap, *followers = G
    (fol,) = followers or ((0.0, -1.0, 1.0),)
    s0, seg, fol = (np.array(a, dtype=float) for a in (s0, seg, fol))
    return (s0, seg, float(lap), fol)
