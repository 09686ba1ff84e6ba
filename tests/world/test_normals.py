"""numpy's standard normals written out as a kernel source (`rtsim.world.normals`): the
Python run and the compiled run draw numpy's own numbers, in numpy's order, and leave the
generator's state where numpy leaves it (across requests of any size, seeds, the
ziggurat's wedges and its tail); the compiled world's scans draw the world's stream."""

from __future__ import annotations

import numpy as np
import pytest

from rtsim.config.scenario import load_scenario
from rtsim.model.window import LASER_POINTS
from rtsim.world import compiled
from rtsim.world.jit import build
from rtsim.world.normals import M52, set_state, standard_normals, state_of
from rtsim.world.world import World
from rtsim.world.ziggurat import KI

needs_numba = pytest.mark.skipif(not compiled.available(), reason="numba is not importable")


def _twin(G: np.ndarray, m: int) -> np.ndarray:
    out = np.empty(m)
    with np.errstate(over="ignore"):  # (uint64 products wrap, as numpy's C does)
        standard_normals(G, out, m)
    return out


def _same_state(rng: np.random.Generator, G: np.ndarray) -> bool:
    return bool((state_of(rng.bit_generator) == G).all())


def test_the_state_round_trips() -> None:
    rng = np.random.default_rng(3)
    rng.standard_normal(5)
    G = state_of(rng.bit_generator)
    other = np.random.default_rng(4)
    set_state(other.bit_generator, G)
    assert other.bit_generator.state == rng.bit_generator.state
    assert other.standard_normal(7).tolist() == rng.standard_normal(7).tolist()


@pytest.mark.parametrize("seed", [0, 1, 20261129])
def test_python_run_is_numpys_draws(seed: int) -> None:
    rng = np.random.default_rng(seed)
    G = state_of(rng.bit_generator)
    for m in (1, 2, 361, 2000):
        assert _twin(G, m).tolist() == rng.standard_normal(m).tolist(), m
        assert _same_state(rng, G)


def _rejected(seed: int, wedges: int, tails: int) -> list[dict]:
    """States of a PCG64 just before a raw draw the ziggurat rejects: ``wedges`` in a
    wedge (a layer > 0, magnitude beyond its ki), ``tails`` in the tail (layer 0)."""
    bits = np.random.PCG64(seed)
    found: dict[bool, list[dict]] = {False: [], True: []}
    while len(found[False]) < wedges or len(found[True]) < tails:
        state = bits.state
        u = int(bits.random_raw())
        idx, rabs = u & 0xFF, (u >> 9) & int(M52)
        if rabs >= KI[idx] and len(found[idx == 0]) < (tails if idx == 0 else wedges):
            found[idx == 0].append(state)
    return found[False] + found[True]


@pytest.mark.parametrize("seed", [5, 6])
def test_python_run_takes_the_tail_and_wedges_as_numpy(seed: int) -> None:
    """Started where a draw is rejected (the tail's loop, a wedge's test), the twin draws
    numpy's numbers."""
    for state in _rejected(seed, 8, 4):
        bits = np.random.PCG64()
        bits.state = state
        rng = np.random.Generator(bits)
        G = state_of(bits)
        assert _twin(G, 3).tolist() == rng.standard_normal(3).tolist()
        assert _same_state(rng, G)


@needs_numba
@pytest.mark.parametrize("seed", [0, 7, 123456789])
def test_compiled_run_is_numpys_draws(seed: int) -> None:
    """Millions of draws in requests of every size, through several of numpy's blocks."""
    fn = build(standard_normals)
    rng = np.random.default_rng(seed)
    G = state_of(rng.bit_generator)
    out = np.empty(1_500_000)
    for m in (1, 361, 16_384, 361, 2, 1_500_000, 7):
        fn(G, out, m)
        assert np.array_equal(out[:m], rng.standard_normal(m)), m
        assert _same_state(rng, G)
    # the twin and the compiled run from one state
    H = G.copy()
    fn(G, out, 5000)
    assert _twin(H, 5000).tolist() == out[:5000].tolist()
    assert (G == H).all()


@needs_numba
def test_the_compiled_worlds_scans_draw_the_stream() -> None:
    """The fused scan's kernel draws each scan's 361 normals from the world's stream, the
    commands' normals (`World._normals`) between them from the same stream, in order."""
    cfg = load_scenario("test2", overrides={"world.backend": "compiled"}).world
    world = World(cfg, np.random.default_rng(11))
    assert world._fused is not None and world._pcg is not None
    ref = np.random.default_rng(11)
    ref.standard_normal((cfg.n, 3))
    ref_z: list[float] = []
    t = 0.0
    for j in range(60):
        t += 100.0
        world.scan(t)
        assert world._fused.z.tolist() == ref.standard_normal(LASER_POINTS).tolist(), j
        for _ in range(j % 4):
            if not ref_z:
                ref_z = ref.standard_normal(512).tolist()
            want, ref_z = ref_z[:2], ref_z[2:]
            assert world._normals(2) == want


@needs_numba
def test_another_bit_generator_scans_as_the_reference() -> None:
    """A world on another bit generator (not a PCG64) takes its laser's normals from numpy
    and hands them to the fused scan: the Python world's scans, bit for bit."""
    seen = {}
    for backend in ("python", "compiled"):
        cfg = load_scenario("test2", overrides={"world.backend": backend}).world
        world = World(cfg, np.random.Generator(np.random.MT19937(5)))
        assert world._pcg is None
        rows = []
        t = 0.0
        for _ in range(25):
            t += 150.0
            scan = world.scan_estimate(t)
            rows.append([scan.as_lists(k) for k in ("measured", "points", "changes")])
            rows.append(world.covariances())
            for i in range(1, world.n + 1):
                world.command(i, t + 3.0 * i)
        seen[backend] = repr(rows)
    assert seen["python"] == seen["compiled"]
