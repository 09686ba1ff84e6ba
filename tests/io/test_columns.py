"""The column CSV writer gives the bytes of ``DataFrame.to_csv(index=False)`` (the writer that
rtsim's tables were written with before), on random tables and on the runs' own outputs.

pandas is the independent reference here: every case formats the same table both ways.
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rtsim.io.columns import ARROW_MIN, ARROW_RANGE, ChunkWriter, column_kind, csv_text, float_texts
from rtsim.sim.records import JOB_COLUMNS, RowBuffer, jobs_frame

ROOT = Path(__file__).resolve().parents[2]

#: Floats pandas and repr might disagree on if the writer were wrong: signed zero, the
#: exponent thresholds of the short form (1e16, 1e-5), subnormals, the extremes, NaN, inf.
EDGE = [
    0.0,
    -0.0,
    1e16,
    9999999999999998.0,
    1e15,
    1e-4,
    1e-5,
    0.0001234,
    5e-324,
    -5e-324,
    2.2250738585072014e-308,
    1.7976931348623157e308,
    -1.7976931348623157e308,
    math.inf,
    -math.inf,
    math.nan,
    0.1,
    1 / 3,
    100.0,
    1e22,
    123456789012345678.0,
    -1.5e-7,
]

floats = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from(EDGE))
texts = st.one_of(st.none(), st.text(alphabet=st.sampled_from('ab ,"\n\r;x:é'), max_size=6))


def _pandas(df: pd.DataFrame) -> str:
    return df.to_csv(index=False)


def _ours(df: pd.DataFrame) -> str | None:
    return csv_text(
        [df[c].to_numpy() for c in df.columns],
        [column_kind(t) for t in df.dtypes],
        list(df.columns),
    )


@settings(max_examples=150, deadline=None)
@given(data=st.data(), m=st.integers(0, 40))
def test_random_tables_give_pandas_bytes(data: st.DataObject, m: int) -> None:
    _random_table_gives_pandas_bytes(data, m)


def _random_table_gives_pandas_bytes(data: st.DataObject, m: int) -> None:
    f = data.draw(st.lists(floats, min_size=m, max_size=m))
    i = data.draw(st.lists(st.integers(-(2**63), 2**63 - 1), min_size=m, max_size=m))
    b = data.draw(st.lists(st.booleans(), min_size=m, max_size=m))
    s = data.draw(st.lists(texts, min_size=m, max_size=m))
    o = data.draw(st.lists(texts, min_size=m, max_size=m))
    df = pd.DataFrame(
        {
            "f": np.array(f, dtype=float),
            "i": np.array(i, dtype=np.int64),
            "b": np.array(b, dtype=bool),
            "s": pd.array(s, dtype="string"),
            "o": pd.Series(o, dtype=object),
            'with,"comma': np.array(f),
        }
    )
    assert [column_kind(t) for t in df.dtypes] == ["f", "i", "b", "s", "s", "f"]
    assert _ours(df) == _pandas(df)


@settings(max_examples=60, deadline=None)
@given(f=st.lists(floats, min_size=ARROW_MIN, max_size=400))
def test_long_float_columns_are_repr(f: list[float]) -> None:
    """A column long enough for Arrow's formatting gives repr's text, value by value."""
    a = np.array(f, dtype=float)
    assert float_texts(a) == list(map(repr, a.tolist()))


def test_floats_of_every_magnitude_are_repr() -> None:
    """Random doubles (random bits, and random digits at every power of ten from 1e-7 to
    1e17, both signs, whole numbers, the range's edges and their neighbours) through
    `float_texts` against repr: Arrow's digits and repr's agree, and the values Arrow
    writes in another form are left to repr."""
    rng = np.random.default_rng(36)
    lo, hi = ARROW_RANGE
    edges = [lo, hi, -lo, -hi, 1e15, 1e16, 1e-5, 2.0**53, 0.0, -0.0]
    near = [np.nextafter(x, d) for x in edges for d in (-math.inf, math.inf)]
    a = np.concatenate(
        [
            rng.integers(0, 2**63, 20_000, dtype=np.uint64).view(np.float64),
            rng.random(60_000) * 10.0 ** rng.integers(-7, 18, 60_000),
            -rng.random(20_000) * 10.0 ** rng.integers(-7, 18, 20_000),
            np.floor(rng.random(20_000) * 10.0 ** rng.integers(0, 17, 20_000)),
            np.round(rng.random(20_000) * 1e4, 3),
            np.array(edges + near + EDGE),
        ]
    )
    assert float_texts(a) == list(map(repr, a.tolist()))


@settings(max_examples=40, deadline=None)
@given(data=st.data(), m=st.integers(ARROW_MIN, ARROW_MIN + 150))
def test_long_random_tables_give_pandas_bytes(data: st.DataObject, m: int) -> None:
    """A table long enough to be formatted by Arrow: every kind of column, pandas' bytes."""
    _random_table_gives_pandas_bytes(data, m)


def test_edge_floats_one_by_one() -> None:
    df = pd.DataFrame({"x": np.array(EDGE), "y": -np.array(EDGE)})
    text = _ours(df)
    assert text == _pandas(df)
    assert text is not None
    lines = text.splitlines()
    assert lines[1:3] == ["0.0,-0.0", "-0.0,0.0"]  # the sign of zero kept
    assert lines[1 + EDGE.index(1e16)] == "1e+16,-1e+16"
    assert lines[1 + EDGE.index(1e-5)] == "1e-05,-1e-05"
    nan_row = 1 + next(k for k, x in enumerate(EDGE) if x != x)
    assert lines[nan_row] == ","  # NaN is an empty cell, not 'nan'
    assert "nan" not in text


def test_values_the_fast_path_does_not_know_go_to_pandas(tmp_path: Path) -> None:
    """Numbers in an object column, categoricals, a single column: pandas writes them."""
    for df in (
        pd.DataFrame({"a": [1.5, "x"], "b": [1, 2]}),
        pd.DataFrame({"a": pd.Categorical(["u", "v"]), "b": [1.0, 2.0]}),
        pd.DataFrame({"a": ["", "x"]}),
    ):
        w = ChunkWriter([tmp_path / "t.csv"], None)
        w.write(df)
        w.write(df)
        w.close()
        assert (tmp_path / "t.csv").read_text() == _pandas(pd.concat([df, df]))


def _job_rows(n: int, seed: int) -> list[tuple[object, ...]]:
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        r = float(rng.uniform(-1e3, 1e9)) * 10.0 ** int(rng.integers(-8, 8))
        skipped = bool(rng.random() < 0.2)
        f = math.nan if skipped else r + float(rng.exponential(10))
        out.append(
            (
                f"t{k % 3}",
                k,
                r,
                f,
                f,
                f - r,
                r + 50.0,
                50.0,
                skipped or f > r + 50,
                int(rng.integers(0, 4)),
                False,
                skipped,
                -0.0 if k % 5 == 0 else 1.0,
                r,
            )
        )
    return out


@pytest.mark.parametrize("chunk", [1, 7, 10_000])
def test_job_rows_streamed_as_tuples_equal_the_frame(tmp_path: Path, chunk: int) -> None:
    """A RowBuffer whose sink is a ChunkWriter hands it tuples: the CSV and the Parquet are
    those of the whole jobs_frame written by pandas."""
    rows = _job_rows(150, 3)
    w = ChunkWriter([tmp_path / "j.csv", tmp_path / "j.parquet"], jobs_frame([]))
    buf = RowBuffer(jobs_frame, w, chunk_rows=chunk)
    for r in rows:
        buf.append(r)
    buf.flush()
    w.close()
    whole = jobs_frame(rows)
    assert (tmp_path / "j.csv").read_text() == _pandas(whole)
    back = pd.read_parquet(tmp_path / "j.parquet")
    pd.testing.assert_frame_equal(back, whole)
    assert pq.ParquetFile(tmp_path / "j.parquet").num_row_groups == -(-150 // chunk)
    assert list(whole.columns) == list(JOB_COLUMNS)


def test_empty_tables(tmp_path: Path) -> None:
    w = ChunkWriter([tmp_path / "j.csv"], jobs_frame([]))
    w.close()
    assert (tmp_path / "j.csv").read_text() == _pandas(jobs_frame([]))
    w = ChunkWriter([tmp_path / "k.csv"], jobs_frame([]))
    w.write_rows([])
    w.close()
    assert (tmp_path / "k.csv").read_text() == _pandas(jobs_frame([]))


@pytest.mark.parametrize("scenario", ["test1", "test2"])
def test_scenario_windows_as_columns_equal_pandas(scenario: str) -> None:
    """Test 1 and Test 2's window table, formatted from its columns, is pandas' CSV of it."""
    from rtsim.coupling import run_scenario
    from rtsim.coupling.recorder import records_columns

    res = run_scenario(scenario, duration_s=120, seed=2, record_jobs=True)
    assert res.windows is not None and res.jobs is not None
    buf = io.StringIO()
    res.windows.to_csv(buf, index=False)
    cols = records_columns([], 2, ((0.0,) * 2,) * 4)  # the schema: arrays or lists of str
    df = res.windows
    kinds = [
        column_kind(df[c].dtype) if isinstance(cols[c], np.ndarray) else "s" for c in df.columns
    ]
    assert (
        csv_text([df[c].to_numpy() for c in df.columns], kinds, list(df.columns)) == buf.getvalue()
    )
    assert _ours(res.jobs) == _pandas(res.jobs)


def test_repeated_constant_and_whole_columns_give_pandas_bytes() -> None:
    """Float columns formatted once per distinct column and once per constant column, and
    the whole numbers' and the others' cells rewritten in one pass (mostly whole, a few
    whole among others, none): pandas' bytes."""
    m = 3 * ARROW_MIN
    rng = np.random.default_rng(3)
    x = rng.normal(0, 100, m)
    whole = np.round(rng.normal(0, 1e4, m))
    mixed = whole.copy()
    mixed[::7] = rng.choice(EDGE, len(mixed[::7]))  # (others: inf, nan, 1e16, tiny, -0.0)
    df = pd.DataFrame(
        {
            "x": x,
            "x_again": x.copy(),  # (the same bits: formatted once)
            "whole": whole,
            "mixed": mixed,
            "mixed_again": mixed.copy(),
            "c": np.full(m, 2.5),
            "zero": np.zeros(m),
            "neg_zero": np.full(m, -0.0),  # (equal to zero, not the same bits)
            "inf": np.full(m, math.inf),
            "nan": np.full(m, math.nan),
            "tiny": np.full(m, 1e-7),
            "i": np.arange(m),
        }
    )
    assert _ours(df) == _pandas(df)
    assert _ours(df.iloc[:1]) == _pandas(df.iloc[:1])


def test_mostly_whole_floats_are_repr() -> None:
    """Whole numbers of every magnitude below and around 1e16 (both signs, zeros, -0.0)
    as most of an array, the others among them: their texts (from the integers) and the
    others' are repr's; the same as columns of a table (each distinct value formatted
    once) give pandas' bytes."""
    rng = np.random.default_rng(45)
    whole = np.floor(rng.random(30_000) * 10.0 ** rng.integers(0, 17, 30_000))
    whole *= rng.choice([-1.0, 1.0], len(whole))
    edges = [0.0, -0.0, 1.0, -1.0, 9.0, 10.0, 1e15, 1e16, 9999999999999998.0, 2.0**53]
    a = np.concatenate([whole, np.array(edges * 50), rng.random(5_000) * 1e3, np.array(EDGE)])
    rng.shuffle(a)
    assert float_texts(a) == list(map(repr, a.tolist()))
    times = np.round(rng.random(4 * ARROW_MIN) * 40) * 40.0  # (repeated: formatted once)
    df = pd.DataFrame({"r": times, "d": times + 40.0, "z": np.where(times > 600, -0.0, 0.0)})
    df["x"] = np.where(np.arange(len(df)) % 9 == 0, times + 0.25, times)
    assert _ours(df) == _pandas(df)


def test_long_tables_with_cells_to_quote_give_pandas_bytes() -> None:
    """A long chunk whose strings need quotes (a comma, a quote, a line break) leaves Arrow's
    CSV writer, which refuses them, for the join: pandas' bytes either way."""
    m = 2 * ARROW_MIN
    x = np.linspace(0.1, 7.3, m)
    for odd in ("a,b", 'say "hi"', "two\nlines", "plain"):
        names = ["t1", odd] * (m // 2)
        df = pd.DataFrame({"task": pd.array(names, dtype="string"), "x": x, "k": np.arange(m)})
        assert _ours(df) == _pandas(df)


def test_a_writer_without_eol_falls_back_to_the_join(monkeypatch: pytest.MonkeyPatch) -> None:
    """pyarrow 14's CSV `WriteOptions` has no ``eol``: the rows are then joined as before,
    pandas' bytes still."""
    import pyarrow.csv as pcsv

    real = pcsv.WriteOptions

    def no_eol(*args: object, **kws: object) -> object:
        if "eol" in kws:
            raise TypeError("__init__() got an unexpected keyword argument 'eol'")
        return real(*args, **kws)

    m = 2 * ARROW_MIN
    df = pd.DataFrame({"x": np.linspace(0.1, 7.3, m), "k": np.arange(m)})
    want = _pandas(df)
    monkeypatch.setattr(pcsv, "WriteOptions", no_eol)
    assert _ours(df) == want
