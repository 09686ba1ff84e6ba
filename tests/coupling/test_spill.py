"""Exact percentiles from spilled samples (rtsim.coupling.spill; issue 35 item 11).

The summary's p95 and maxima of the separation error, the cross-track distance and the
fixes' error are selected from samples appended to a scratch file and read back in chunks;
they must be numpy's ``percentile(v, 95)`` and ``max`` of the whole arrays to the bit
(`p95_max_rows` and plain numpy calls are the independent side), whatever the chunking and
however early the selection stops refining. The scratch files go with the run: removed on
success and on an exception, and, after ``kill -9``, with the staging directory the next run
clears.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import rtsim.coupling.spill as spill
from rtsim.cli import main
from rtsim.coupling import run_scenario
from rtsim.coupling.physical import p95_max_rows
from rtsim.coupling.spill import ValueSpill, p95_max_columns, percentile95

ROOT = Path(__file__).resolve().parents[2]
TEST2 = ROOT / "experiments" / "scenarios" / "test2.toml"


def plain(v: Any) -> dict[str, float] | None:
    """p95 and max by one numpy call each (None: no values)."""
    a = np.asarray(v, dtype=float)
    return {"p95": float(np.percentile(a, 95)), "max": float(a.max())} if a.size else None


def same(a: Any, b: Any) -> bool:
    """Equal to the bit, NaN equal to NaN (repr of floats is exact)."""
    return repr(a) == repr(b)


def _data(rng: np.random.Generator, kind: int, rows: int, width: int) -> np.ndarray:
    if kind == 0:  # spread
        return rng.random((rows, width)) * 300.0
    if kind == 1:  # many ties
        return rng.integers(0, 4, (rows, width)).astype(float)
    if kind == 2:  # many magnitudes, exponents of both signs
        return np.exp(rng.normal(0.0, 20.0, (rows, width)))
    return rng.normal(0.0, 1.0, (rows, width))  # negatives


@pytest.mark.parametrize("direct", [0, spill.DIRECT_ROWS])
@pytest.mark.parametrize("limit", [0, 5, 1_000, spill.COLLECT_LIMIT])
@pytest.mark.filterwarnings("ignore:invalid value:RuntimeWarning")  # inf - inf, as numpy
def test_selected_percentiles_are_numpys(
    monkeypatch: pytest.MonkeyPatch, limit: int, direct: int
) -> None:
    """Random tables of odd sizes (1 row, primes, a chunk's length ± 1), ties, negative
    values, infinities and NaN, read in chunks of random lengths: every column's and all
    columns' p95/max equal numpy's on the whole arrays; ``limit`` 0 refines all 64 bits;
    ``direct`` 0 selects by the radix passes at every size, else tables up to that many
    rows by one partition."""
    monkeypatch.setattr(spill, "COLLECT_LIMIT", limit)
    monkeypatch.setattr(spill, "DIRECT_ROWS", direct)
    rng = np.random.default_rng(35 + limit)
    for trial in range(60):
        width = int(rng.integers(1, 5))
        rows = int(rng.choice([0, 1, 2, 3, 19, 97, 128, 129, 1_000, 4_095, 4_096, 4_097, 8_193]))
        data = _data(rng, trial % 4, rows, width)
        if rows and trial % 5 == 0:
            data[rng.integers(0, rows), 0] = np.inf
        if rows and trial % 7 == 0:
            data[rng.integers(0, rows), width - 1] = np.nan
        step = int(rng.integers(1, 600))

        def chunks(data: np.ndarray = data, step: int = step) -> Any:
            return (data[i : i + step] for i in range(0, len(data), step))

        cols = [data[:, j] for j in range(width)]
        got = p95_max_columns(chunks, width)
        assert same(got, p95_max_rows(cols))
        assert same(got[0], plain(data.ravel())) and same(got[1], [plain(c) for c in cols])
        finite = [c[np.isfinite(c)] for c in cols]
        got = p95_max_columns(chunks, width, finite_only=True)
        assert same(got, (plain(np.concatenate(finite)), [plain(c) for c in finite]))


def test_the_direct_selection_is_the_passes_with_signed_zeros(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """-0.0 and 0.0 mixed (the keys take -0.0 as 0.0): the selection in memory gives what
    the radix passes give, to the bit, at every p95 position among them."""
    rng = np.random.default_rng(3)
    for rows in (2, 20, 41, 300):
        data = np.where(rng.random((rows, 2)) < 0.5, -0.0, 0.0)
        data[rng.integers(0, rows), 1] = 1.0

        def chunks(data: np.ndarray = data) -> Any:
            return (data[i : i + 7] for i in range(0, len(data), 7))

        monkeypatch.setattr(spill, "DIRECT_ROWS", 0)
        passes = p95_max_columns(chunks, 2)
        monkeypatch.setattr(spill, "DIRECT_ROWS", 10_000)
        assert same(p95_max_columns(chunks, 2), passes)


def test_the_interpolation_is_numpys_at_every_size() -> None:
    """`percentile95` from the two order statistics equals numpy's percentile for every
    count up to 2,000 (each fraction of the virtual index, both sides of γ = 0.5)."""
    rng = np.random.default_rng(7)
    for count in range(1, 2_001):
        v = rng.normal(50.0, 30.0, count)
        s = np.sort(v)
        assert percentile95(count, lambda k, s=s: float(s[k]), float(s[-1])) == float(
            np.percentile(v, 95)
        )


def test_a_file_backed_spill_gives_back_its_rows_and_removes_its_file(tmp_path: Path) -> None:
    """Rows appended one value at a time and in blocks (across the buffer's length) come
    back in order, in chunks no longer than asked, from the file as from memory; `close`
    removes the file."""
    rng = np.random.default_rng(3)
    rows = rng.random((2 * spill.SPILL_ROWS + 17, 3))
    path = tmp_path / ".rtsim-spool-test"
    kept, filed = ValueSpill(3), ValueSpill(3, path)
    for s in (kept, filed):
        for r in rows[:100]:  # the loop's way: values appended, then `full`
            s.buf.extend(r.tolist())
            s.full()
        s.add_rows(rows[100:])
    assert path.exists() and path.stat().st_size >= 2 * spill.SPILL_ROWS * 3 * 8
    for s in (kept, filed):
        parts = list(s.chunks(1_000))
        assert max(len(p) for p in parts) <= 1_000
        assert np.array_equal(np.concatenate(parts), rows)
    filed.close()
    assert not path.exists()


def test_the_run_spills_and_removes_its_scratch_files(tmp_path: Path) -> None:
    """A run with a scratch directory gives the summary of a run without one, byte for
    byte, and leaves nothing there; an exception mid-run (an interrupt) removes the file."""
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    seen: list[list[str]] = []

    def look(share: float, t_ms: float) -> None:
        seen.append(sorted(p.name for p in scratch.iterdir()))

    kept = run_scenario("test2", duration_s=120.0, record_jobs=False)
    filed = run_scenario(
        "test2", duration_s=120.0, record_jobs=False, scratch_dir=scratch, progress=look
    )
    assert json.dumps(kept.summary) == json.dumps(filed.summary)
    assert any(any(n.endswith("-physical") for n in names) for names in seen)
    assert list(scratch.iterdir()) == []

    def stop(share: float, t_ms: float) -> None:
        if share > 0.5:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_scenario(
            "test2", duration_s=120.0, record_jobs=False, scratch_dir=scratch, progress=stop
        )
    assert list(scratch.iterdir()) == []


def _spools(d: Path) -> list[Path]:
    return [p for p in d.rglob(".rtsim-spool-*")]


@pytest.mark.slow
def test_a_killed_runs_scratch_file_is_cleared_by_the_next_run(tmp_path: Path) -> None:
    """``kill -9`` while the loop writes its samples leaves the scratch file in the killed
    run's staging directory; the next run into the same place removes it with the staging
    directory, and a complete run leaves none in its output."""
    out = tmp_path / "run"
    assert (
        main(["scenario", str(TEST2), "--duration", "20", "--no-figures", "-q", "--out", str(out)])
        == 0
    )
    assert _spools(tmp_path) == []
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "rtsim",
            "scenario",
            str(TEST2),
            "--duration",
            "3600",
            "--no-figures",
            "-q",
            "--out",
            str(out),
        ],
        cwd=ROOT,
        env={**os.environ, "MPLBACKEND": "Agg"},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 120.0
        while not _spools(tmp_path) and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.05)
        left = _spools(tmp_path)
        assert left and all(p.parent.name.startswith(".run.rtsim-") for p in left)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    assert _spools(tmp_path)  # the killed run's file is still there
    assert (
        main(["scenario", str(TEST2), "--duration", "20", "--no-figures", "-q", "--out", str(out)])
        == 0
    )
    assert _spools(tmp_path) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]
