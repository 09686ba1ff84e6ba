"""The compiled backend's scan in one call (`rtsim.world.scanstep`) gives the Python
reference's scans bit for bit: every field a reader sees, scan after scan, with windows
that lose their followers, searches, re-acquisitions and both window centres."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from rtsim.config.scenario import load_scenario
from rtsim.world import compiled
from rtsim.world.scanstep import PY, bound_violations, fix_error, to_leader_xy, truth_change
from rtsim.world.world import World

needs_numba = pytest.mark.skipif(not compiled.available(), reason="numba is not importable")

FIELDS = (
    "points", "measured", "truth", "centre", "in_window", "lost", "reacquired", "changes",
    "violations", "searched",
)  # fmt: skip


def _bits(x: Any) -> Any:
    if isinstance(x, float):
        return ("f", x.hex())
    if isinstance(x, bool):
        return ("b", x)
    if isinstance(x, int):
        return ("i", x)
    if isinstance(x, list | tuple):
        return (type(x).__name__, [_bits(v) for v in x])
    if isinstance(x, dict):
        return {k: _bits(v) for k, v in x.items()}
    return x


def _seen(scan: Any) -> Any:
    """Everything a reader of ``scan`` sees, with its Python types."""
    out = {name: scan.as_lists(name) for name in FIELDS}
    out["arrays"] = [scan.measured.tolist(), scan.violations["bearing"].tolist()]
    for name in ("t_ms", "leader_pose", "cause", "voted", "fix_error", "neighbour", "cells"):
        out[name] = getattr(scan, name)
    out["lost_by_cause"] = scan.lost_by_cause()
    out["totals"] = (scan.n_lost, scan.n_searched, scan.n_reacquired, scan.confusions)
    return _bits(out)


def _drive(
    backend: str, over: dict[str, Any], scans: int, gap_ms: float, both: bool = False
) -> list[Any]:
    """``scans`` scans, each estimated (``both``: in one call, `World.scan_estimate`), and
    commands between them: everything a reader sees of each scan, then the estimates."""
    cfg = load_scenario("test2", overrides={**over, "world.backend": backend}).world
    world = World(cfg, np.random.default_rng(11))
    if backend == "compiled":
        assert world._fused is not None
    seen = []
    t = 0.0
    for j in range(scans):
        t += gap_ms * (1.0 + 0.5 * (j % 3))
        if both:
            scan = world.scan_estimate(t)
        else:
            scan = world.scan(t)
            world.estimate(scan)
        seen.append(_seen(scan))
        seen.append(_bits([world.covariances(), world.max_heading_var]))
        for i in range(1, world.n + 1):
            world.command(i, t + 3.0 * i)
    seen.append(_bits([world.covariances(), world.state()]))
    return seen


CASES = {
    "shipped": {},
    "lost, previous, always": {
        "sensing.r_H": 6.0,
        "sensing.range_noise": 6.0,
        "localization.centre": "previous",
        "localization.search": "always",
        "formation.followers": 4,
    },
    "lost, predicted, visible": {
        "sensing.r_H": 5.0,
        "sensing.range_noise": 5.0,
        "formation.followers": 5,
    },
}


@needs_numba
@pytest.mark.parametrize("case", sorted(CASES))
def test_fused_scan_is_the_reference(case: str) -> None:
    over = CASES[case]
    py = _drive("python", over, 40, 250.0)
    co = _drive("compiled", over, 40, 250.0)
    assert py == co
    # the scan and the estimate in one compiled call: the same, and the Python world's
    # `scan_estimate` is its `scan` then `estimate`
    assert _drive("compiled", over, 40, 250.0, both=True) == py
    assert _drive("python", over, 40, 250.0, both=True) == py
    if case != "shipped":  # (the cases reach the search and its outcomes)
        flat = repr(py)
        assert "('b', True)" in flat


@needs_numba
def test_lost_tracks_reached() -> None:
    """The lossy case searches and re-acquires (so the comparison above covers them)."""
    cfg = load_scenario("test2", overrides=CASES["lost, previous, always"]).world
    world = World(cfg, np.random.default_rng(11))
    searched = reacquired = 0
    t = 0.0
    for j in range(40):
        t += 250.0 * (1.0 + 0.5 * (j % 3))
        scan = world.scan(t)
        world.estimate(scan)
        searched += scan.n_searched
        reacquired += scan.n_reacquired
        for i in range(1, world.n + 1):
            world.command(i, t + 3.0 * i)
    assert searched > 0 and reacquired > 0


@needs_numba
def test_scan_kernels_compiled_are_the_twins() -> None:
    """Each per-follower kernel, compiled, gives its Python twin's bits on random inputs."""
    from rtsim.world.jit import build

    rng = np.random.default_rng(5)
    built = {
        fn.__name__: build(fn) for fn in (to_leader_xy, truth_change, bound_violations, fix_error)
    }
    for _ in range(3000):
        a = rng.uniform(-800, 800, 8).tolist()
        h = float(rng.uniform(-7, 7))
        c, s = math.cos(h), math.sin(h)
        assert _bits(built["to_leader_xy"](a[0], a[1], c, s, a[2], a[3])) == _bits(
            PY["to_leader_xy"](a[0], a[1], c, s, a[2], a[3])
        )
        beta = float(rng.uniform(0, 2 * math.pi))
        for first in (True, False):
            args = (a[0], a[1], a[4], a[2], a[3], abs(a[5]), beta, a[6], first)
            assert _bits(built["truth_change"](*args)) == _bits(PY["truth_change"](*args))
        args2 = (abs(a[0]), abs(a[1]), a[2], abs(a[3]) / 100, 25.0, 30.0, 40.0, 0.3)
        assert built["bound_violations"](*args2) == PY["bound_violations"](*args2)
        assert _bits(built["fix_error"](*a[:4])) == _bits(PY["fix_error"](*a[:4]))


