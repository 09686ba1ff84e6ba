"""The scenario's summary is computed from its window columns read back in chunks (issue 35,
item 11: the whole read-back grew a coupled run with 10 followers and every output by 73 MB
over one simulated hour). Any chunking gives the summary of the whole table."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rtsim.cli import main
from rtsim.config.scenario import load_scenario
from rtsim.coupling import run_scenario
from rtsim.coupling.summary import summarize, summary_columns

ROOT = Path(__file__).resolve().parents[2]
TEST2 = ROOT / "experiments" / "scenarios" / "test2.toml"
#: the most followers Test 2 admits with its clearance (9 and 10 are refused before the run)
N = 8


@pytest.fixture(scope="module")
def ten_followers() -> tuple[pd.DataFrame, dict]:
    sc = load_scenario(TEST2, overrides={"formation.followers": N})
    res = run_scenario(sc, duration_s=20, record_jobs=False)
    assert res.windows is not None and len(res.windows) > 40
    return res.windows, res.summary


def _again(df: pd.DataFrame | list, n: int) -> dict:
    return summarize(df, mode="m", w_sch=1.0, duration_s=1.0, seed=0, scenario="s", n=n)


@pytest.mark.parametrize("rows", [1, 2, 7, 64, 10_000])
def test_any_chunking_gives_the_whole_tables_summary(ten_followers, rows: int) -> None:
    df, _ = ten_followers
    cols = df[summary_columns(N)]
    whole = _again(cols, N)
    parts = [cols.iloc[i : i + rows] for i in range(0, len(cols), rows)]
    assert _again(parts, N) == whole
    assert _again(iter(parts), N) == whole  # a generator, read once
    # NaN in a late chunk's minimum, and a chunk with no finished response
    bad = cols.copy()
    bad.loc[bad.index[-1], "msb_min"] = np.nan
    bad["response"] = np.nan
    parts = [bad.iloc[i : i + rows] for i in range(0, len(bad), rows)]
    got, want = _again(parts, N), _again(bad, N)
    assert np.isnan(got["min_msb_over_wsch"]) and np.isnan(want["min_msb_over_wsch"])
    assert np.isnan(got["max_response"]) and np.isnan(want["max_response"])


def test_an_empty_table_gives_the_empty_summary(ten_followers) -> None:
    df, _ = ten_followers
    empty = df[summary_columns(N)].iloc[:0]
    assert json.dumps(_again([], N), default=str) == json.dumps(_again(empty, N), default=str)


@pytest.mark.parametrize("parquet", [False, True])
def test_the_cli_summary_read_back_in_chunks_equals_the_librarys(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, ten_followers, parquet: bool
) -> None:
    """The command line writes the windows as it goes and reads them back in chunks (here
    of 5 rows, CSV and Parquet): summary.json is the in-memory run's summary."""
    import rtsim.io.columns as columns

    monkeypatch.setattr(columns, "READ_ROWS", 5)
    monkeypatch.setattr(
        columns.ChunkWriter,
        "iter_read",
        lambda self, cols=None, chunk_rows=5, f=columns.ChunkWriter.iter_read: f(self, cols, 5),
    )
    out = tmp_path / "run"
    argv = ["scenario", str(TEST2), "--duration", "20", "--no-figures", "--out", str(out)]
    argv += ["--set", f"formation.followers={N}"] + (["--parquet"] if parquet else [])
    assert main(argv) == 0
    got = json.loads((out / "summary.json").read_text())
    _, want = ten_followers
    for key in (
        "windows",
        "missed",
        "violations",
        "critical_share",
        "methods",
        "binding_critical",
        "min_msb_over_wsch",
        "min_speed_ratio",
        "max_response",
        "tracks_lost_by_cause",
        "infeasible",
    ):
        assert got[key] == want[key], key  # (floats through JSON: exact)
