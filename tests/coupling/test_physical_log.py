"""The truth log's samples per scan (`rtsim.coupling.physical.PhysicalLog.add`): the
compiled call on a compiled law and the Python twin on the Python law give the same floats,
and both are the per-follower arithmetic they replace (the law's ``project`` and ``point``,
``math.hypot``, `rtsim.world.contact.closest_to`), bit for bit."""

from __future__ import annotations

import math
import struct
from typing import Any

import numpy as np
import pytest

from rtsim.coupling import run_scenario
from rtsim.coupling.physical import PhysicalLog
from rtsim.world import compiled
from rtsim.world.contact import closest_each, closest_to
from rtsim.world.ftl import TraceFollower
from rtsim.world.path import rounded_rectangle

numba = pytest.importorskip("numba")

RHO = [325.0, 325.0, 500.0, 520.0, 700.0]
LAT = [80.0, -80.0, 80.0, -60.0, 0.0]


def _bits(v: Any) -> bytes:
    a = [float(x) for x in np.ravel(np.asarray(v, dtype=float))]
    return struct.pack(f"{len(a)}d", *a)


def _by_hand(law: TraceFollower, rho_d: list[float], leader: Any, xs: Any, ys: Any) -> Any:
    """The samples and closest approaches one follower at a time (the loop `add` had)."""
    xl, yl, _ = leader
    out = []
    for k in range(len(xs)):
        x, y = xs[k], ys[k]
        out.append(abs(math.hypot(x - xl, y - yl) - rho_d[k]))
        px, py, _ = law.point(k, law.project(k, x, y, 0.0))
        out.append(math.hypot(x - px, y - py))
    near = tuple(closest_to(xs, ys, i, xl, yl) for i in range(len(xs)))
    return out, near


@pytest.mark.parametrize("n", [1, 2, 5])
def test_compiled_python_and_by_hand_agree(n: int) -> None:
    """300 scans of followers scattered about their traces behind a leader driving the
    path: every sample, closest approach and kept projection identical on all three."""
    path = rounded_rectangle(800, 400, 120)
    rho, lat = RHO[:n], LAT[:n]
    py_law = TraceFollower(path, rho, lat, 0.5, 40.0)
    co_law = compiled.CompiledTraceFollower(path, rho, lat, 0.5, 40.0)
    if not co_law.compiled:
        pytest.skip("this interpreter's hypot is not the kernels'")
    ref = TraceFollower(path, rho, lat, 0.5, 40.0)
    logs = [PhysicalLog(n, rho, 25.0, law) for law in (py_law, co_law)]
    rng = np.random.default_rng(36)
    s_l = 1200.0
    for _ in range(300):
        s_l += float(rng.uniform(0.0, 60.0))
        leader = path.pose(s_l)
        xs, ys = [], []
        for k in range(n):
            x, y, _ = ref.point(k, s_l - rho[k])
            xs.append(x + float(rng.normal(0.0, 8.0)))
            ys.append(y + float(rng.normal(0.0, 8.0)))
        want, want_near = _by_hand(ref, rho, leader, xs, ys)
        for log in logs:
            before = len(log.samples.buf)
            near = log.add(leader, xs, ys)
            assert _bits(log.samples.buf[before:]) == _bits(want)
            assert _bits(near) == _bits(want_near)
            assert _bits(log._law._sf) == _bits(ref._sf)  # type: ignore[union-attr]
    assert logs[0].min_dist == logs[1].min_dist


def test_closest_each_is_closest_to_per_follower() -> None:
    """`closest_each` (every pair once, `closest_into`) against `closest_to` per follower,
    ties and coincident robots included."""
    rng = np.random.default_rng(7)
    for n in (1, 2, 3, 9):
        for _ in range(50):
            xs = rng.integers(-3, 4, n).astype(float).tolist()
            ys = rng.normal(0.0, 100.0, n).round(1).tolist()
            got = closest_each(xs, ys, 0.5, -1.0)
            assert _bits(got) == _bits([closest_to(xs, ys, i, 0.5, -1.0) for i in range(n)])


@pytest.mark.parametrize("n", [2, 5])
def test_samples_made_in_the_scan_are_the_logs_own(n: int, monkeypatch: Any) -> None:
    """A run whose truth log's samples the world's scan makes (`PhysicalLog.fuse`:
    `trace_samples` inside `rtsim.world.scanstep.scan_step`) and one whose log makes them by
    its own compiled call: the same physical outcomes and windows (closest approaches
    included), bit for bit."""
    if not compiled.CompiledTraceFollower(
        rounded_rectangle(800, 400, 120), [1.0], [0.0], 0.5, 40.0
    ).compiled:
        pytest.skip("this interpreter's hypot is not the kernels'")
    made: list[bool] = []
    fuse = PhysicalLog.fuse

    def spy(self: PhysicalLog, world: Any) -> Any:
        put = fuse(self, world)
        made.append(put is not None)
        return put

    keys = (
        "cross_track_cm", "separation_error_cm", "min_robot_distance_cm", "collisions",
        "clearance_violations", "per_follower",
    )  # fmt: skip
    ov = {"formation.followers": n}
    monkeypatch.setattr(PhysicalLog, "fuse", spy)
    fused = run_scenario("test2", duration_s=40, overrides=ov, record_jobs=False)
    monkeypatch.setattr(PhysicalLog, "fuse", lambda self, world: None)
    own = run_scenario("test2", duration_s=40, overrides=ov, record_jobs=False)
    assert made == [True]
    assert repr({k: fused.summary[k] for k in keys}) == repr({k: own.summary[k] for k in keys})
    assert fused.windows.equals(own.windows)
