"""Leader path: segment lookup, curvature, closure, lap length, exact poses."""

from __future__ import annotations

import math

import pytest

from rtsim.errors import ScenarioError
from rtsim.world.path import LeaderPath, Straight, Turn, rounded_rectangle


def test_rounded_rectangle_lap_length_and_lookup() -> None:
    path = rounded_rectangle(600, 400, 200)
    # 2·600 + 2·400 straight + a full circle of radius 200 in four quarters
    assert path.lap_length == pytest.approx(2000 + 2 * math.pi * 200, abs=1e-9)
    assert path.lap_time(25) == pytest.approx(path.lap_length / 25)
    q = math.pi * 200 / 2
    assert path.segment_at(0) == ("straight", 0.0)
    assert path.segment_at(599.9) == ("straight", 0.0)
    kind, kappa = path.segment_at(600 + q / 2)
    assert kind == "turn" and kappa == pytest.approx(1 / 200)
    assert path.segment_at(600 + q + 1)[0] == "straight"
    assert path.curvature(600 + q + 400 + 1) == pytest.approx(1 / 200)
    # wraps around after a lap
    assert path.segment_at(path.lap_length + 10) == ("straight", 0.0)
    assert path.index(600) == 1  # a boundary belongs to the segment it starts


def test_pose_on_quarter_turn_matches_circle() -> None:
    path = rounded_rectangle(600, 400, 200)
    # first turn: starts at (600, 0) heading 0, left, centre (600, 200)
    q = math.pi * 200 / 2
    for frac in (0.0, 0.3, 0.5, 1.0):
        a = frac * math.pi / 2
        x, y, h = path.pose(600 + frac * q)
        assert x == pytest.approx(600 + 200 * math.sin(a), abs=1e-9)
        assert y == pytest.approx(200 - 200 * math.cos(a), abs=1e-9)
        assert h == pytest.approx(a, abs=1e-12)
    # after the turn: heading north at (800, 200)
    x, y, h = path.pose(600 + q + 100)
    assert (x, y, h) == pytest.approx((800, 300, math.pi / 2), abs=1e-9)


def test_right_turn_path_closes_clockwise() -> None:
    path = rounded_rectangle(300, 0, 120, direction="right")
    x, y, _ = path.pose(300 + math.pi * 120 / 4)  # halfway through the first right turn
    assert y < 0
    assert path.curvature(310) == pytest.approx(-1 / 120)
    assert path.pose(path.lap_length - 1e-9)[:2] == pytest.approx((0, 0), abs=1e-6)


def test_pose_is_continuous_at_every_boundary() -> None:
    path = LeaderPath(
        [Straight(100), Turn("left", 50, math.pi), Straight(100), Turn("left", 50, math.pi)]
    )
    s = 0.0
    for seg in path.segments:
        s += seg.length
        a = path.pose(s - 1e-7)
        b = path.pose(s + 1e-7)
        assert math.hypot(a[0] - b[0], a[1] - b[1]) < 1e-5


@pytest.mark.parametrize(
    ("segments", "match"),
    [
        ([Straight(100)], "does not close"),
        (
            [Straight(100), Turn("left", 50, math.pi), Straight(100), Turn("left", 51, math.pi)],
            "does not close",
        ),
        ([Turn("left", 100, math.pi)], "does not close"),
        ([], "no segments"),
    ],
)
def test_open_paths_are_rejected(segments: list, match: str) -> None:
    with pytest.raises(ScenarioError, match=match):
        LeaderPath(segments)


def test_full_circle_and_figure_eight_close() -> None:
    assert LeaderPath([Turn("left", 100, 2 * math.pi)]).lap_length == pytest.approx(200 * math.pi)
    eight = LeaderPath([Turn("left", 100, 2 * math.pi), Turn("right", 100, 2 * math.pi)])
    assert eight.curvature(10) > 0 > eight.curvature(200 * math.pi + 10)


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: Straight(-5), "straight: must be positive"),
        (lambda: Straight(0), "straight: must be positive"),
        (lambda: Turn("left", -200, 1.0), "radius: must be positive"),
        (lambda: Turn("left", 200, 0), "angle: must be positive"),
        (lambda: Turn("up", 200, 1.0), "turn: must be .left. or .right."),
        (lambda: rounded_rectangle(-1, 0, 100), "length: must be non-negative"),
    ],
)
def test_bad_segments(make, match: str) -> None:
    with pytest.raises(ScenarioError, match=match):
        make()
