"""The compiled world's estimates as one array (`rtsim.world.estimates`,
`rtsim.world.compiled.CompiledEstimates`) against the Python world's filters and lists, bit
for bit, on whole call sequences: more commands held between two scans than the array has
room for at first, a command replaced at the same time, a lost follower re-acquired (the
filter reset), with either Hough window centre and either formation law."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from rtsim.world import SensingParams, World, WorldConfig, chevron
from rtsim.world import compiled as compiled_world
from rtsim.world import rounded_rectangle as rr
from rtsim.world.config import LocalizationParams
from rtsim.world.estimates import BASE, HELD_ROOM

needs_numba = pytest.mark.skipif(not compiled_world.available(), reason="numba is not importable")


def _hex(x: Any) -> Any:
    if isinstance(x, float):
        return x.hex()
    if isinstance(x, list | tuple):
        return [_hex(v) for v in x]
    return x


def _seen(world: World, t: float) -> Any:
    """Everything a reader of the estimates gets at ``t`` ms, as exact bits."""
    n = world.n
    return _hex(
        [
            [f.pose for f in world.filters],
            [f.P.ravel().tolist() for f in world.filters],
            world.covariances(),
            [world.estimate_at(i, t) for i in range(1, n + 1)],
            world.estimates_at(t),
            [world.held_command(i) for i in range(1, n + 1)],
            world.max_heading_var,
            world.state()["estimate"],
        ]
    )


def _config(model: str, centre: str, backend: str) -> WorldConfig:
    form = chevron(2, 390)
    if model != "l-psi":
        form = replace(form, model=model)
    return WorldConfig(
        rr(5000, 400, 200),
        25.0,
        form,
        sensing=SensingParams(r_reacq=100.0, position_noise=0.5),
        localization=LocalizationParams(centre=centre),
        backend=backend,
    )


def _drive(world: World) -> tuple[int, list[Any]]:
    """A call sequence with the cases the array must grow and restart for: the scans
    re-acquiring a follower, and what the readers see after each call."""
    out: list[Any] = []
    reacquired = 0
    t = 0.0
    for window in range(14):
        if window == 6:  # follower 2 jumps 40 cm: lost, then re-acquired (reset)
            world.advance(t)
            world.followers.y[1] += 40.0
        scan = world.scan(t)
        world.estimate(scan)
        reacquired += int(scan.reacquired.sum())
        out.append(_seen(world, t))
        sends = [(1, t + 110.0), (2, t + 113.0)]
        if window == 3:  # more commands held than the row's room, one time given twice
            sends = [(1, t + 5.0 + 7.0 * j) for j in range(2 * HELD_ROOM + 3)]
            sends.insert(4, sends[3])
            sends.append((2, t + 200.0))
        for i, s in sends:
            world.command(i, s)
            out.append(_seen(world, s))
        t += 240.0
    return reacquired, out


@needs_numba
@pytest.mark.parametrize("model", ["l-psi", "follow-the-leader"])
@pytest.mark.parametrize("centre", ["previous", "predicted"])
def test_array_estimates_are_the_filters_bit_for_bit(model: str, centre: str) -> None:
    ref = World(_config(model, centre, "python"), np.random.default_rng(5))
    fast = World(_config(model, centre, "compiled"), np.random.default_rng(5))
    assert fast._arr is not None and ref._arr is None
    (n_got, got), (n_want, want) = _drive(fast), _drive(ref)
    assert n_want == n_got == 1
    assert fast._arr.E.shape[1] > BASE + 3 * HELD_ROOM  # (the row grew)
    assert got == want


@needs_numba
def test_a_python_law_is_not_handed_to_the_fused_command(monkeypatch: pytest.MonkeyPatch) -> None:
    """Where the kernels' hypot is not this interpreter's, the follow-the-leader law stays
    Python (its search starts are lists) and the compiled world's command runs it between
    two calls on the array (`est_carry`, `est_hold`), not inside `est_command_ftl` (which
    would take those lists as numba's deprecated reflected lists, and the kernels' hypot)."""
    monkeypatch.setattr(compiled_world.kernels(), "exact_hypot", False)
    ref = World(_config("follow-the-leader", "predicted", "python"), np.random.default_rng(5))
    fast = World(_config("follow-the-leader", "predicted", "compiled"), np.random.default_rng(5))
    assert fast.follow_law is not None and not fast.follow_law.compiled
    assert fast._arr is not None and fast._arr._ftl_entry is None
    assert _drive(fast) == _drive(ref)
    assert fast._arr._ftl_entry is None  # (the fused command never ran)
