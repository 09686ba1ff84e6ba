"""`records_columns` reads a chunk's records in a few passes: the per-record paths it
replaced give the same values (the records' segments at their arc lengths, the fields a
record made by hand leaves empty)."""

from __future__ import annotations

import math
import random

import numpy as np

from rtsim.coupling.recorder import _path_segments, _rows, _rows_or
from rtsim.world.path import LeaderPath, Straight, Turn


def test_segments_at_once_equal_segment_at() -> None:
    path = LeaderPath(
        [Straight(100), Turn("left", 50, math.pi), Straight(100), Turn("left", 50, math.pi)]
    )
    rng = random.Random(3)
    lap = path.lap_length
    starts = np.cumsum([0.0] + [seg.length for seg in path.segments]).tolist()
    s = [rng.uniform(0, 5 * lap) for _ in range(500)]
    s += starts + [x + k * lap for x in starts for k in (1, 2, 7)]
    s += [math.nextafter(x, -math.inf) for x in s[-40:]] + [0.0, lap, -0.0]
    kinds, kappas = _path_segments(path, np.array(s))
    want = [path.segment_at(x) for x in s]
    assert kinds == [k for k, _ in want]
    assert np.array(kappas).tobytes() == np.array([v for _, v in want]).tobytes()


class _Rec:
    def __init__(self, fix_error: object) -> None:
        self.fix_error = fix_error


def test_rows_or_takes_the_default_where_a_record_has_none() -> None:
    n = 3
    inf = (math.inf,) * n
    for held in ([[1.0, 2.0, 3.0]] * 4, [[1.0, 2.0, 3.0], None, [4.0, 5.0, 6.0]], [(), ()]):
        recs = [_Rec(v) for v in held]
        got = _rows_or(recs, "fix_error", inf, float)  # type: ignore[arg-type]
        want = _rows((r.fix_error or inf for r in recs), float, len(recs), n)
        assert got.tobytes() == want.tobytes()
