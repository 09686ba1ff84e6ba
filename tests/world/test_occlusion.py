"""The occlusion share of a formation along a path, against hand-computed geometry."""

from __future__ import annotations

import math

import pytest

from rtsim.world import rounded_rectangle as rr
from rtsim.world.formation import Formation, in_line
from rtsim.world.occlusion import occlusion_share
from rtsim.world.path import LeaderPath, Turn


def test_share_is_zero_on_a_straight() -> None:
    path = rr(20000, 400, 200)
    for n in (2, 6):
        share = occlusion_share(path, in_line(n, 390), 25.0, start_s=3000.0, length=10000.0)
        assert share.samples == 1667
        assert share.occluded == (0.0,) * n and share.out_of_range == (0.0,) * n


def _circle_formation() -> Formation:
    # followers 1 and 3 on the trace (lateral 0), 3 following 1 at 150 cm; 2 on the right
    return Formation((150.0, 200.0, 300.0), (math.pi, math.pi + 0.8, math.pi), "follow-the-leader")


@pytest.mark.parametrize("radius, hidden", [(1000.0, True), (150.0, False)])
def test_share_matches_a_constructed_turn(radius: float, hidden: bool) -> None:
    """On a circle of radius R the followers on the trace keep their place in the leader's
    frame: follower 1 at chord 150 cm sits α/2 = asin(75/R) off straight back, follower 3
    (150 cm further along the circle) at α, ρ_3 = 2R·sin α. Follower 3 is hidden when its
    disc's bearings [α − asin(25/ρ_3), α + asin(25/ρ_3)] lie inside follower 1's
    [α/2 − asin(25/150), α/2 + asin(25/150)]."""
    half_a = math.asin(75.0 / radius)
    rho3 = 2 * radius * math.sin(2 * half_a)
    lo3, hi3 = 2 * half_a - math.asin(25.0 / rho3), 2 * half_a + math.asin(25.0 / rho3)
    lo1, hi1 = half_a - math.asin(25.0 / 150.0), half_a + math.asin(25.0 / 150.0)
    by_hand = lo1 <= lo3 and hi3 <= hi1
    assert by_hand == hidden
    if not hidden:
        assert lo3 > hi1  # wholly clear of follower 1
    path = LeaderPath([Turn("left", radius, 2 * math.pi)])
    share = occlusion_share(path, _circle_formation(), 25.0, step=10.0)
    assert share.occluded[0] == 0.0 and share.out_of_range[0] == 0.0
    assert share.occluded[2] == (1.0 if hidden else 0.0)
    assert share.out_of_range[2] == 0.0


def test_fan_bearings_by_hand() -> None:
    """Ten followers at 390 cm: the pair at 195° and 165°, then steps of 2·asin(25/390) + 1°
    = 8.35° on the right (outer for a counter-clockwise path); all at ρ_d."""
    from rtsim.world.formation import fan, fan_bearings

    step = 2 * math.degrees(math.asin(25 / 390)) + 1.0
    got = [math.degrees(b) for b in fan_bearings(10, 390.0, math.radians(15), 25.0)]
    want = [195.0, 165.0] + [195.0 + k * step for k in range(1, 9)]
    assert got == pytest.approx(want)
    f = fan(10, 390.0)
    assert f.rho_d == (390.0,) * 10 and f.model == "follow-the-leader"
    # the pair is the paper's (and the line's) for two followers
    assert fan(2, 390.0).beta_d == pytest.approx(in_line(2, 390.0).beta_d)
    # at 325 cm the right side holds 8 (the 9th step would reach 273.6° > 270° − 4.4°):
    # the tenth goes inside, one step beyond 165°
    step325 = 2 * math.degrees(math.asin(25 / 325)) + 1.0
    b325 = [math.degrees(b) for b in fan_bearings(10, 325.0, math.radians(15), 25.0)]
    assert b325[-1] == pytest.approx(165.0 - step325)
    assert max(b325) == pytest.approx(195.0 + 7 * step325)


def test_fan_is_seen_on_both_test_paths() -> None:
    """The fan of ten followers on Test 1's path: no follower hidden or out of the laser's
    view at any sample of the lap (the line's further ranks are, 8-16 % of the lap)."""
    from rtsim.world.formation import fan

    path = rr(800, 400, 200)
    share = occlusion_share(path, fan(10, 390.0), 25.0, step=12.0)
    assert share.worst == 0.0
    line = occlusion_share(path, in_line(4, 390.0), 25.0, step=12.0)
    assert line.worst > 0.05
