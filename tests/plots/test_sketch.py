"""The bounded sketches a long run's figures draw from (rtsim/plots/sketch.py): each keeps
what its definition says against a plain loop, gives the same result whatever the chunks
it is fed in, and stops growing when the run only repeats itself (issue 35: memory flat
with every output)."""

from __future__ import annotations

import numpy as np
import pytest

from rtsim.plots.sketch import DotSketch, Grid, LineSketch, PointSketch


def _lap(m: int = 400, noise: float = 0.0, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A rounded closed path of ``m`` points (cm), optionally jittered."""
    rng = np.random.default_rng(seed)
    a = np.linspace(0, 2 * np.pi, m, endpoint=False)
    x = 400 * np.cos(a) + 60 * np.cos(3 * a) + rng.normal(0, noise, m)
    y = 200 * np.sin(a) + rng.normal(0, noise, m)
    return x, y


def _fed(sk: LineSketch | PointSketch, x: np.ndarray, y: np.ndarray, sizes: list[int]) -> None:
    at = 0
    for k in sizes:
        sk.add(x[at : at + k], y[at : at + k])
        at += k
    sk.add(x[at:], y[at:])


GRID = Grid.over((-500.0, -250.0), (500.0, 250.0), 256)


@pytest.mark.parametrize("sizes", [[], [1, 1, 5], [397, 3], [50] * 30])
def test_a_retraced_path_keeps_its_first_lap_whatever_the_chunks(sizes: list[int]) -> None:
    """Three laps of the same path: the kept polyline is the first lap (plus the closing
    segment back to its start), one run without breaks, fed whole or in chunks of any
    size; a fourth lap with an excursion adds that excursion's segments only."""
    x, y = _lap()
    xs, ys = np.tile(x, 3), np.tile(y, 3)
    sk = LineSketch(GRID)
    _fed(sk, xs, ys, sizes)
    kx, ky = sk.xy()
    drawn = ~np.isnan(kx)
    assert np.isnan(kx[0]) and drawn[1:].all()  # one run
    np.testing.assert_array_equal(kx[1:], np.r_[x, x[0]])
    np.testing.assert_array_equal(ky[1:], np.r_[y, y[0]])
    once = LineSketch(GRID)
    once.add(xs, ys)
    np.testing.assert_array_equal(once.xy()[0], kx)
    # an excursion: lap four with points 100..110 pushed outward by 30 cm
    x4, y4 = x.copy(), y.copy()
    y4[100:111] += 30
    sk.add(x4, y4)
    k2x, _ = sk.xy()
    new = k2x[len(kx) :]
    assert np.isnan(new[0]) and 11 <= np.count_nonzero(~np.isnan(new)) <= 14
    assert set(new[~np.isnan(new)]) <= set(x4[98:113])


def test_a_noisy_path_stops_growing_and_holds_at_most_a_segment_per_cell() -> None:
    """A path retraced with centimetre noise: the kept vertices of 40 laps are within a
    few percent of those of 20 (the cells near the path fill up), and never more than the
    grid's cells; NaN breaks separate runs and each kept segment has finite ends."""
    sk = LineSketch(GRID)
    counts = []
    for lap in range(40):
        sk.add(*_lap(noise=0.5, seed=lap))
        counts.append(np.count_nonzero(~np.isnan(sk.xy()[0])))
    assert counts[-1] - counts[19] < 0.15 * counts[19]
    assert counts[-1] < len(sk.seen) + 2 * np.count_nonzero(np.isnan(sk.xy()[0]))
    assert len(sk.seen) <= GRID.size**2


def _first_per_cell(ids: np.ndarray, cap: int) -> np.ndarray:
    seen: dict[int, int] = {}
    keep = np.zeros(len(ids), dtype=bool)
    for i, c in enumerate(ids.tolist()):
        if seen.get(c, 0) < cap:
            keep[i] = True
            seen[c] = seen.get(c, 0) + 1
    return keep


@pytest.mark.parametrize("sizes", [[], [7, 1, 300], [64] * 40])
@pytest.mark.parametrize("cap", [1, 3, 8])
def test_a_scatter_keeps_the_first_points_of_each_cell_up_to_its_cap(
    sizes: list[int], cap: int
) -> None:
    """`PointSketch` keeps, in order, exactly the first ``cap`` points of each grid cell
    (a plain loop over the points says which, as float32), NaN dropped, fed in chunks of
    any size."""
    rng = np.random.default_rng(cap)
    x = np.tile(rng.normal(0, 40, 1000), 3) + rng.normal(0, 2, 3000)
    y = np.tile(rng.normal(0, 20, 1000), 3) + rng.normal(0, 2, 3000)
    x[::97] = np.nan
    sk = PointSketch(GRID, cap)
    _fed(sk, x, y, sizes)
    ok = np.isfinite(x)
    want = _first_per_cell(GRID.ids(x[ok], y[ok]), cap)
    kx, ky = sk.xy()
    np.testing.assert_array_equal(kx, x[ok][want].astype(np.float32))
    np.testing.assert_array_equal(ky, y[ok][want].astype(np.float32))
    assert np.bincount(np.unique(GRID.ids(kx, ky), return_inverse=True)[1]).max() <= cap


@pytest.mark.parametrize("sizes", [[], [5, 5, 5], [333] * 5])
def test_dots_keep_the_first_of_each_bin_and_band_across_chunks(sizes: list[int]) -> None:
    """`DotSketch` keeps the first dot of each (bin, band), also where a bin spans two
    chunks, and counts every dot fed."""
    rng = np.random.default_rng(3)
    m = 2000
    t = np.sort(rng.uniform(0, 1e6, m))
    bins = np.floor(t / 1e6 * 64).astype(np.int64)
    v = rng.gamma(2.0, 30.0, m)
    sk = DotSketch(7.5)
    at = 0
    for k in [*sizes, m]:
        sk.add(bins[at : at + k], t[at : at + k], v[at : at + k])
        at += k
        if at >= m:
            break
    seen: set[tuple[int, int]] = set()
    want = []
    for i in range(m):
        key = (int(bins[i]), int(np.floor(v[i] / 7.5)))
        if key not in seen:
            seen.add(key)
            want.append(i)
    kt, kv = sk.tv()
    np.testing.assert_array_equal(kt, t[want].astype(np.float32))
    np.testing.assert_array_equal(kv, v[want].astype(np.float32))
    assert sk.count == m