@needs_numba
def test_estimate_from_an_earlier_scan() -> None:
    """`World.estimate` with a scan other than the last (its fixes packed from the scan's
    lists, not the fused scan's buffer) is the reference's too."""
    out = []
    for backend in ("python", "compiled"):
        cfg = load_scenario("test2", overrides={"world.backend": backend}).world
        world = World(cfg, np.random.default_rng(4))
        first = world.scan(120.0)
        world.scan(240.0)
        world.estimate(first)
        out.append(_bits([world.covariances(), world.state()]))
    assert out[0] == out[1]


@needs_numba
def test_fused_fields_zip_on_first_read() -> None:
    """A fused scan's pairs (truth, centre, fixes) are zipped from its columns when first
    read, once; its other fields are the kernel's columns as lists."""
    cfg = load_scenario("test2", overrides={"world.backend": "compiled"}).world
    world = World(cfg, np.random.default_rng(3))
    scan = world.scan_estimate(240.0)
    raw = scan._raw
    assert "truth" not in raw and "measured" not in raw and "centre" not in raw
    truth = scan.as_lists("truth")
    assert raw["truth"] is truth and scan.as_lists("truth") is truth
    assert all(type(p) is tuple and type(p[0]) is float for p in truth)
    assert scan.truth.shape == (world.n, 2)
    assert scan.as_lists("searched") == [False] * world.n


@pytest.mark.parametrize("backend", ["python", pytest.param("compiled", marks=needs_numba)])
def test_a_scan_older_than_the_estimates_is_refused(backend: str) -> None:
    """`World.estimate` refuses a scan older than the estimates (`World._not_older`, which
    `World.scan_estimate` asks too, or the world's clock refuses the past first), and the
    refusals leave the estimates as they were."""
    from rtsim.errors import RtsimError

    cfg = load_scenario("test2", overrides={"world.backend": backend}).world
    world = World(cfg, np.random.default_rng(3))
    old = world.scan(500.0)
    world.scan_estimate(1000.0)
    before = [world.estimate_at(i, 1000.0) for i in range(1, cfg.n + 1)]
    with pytest.raises(RtsimError, match="older than the estimates"):
        world.estimate(old)
    with pytest.raises(RtsimError, match="older than the estimates|back in time"):
        world.scan_estimate(800.0)
    assert [world.estimate_at(i, 1000.0) for i in range(1, cfg.n + 1)] == before
