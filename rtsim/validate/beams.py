"""Beams counted per processing window, from a world run on Test 1 stepped at a fixed window w:
the counted points of each scan give the localization segment's time by Eq 1, which the
validation replays by window index; lost tracks and scans beyond Eq 1's count are recorded.
The method: docs/validation.md.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rtsim.analysis.window import LASER_POINTS
from rtsim.config.load import with_overrides
from rtsim.config.scenario import parse_scenario
from rtsim.model.window import WindowSpec
from rtsim.world import World, WorldConfig, rounded_rectangle
from rtsim.world.formation import in_line

__all__ = ["Test1", "BeamCounts", "count_window_beams", "scenario_world", "world_config"]


@dataclass(frozen=True)
class Test1:
    """The world of the paper's Test 1 (lengths cm, speed cm/s, angle rad)."""

    speed: float = 25.0
    turn_radius: float = 200.0
    separation: float = 390.0
    length: float = 800.0
    width: float = 400.0
    bearing_offset: float = math.radians(15.0)

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def scenario_world(
    text: str, source: str, n: int, r_H: float, overrides: dict[str, Any] | None = None
) -> Any:
    """The world of a scenario file's text (changed by ``overrides``, dotted paths) with n
    followers and Hough radius r_H."""
    import tomllib

    data = with_overrides(tomllib.loads(text), overrides, source)
    data.setdefault("formation", {})["followers"] = int(n)
    data.setdefault("sensing", {})["r_H"] = float(r_H)
    return parse_scenario(data, source).world


def world_config(n: int, test: Test1 | None = None) -> Any:
    """The [`WorldConfig`][rtsim.world.WorldConfig] of Test 1 with n follow-the-leader followers in
    the default line (`in_line`)."""
    t = Test1() if test is None else test
    path = rounded_rectangle(t.length, t.width, t.turn_radius)
    return WorldConfig(path, t.speed, in_line(n, t.separation, t.bearing_offset))


@dataclass(frozen=True)
class BeamCounts:
    """Per-window scan results of a world run at fixed window ``w``.

    ``points``: (windows, n) beams returned by each follower; ``lost``: tracks lost per window;
    ``lost_sensor``: those of them whose follower returned fewer than ``min_points`` beams
    (the sensor's limit, module doc).
    """

    w: float
    points: NDArray[np.int64]
    lost: NDArray[np.int64]
    lost_sensor: NDArray[np.int64] | None = None

    @property
    def lost_moved(self) -> int:
        """Lost tracks whose follower returned enough beams (it moved more than r_H)."""
        hidden = 0 if self.lost_sensor is None else int(self.lost_sensor.sum())
        return int(self.lost.sum()) - hidden

    @property
    def windows(self) -> int:
        return int(self.points.shape[0])

    @property
    def total(self) -> NDArray[np.int64]:
        """Points per window, all followers."""
        return self.points.sum(axis=1)

    def hough_times(self, window: WindowSpec) -> NDArray[np.float64]:
        """e_hough per window by Eq 1 with the counted points (ms)."""
        return np.array([window.e_hough(points=float(p)) for p in self.total])

    def beyond_wcet(self, window: WindowSpec) -> int:
        """Windows whose counted points exceed Eq 1's min(361, k·n)."""
        limit = min(LASER_POINTS, window.k * window.n)
        return int((self.total > limit + 1e-9).sum())


def count_window_beams(
    window: WindowSpec, w: float, windows: int, rng: np.random.Generator, config: Any = None
) -> BeamCounts:
    """Run the world ``config`` (default: `world_config` of `Test1`, n from
    ``window``) for ``windows`` windows of fixed length ``w`` (module doc)."""
    n = window.n
    cfg = world_config(n) if config is None else config
    if cfg.n != n:
        raise ValueError(f"world has {cfg.n} followers, the window {n}")
    world = World(cfg, rng)
    step = window.e_estimate + window.e_send
    send0 = window.e_scan + window.e_hough()
    pts = np.zeros((windows, n), dtype=np.int64)
    lost = np.zeros(windows, dtype=np.int64)
    hidden = np.zeros(windows, dtype=np.int64)
    min_points = cfg.sensing.min_points
    for j in range(windows):
        t = j * w
        scan = world.scan(t)
        world.estimate(scan)
        for i in range(1, n + 1):
            world.command(i, t + send0 + i * step)
        pts[j] = scan.points
        lost[j] = scan.n_lost
        hidden[j] = int((scan.lost & (scan.points < min_points)).sum())
    return BeamCounts(w, pts, lost, hidden)
