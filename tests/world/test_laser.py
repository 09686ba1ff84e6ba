"""Laser beam counts against an independent ray–circle intersection (SPEC §2)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtsim.world.laser import BEAM_BEARINGS, beam_owners, count_beams, max_points

R_F = 25.0


def brute_force(centres: list[tuple[float, float]], r: float) -> list[int]:
    """Per beam, solve |t·u − c|² = r² for the smallest t > 0; nearest disc wins."""
    counts = [0] * len(centres)
    for j in range(361):
        phi = math.radians(90 + 0.5 * j)
        ux, uy = math.cos(phi), math.sin(phi)
        best, who = math.inf, -1
        for i, (cx, cy) in enumerate(centres):
            b = ux * cx + uy * cy
            disc = b * b - (cx * cx + cy * cy - r * r)
            if disc < 0:
                continue
            t = b - math.sqrt(disc)
            if t > 0 and t < best:
                best, who = t, i
        if who >= 0:
            counts[who] += 1
    return counts


def polar(rho: float, beta_deg: float) -> tuple[float, float]:
    b = math.radians(beta_deg)
    return rho * math.cos(b), rho * math.sin(b)


def test_beam_bearings_face_backward() -> None:
    assert BEAM_BEARINGS.shape == (361,)
    assert math.degrees(BEAM_BEARINGS[0]) == pytest.approx(90)
    assert math.degrees(BEAM_BEARINGS[180]) == pytest.approx(180)
    assert math.degrees(BEAM_BEARINGS[-1]) == pytest.approx(270)


@pytest.mark.parametrize("rho", [60.0, 150.0, 325.0, 390.0, 780.0])
@pytest.mark.parametrize("beta", [100.0, 165.0, 180.0, 180.25, 195.0, 262.3])
def test_single_follower_matches_brute_force(rho: float, beta: float) -> None:
    c = polar(rho, beta)
    got = count_beams(np.array([c]), R_F)
    assert got.tolist() == brute_force([c], R_F)
    assert got[0] > 0


def test_follower_outside_field_of_view_returns_nothing() -> None:
    c = polar(300, 0)  # straight ahead
    assert count_beams(np.array([c]), R_F).tolist() == [0]


@pytest.mark.parametrize(
    "centres",
    [
        [polar(150, 180), polar(390, 180)],  # fully behind one another
        [polar(390, 185), polar(200, 180)],  # partly shadowed, nearer listed second
        [polar(390, 195), polar(390, 165), polar(780, 200), polar(780, 160)],  # chevron
        [polar(300, 180), polar(350, 184), polar(400, 188)],
    ],
)
def test_shadowing_matches_brute_force(centres: list[tuple[float, float]]) -> None:
    got = count_beams(np.array(centres), R_F)
    assert got.tolist() == brute_force(centres, R_F)


def test_full_shadow_is_zero_and_partial_shadow_reduces() -> None:
    alone = count_beams(np.array([polar(390, 180)]), R_F)[0]
    hidden = count_beams(np.array([polar(150, 180), polar(390, 180)]), R_F)
    assert hidden[1] == 0 and hidden[0] > alone
    part = count_beams(np.array([polar(200, 180), polar(390, 186)]), R_F)
    assert 0 < part[1] < count_beams(np.array([polar(390, 186)]), R_F)[0]


def test_max_range_hides_far_followers() -> None:
    got = count_beams(np.array([polar(300, 180), polar(900, 200)]), R_F, max_range=800)
    assert got[0] > 0 and got[1] == 0


def test_owner_array() -> None:
    owners = beam_owners(np.array([polar(390, 195), polar(390, 165)]), R_F)
    assert set(owners.tolist()) == {-1, 0, 1}
    assert (owners == 0).sum() == count_beams(np.array([polar(390, 195)]), R_F)[0]


def test_k_at_150_cm_versus_paper() -> None:
    """The paper's Eq 2 takes k = 34 at 150 cm; the geometry gives 38–39 (SPEC §2)."""
    counts = {b: brute_force([polar(150, 180 + b)], R_F)[0] for b in np.arange(0, 0.5, 0.01)}
    k_geom = max(counts.values())
    assert set(counts.values()) == {38, 39}
    assert max_points(150, R_F) == k_geom == 39
    for b, c in counts.items():
        assert count_beams(np.array([polar(150, 180 + b)]), R_F)[0] == c
    print(
        f"\nk at 150 cm: geometry {min(counts.values())}-{k_geom} beams, paper's Eq 2: 34 "
        f"(2*arctan(25/150)/0.5deg = {2 * math.degrees(math.atan(25 / 150)) / 0.5:.2f})"
    )
