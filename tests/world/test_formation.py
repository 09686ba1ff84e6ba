"""The default chevron keeps every follower in the laser's view (SPEC §6, issue 4)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtsim.errors import ScenarioError
from rtsim.world.formation import Formation, chevron
from rtsim.world.laser import count_beams


def _beams(f: Formation, r_F: float = 25.0) -> np.ndarray:
    return count_beams(f.xy(), r_F)


def test_paper_pair_is_unchanged() -> None:
    f = chevron(2, 390)
    assert f.rho_d == (390, 390)
    assert [math.degrees(b) for b in f.beta_d] == pytest.approx([195, 165])


@pytest.mark.parametrize("sep", [150, 325, 390])
@pytest.mark.parametrize("n", [3, 4, 7, 10, 20])
def test_no_follower_is_hidden(n: int, sep: float) -> None:
    f = chevron(n, sep)
    # pairs one separation further back, alternating sides, widening outward
    assert f.rho_d == tuple(sep * ((i + 1) // 2) for i in range(1, n + 1))
    offs = [abs(b - math.pi) for b in f.beta_d]
    assert offs[0] == pytest.approx(math.radians(15))
    assert all(b > a for a, b in zip(offs[::2], offs[2::2], strict=False))
    beams = _beams(f)
    # each follower returns at least the beams that an unshadowed disc of its range
    # would give, minus the one at each edge that the grid may miss
    for i, (rho, count) in enumerate(zip(f.rho_d, beams, strict=True)):
        half = math.degrees(math.asin(25 / rho))
        assert count >= math.floor(2 * half / 0.5) - 1, (i, rho, count)


def test_the_literal_chevron_would_hide_followers() -> None:
    """Same offset for every pair: pair 2 sits behind pair 1 and returns no beam."""
    lit = Formation(
        (390, 390, 780, 780), tuple(math.pi + s * math.radians(15) for s in (1, -1, 1, -1))
    )
    assert list(_beams(lit)[2:]) == [0, 0]
    assert min(_beams(chevron(4, 390))) > 0


def test_too_many_followers_for_the_view_is_a_clear_error() -> None:
    with pytest.raises(ScenarioError, match=r"formation.followers: 50 followers do not fit"):
        chevron(50, 100)
