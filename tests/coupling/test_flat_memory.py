"""The post-run writers of ``rtsim scenario`` hold a bounded chunk whatever the run's length
(issue 35, item 11). followers.csv was built from windows.csv read back 20,000 windows at a
time: a run shorter than that (an hour with 8 followers is ~12,000 windows) was one chunk,
and its long frame and CSV text grew the peak by ~300 MB between 10 min and 1 h."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from traced import traced_peak as _peak

import rtsim.coupling.scenario_run as scenario_run
from rtsim.cli.scenario import FOLLOWER_CHUNK_ROWS, _write_followers
from rtsim.config.scenario import load_scenario
from rtsim.coupling import run_scenario
from rtsim.coupling.tidy import follower_count, followers_frame
from rtsim.io.columns import ChunkWriter

ROOT = Path(__file__).resolve().parents[2]
TEST2 = ROOT / "experiments" / "scenarios" / "test2.toml"
N = 8


@pytest.fixture(scope="module")
def windows() -> pd.DataFrame:
    sc = load_scenario(TEST2, overrides={"formation.followers": N})
    res = run_scenario(sc, duration_s=10, record_jobs=False)
    assert res.windows is not None and len(res.windows) > 20
    return res.windows


def _windows_csv(df: pd.DataFrame, rows: int, path: Path) -> Path:
    """A windows.csv of ``rows`` rows: the run's rows repeated (window numbers renumbered)."""
    reps = -(-rows // len(df))
    big = pd.concat([df] * reps, ignore_index=True).iloc[:rows].copy()
    big["window"] = range(1, rows + 1)
    big.to_csv(path, index=False)
    return path


def test_follower_count_reads_the_wide_header(windows: pd.DataFrame) -> None:
    assert follower_count(windows.columns) == N
    assert follower_count(["window", "t", "w"]) == 0


@pytest.mark.slow
def test_followers_csv_peak_does_not_grow_with_the_run(
    windows: pd.DataFrame, tmp_path: Path
) -> None:
    """Writing followers.csv from a windows.csv one chunk long, and from one four chunks
    long: the traced peak grows by less than a tenth (it grew ~4x when the file was one
    chunk); the long file's followers.csv is the long-form table of the whole file."""
    chunk = FOLLOWER_CHUNK_ROWS // N
    short = _windows_csv(windows, chunk, tmp_path / "short.csv")
    long = _windows_csv(windows, 4 * chunk, tmp_path / "long.csv")
    p_short = _peak(lambda: _write_followers(short, tmp_path / "f_short.csv"))
    p_long = _peak(lambda: _write_followers(long, tmp_path / "f_long.csv"))
    assert p_long < 1.1 * p_short, (p_short, p_long)
    got = pd.read_csv(tmp_path / "f_long.csv")
    want = followers_frame(pd.read_csv(long))
    assert len(got) == 4 * chunk * N
    pd.testing.assert_frame_equal(got, want)


def test_the_summary_reads_the_windows_back_in_bounded_chunks(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, windows: pd.DataFrame
) -> None:
    """With a window sink, `summarize` is given chunks of at most SUMMARY_READ_ROWS rows,
    and its summary is the in-memory run's."""
    sc = load_scenario(TEST2, overrides={"formation.followers": N})
    ref = run_scenario(sc, duration_s=10, record_jobs=False)
    seen: list[int] = []
    real = scenario_run.summarize

    def spy(table, **kw):  # type: ignore[no-untyped-def]
        def chunks():  # type: ignore[no-untyped-def]
            for c in table:
                seen.append(len(c))
                yield c

        return real(chunks(), **kw)

    monkeypatch.setattr(scenario_run, "SUMMARY_READ_ROWS", 7)
    monkeypatch.setattr(scenario_run, "summarize", spy)
    sink = ChunkWriter([tmp_path / "windows.csv"], None)
    res = run_scenario(sc, duration_s=10, record_jobs=False, window_sink=sink)
    assert seen and max(seen) <= 7 and sum(seen) == len(windows)
    for key in ("windows", "missed", "violations", "critical_share", "min_msb_over_wsch"):
        assert res.summary[key] == ref.summary[key], key
