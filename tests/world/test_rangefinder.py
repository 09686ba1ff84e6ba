"""The laser scan as data (rtsim.world.rangefinder) against hand-computed geometry and the
beam counts of rtsim.world.laser."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtsim.world import kernels
from rtsim.world.laser import count_beams
from rtsim.world.rangefinder import Rangefinder

R_F = 25.0


def _scan(centres: list[tuple[float, float]], sd: float = 0.0, fast: bool = False, seed: int = 0,
          max_range: float = 8000.0):  # type: ignore[no-untyped-def]  # fmt: skip
    rf = Rangefinder(R_F, max_range, sd, fast)
    xy = np.array(centres, dtype=float).reshape(-1, 2)
    z = np.random.default_rng(seed).standard_normal(361)
    px, py, owner = rf.scan(xy[:, 0].copy(), xy[:, 1].copy(), z)
    return px.copy(), py.copy(), owner.copy()


def test_one_disc_straight_behind_by_hand() -> None:
    """A disc 200 cm straight behind (bearing 180°, beam 180) subtends ±asin(25/200) =
    ±7.18°: beams 166..194 hit it, beam 180 at 175 cm, beam 180 ± m at
    200·cos δ − √(25² − 200²·sin² δ), δ = 0.5°·m."""
    px, py, owner = _scan([(-200.0, 0.0)])
    hit = np.flatnonzero(owner >= 0)
    assert hit.tolist() == list(range(166, 195))
    rng = np.hypot(px, py)
    assert rng[180] == pytest.approx(175.0, abs=1e-9)
    for m in (1, 7, 14):
        d = math.radians(0.5 * m)
        want = 200 * math.cos(d) - math.sqrt(25**2 - (200 * math.sin(d)) ** 2)
        assert rng[180 + m] == pytest.approx(want, abs=1e-9)
        assert rng[180 - m] == pytest.approx(want, abs=1e-9)
    # every point lies on the disc's circle, on the side facing the laser
    assert np.hypot(px[hit] + 200.0, py[hit]) == pytest.approx(np.full(hit.size, R_F))
    assert (px[hit] >= -200.0).all()
    assert np.isnan(px[owner < 0]).all()


def test_a_disc_behind_another_is_hidden() -> None:
    """A disc at 390 cm straight behind one at 150 cm returns nothing (the near one subtends
    ±9.6°, the far one ±3.7°); moved 60° aside it returns its own beams again."""
    _, _, owner = _scan([(-150.0, 0.0), (-390.0, 0.0)])
    assert (owner == 1).sum() == 0
    assert (owner == 0).sum() == 39
    b = math.radians(120.0)
    _, _, owner = _scan([(-150.0, 0.0), (390 * math.cos(b), 390 * math.sin(b))])
    assert (owner == 1).sum() == count_beams(np.array([[390 * math.cos(b), 390 * math.sin(b)]]),
                                             R_F)[0]  # fmt: skip


def test_beam_counts_match_the_laser_geometry() -> None:
    """Random groups of discs: the beams each returns in the scan are count_beams' counts
    (shadowing included), and the range noise moves points along their beams only."""
    rng = np.random.default_rng(7)
    for _ in range(40):
        n = int(rng.integers(1, 6))
        rho = rng.uniform(60, 600, n)
        beta = rng.uniform(math.radians(60), math.radians(300), n)
        xy = np.c_[rho * np.cos(beta), rho * np.sin(beta)]
        if (
            n > 1
            and min(math.dist(xy[a], xy[b]) for a in range(n) for b in range(a + 1, n)) < 2 * R_F
        ):
            continue
        _, _, owner = _scan([tuple(p) for p in xy], sd=1.0)
        assert np.bincount(owner[owner >= 0], minlength=n).tolist() == count_beams(xy, R_F).tolist()


def test_max_range_and_noise() -> None:
    """Beyond the maximum range nothing returns; the noise is σ·z along the beam."""
    _, _, owner = _scan([(-200.0, 0.0)], max_range=170.0)
    assert (owner >= 0).sum() == 0
    px0, py0, _ = _scan([(-200.0, 0.0)])
    px1, py1, owner = _scan([(-200.0, 0.0)], sd=2.0, seed=3)
    z = np.random.default_rng(3).standard_normal(361)
    hit = owner >= 0
    d = np.hypot(px1, py1)[hit] - np.hypot(px0, py0)[hit]
    assert d == pytest.approx(2.0 * z[hit])


@pytest.mark.skipif(not kernels.available(), reason="numba not installed")
def test_compiled_scan_is_the_python_scan() -> None:
    centres = [(-150.0, 40.0), (-320.0, -84.0), (-330.0, 90.0)]
    a = _scan(centres, sd=1.0, fast=False, seed=5)
    b = _scan(centres, sd=1.0, fast=True, seed=5)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)


def _every_beam(xs, ys, r_F, max_range, sd, z):  # type: ignore[no-untyped-def]
    """The scan with every follower tried on every beam (the rule `scan_points` keeps with
    each follower's span of beams only): per beam, the nearest hit, the first of equals."""
    from rtsim.world.rangefinder import BEAM_COS, BEAM_SIN

    n = len(xs)
    px, py, owner, counts = [math.nan] * 361, [math.nan] * 361, [-1] * 361, [0] * n
    for j in range(361):
        c, s = float(BEAM_COS[j]), float(BEAM_SIN[j])
        best, who = math.inf, -1
        for k in range(n):
            p = xs[k] * c + ys[k] * s
            q = xs[k] * s - ys[k] * c
            half2 = r_F * r_F - q * q
            if half2 >= 0.0 and p > 0.0:
                r = max(p - math.sqrt(half2), 0.0)
                if r < best:
                    best, who = r, k
        if who >= 0 and best <= max_range:
            r = best + sd * z[j]
            owner[j], px[j], py[j] = who, r * c, r * s
            counts[who] += 1
    return px, py, owner, counts


@pytest.mark.parametrize("fast", [False, True])
def test_spans_are_every_beam(fast: bool) -> None:
    """The beams' spans leave no hit out, bit for bit: random formations (discs side by side,
    shadowing one another, around the leader, straddling the scan's ends, touching or
    overlapping the leader, beyond the range) against every follower on every beam."""
    if fast and not kernels.available():
        pytest.skip("numba is not importable")
    rng = np.random.default_rng(8)
    for trial in range(400):
        n = int(rng.integers(1, 7))
        rho = rng.uniform(0.0, 3.0 * R_F, n) if trial % 4 == 0 else rng.uniform(20.0, 400.0, n)
        bearing = rng.uniform(0.0, 2 * math.pi, n)
        if trial % 5 == 0:  # (near the scan's ends, 90° and 270°)
            bearing = rng.choice([0.5, 1.5], n) * math.pi + rng.normal(0.0, 0.05, n)
        xs = (rho * np.cos(bearing)).tolist()
        ys = (rho * np.sin(bearing)).tolist()
        max_range = float(rng.choice([8000.0, 150.0]))
        z = np.random.default_rng(trial).standard_normal(361)
        rf = Rangefinder(R_F, max_range, 0.7, fast)
        px, py, owner = rf.scan(np.array(xs), np.array(ys), z)
        want = _every_beam(xs, ys, R_F, max_range, 0.7, z.tolist())
        got = (px.tolist(), py.tolist(), owner.tolist(), rf.counts[:n].tolist())
        assert repr(got) == repr(want), trial
