"""The leader: a unicycle driving its closed path at an adjustable speed (docs/model/adjustment.md,
docs/model/world.md).

The leader's state is its arc length ``s`` along the path, its actual speed V_L and the
target speed it is driving toward; its pose is the path's exact pose at ``s``, so advancing
is exact whatever the step. The adjustment algorithm sets the **target** (at most the
desired speed V_Ld); the actual speed ramps toward it at ``accel_max`` cm/s² when speeding
up and ``decel_max`` cm/s² when slowing down, as a real robot's speed controller does
(docs/model/world.md). With both limits infinite (the default of a
[`Leader`][rtsim.world.leader.Leader] built by hand)
the speed steps at once, the paper's idealisation. Over a step of dt seconds the arc length is
the exact integral of that ramp-then-hold profile (`rtsim.world.motion.leader_travel`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Literal

from rtsim.errors import InputError
from rtsim.world._check import positive
from rtsim.world.motion import leader_travel
from rtsim.world.path import LeaderPath

__all__ = ["Leader"]


class Leader:
    """Leader on ``path`` with desired speed ``desired_speed`` (cm/s), starting at ``s0`` cm,
    its speed ramping toward the target at most ``accel_max`` / ``decel_max`` cm/s² (by
    ``travel``: a motion model's leader part, `rtsim.world.motionmodels`)."""

    def __init__(
        self,
        path: LeaderPath,
        desired_speed: float,
        s0: float = 0.0,
        *,
        accel_max: float = math.inf,
        decel_max: float = math.inf,
        travel: Callable[..., tuple[float, float]] = leader_travel,
    ) -> None:
        self.path = path
        self._travel = travel
        self.desired_speed = positive("leader.speed", desired_speed)
        self.accel_max = positive("leader.accel_max", accel_max, allow_inf=True)
        self.decel_max = positive("leader.decel_max", decel_max, allow_inf=True)
        self.speed = self.desired_speed
        self.target_speed = self.desired_speed
        self.s = float(s0)

    def set_speed(self, v: float) -> None:
        """Set the target speed, 0 ≤ v ≤ V_Ld (a tiny rounding excess is clipped); the actual
        speed ramps toward it (at once when the limit in that direction is infinite)."""
        if not (0.0 <= v <= self.desired_speed * (1 + 1e-9)):
            raise InputError(f"leader speed must be in [0, {self.desired_speed:g}] cm/s, got {v!r}")
        self.target_speed = min(float(v), self.desired_speed)
        a = self.accel_max if self.target_speed > self.speed else self.decel_max
        if a == math.inf:
            self.speed = self.target_speed

    def advance(self, dt: float) -> None:
        """Drive ``dt`` seconds, the speed ramping toward the target (exact along the path)."""
        self.speed, ds = self._travel(
            self.speed, self.target_speed, self.accel_max, self.decel_max, dt
        )
        self.s += ds

    def speed_after(self, dt: float) -> float:
        """The actual speed ``dt`` seconds from now if the target does not change."""
        return self._travel(self.speed, self.target_speed, self.accel_max, self.decel_max, dt)[0]

    @property
    def pose(self) -> tuple[float, float, float]:
        """(x, y, heading) in cm, cm, rad."""
        return self.path.pose(self.s)

    @property
    def curvature(self) -> float:
        return self.path.curvature(self.s)

    @property
    def omega(self) -> float:
        """Turn rate ω_L = κ·V_L (rad/s), at the actual speed."""
        return self.path.curvature(self.s) * self.speed

    def segment(self) -> tuple[Literal["straight", "turn"], float]:
        """("straight" | "turn", κ) at the current arc length."""
        return self.path.segment_at(self.s)

    @property
    def laps(self) -> float:
        """Laps driven so far."""
        return self.s / self.path.lap_length
