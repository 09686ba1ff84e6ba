"""The leader: a unicycle driving its closed path at an adjustable speed (SPEC §5, §6).

The leader's state is its arc length ``s`` along the path and its actual speed V_L; its pose
is the path's exact pose at ``s``, so advancing is exact whatever the step. The actual speed
may be lowered below the desired speed V_Ld (the adjustment algorithm does so) and raised
back to it; it changes instantly (the paper's leader has no acceleration limit).
"""

from __future__ import annotations

from typing import Literal

from rtsim.errors import InputError
from rtsim.world._check import positive
from rtsim.world.path import LeaderPath

__all__ = ["Leader"]


class Leader:
    """Leader on ``path`` with desired speed ``desired_speed`` (cm/s), starting at ``s0`` cm."""

    def __init__(self, path: LeaderPath, desired_speed: float, s0: float = 0.0) -> None:
        self.path = path
        self.desired_speed = positive("leader.speed", desired_speed)
        self.speed = self.desired_speed
        self.s = float(s0)

    def set_speed(self, v: float) -> None:
        """Set the actual speed, 0 ≤ v ≤ V_Ld (a tiny rounding excess is clipped)."""
        if not (0.0 <= v <= self.desired_speed * (1 + 1e-9)):
            raise InputError(
                f"leader speed must be in [0, {self.desired_speed:g}] cm/s, got {v!r}"
            )
        self.speed = min(float(v), self.desired_speed)

    def advance(self, dt: float) -> None:
        """Drive ``dt`` seconds at the current speed (exact along the path)."""
        self.s += self.speed * dt

    @property
    def pose(self) -> tuple[float, float, float]:
        """(x, y, heading) in cm, cm, rad."""
        return self.path.pose(self.s)

    @property
    def curvature(self) -> float:
        return self.path.curvature(self.s)

    @property
    def omega(self) -> float:
        """Turn rate ω_L = κ·V_L (rad/s)."""
        return self.path.curvature(self.s) * self.speed

    def segment(self) -> tuple[Literal["straight", "turn"], float]:
        """("straight" | "turn", κ) at the current arc length."""
        return self.path.segment_at(self.s)

    @property
    def laps(self) -> float:
        """Laps driven so far."""
        return self.s / self.path.lap_length
