"""Tables written in chunks: CSV appends and Parquet row groups, so a long run's records
never have to be in memory at once.

A `ChunkWriter` takes DataFrame chunks with one fixed schema and appends each to its
files (``.csv``: the header once, then rows; ``.parquet``: one row group per chunk through
``pyarrow.parquet.ParquetWriter``). The CSV bytes are exactly those of ``DataFrame.to_csv``
on the whole table (pandas formats each value on its own: the shortest repr of a float,
``True``/``False``, an empty cell for NaN); the Parquet file holds the same table and the
same pandas dtypes as ``DataFrame.to_parquet``, in row groups.

`read_columns` reads columns back, floats exactly (pandas 3's default parser;
``float_precision="round_trip"`` before), for summaries and figures drawn after the run.

CSV chunks are formatted by `csv_text`, not by pandas: each column is turned into
strings at once (a float by ``repr``, which is what pandas writes — numpy's ``str`` of a
float64 is the same shortest round-trip form —, NaN and None as empty cells, a string
quoted only when it holds a comma, a quote or a line break, as the ``csv`` module's
QUOTE_MINIMAL does) and the rows joined, which gives the bytes of ``to_csv`` several times
faster; from `ARROW_MIN` rows on, Arrow formats and joins the cells, and the joined rows'
data is written as it is (`csv_parts`). A producer that has its chunk as columns
(`ChunkWriter.write_columns`) or as row tuples (`ChunkWriter.write_rows`) skips the
DataFrame altogether; a column type the formatter does not know (categoricals, dates,
...) is written by pandas.
"""

from __future__ import annotations

import io
import os
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from rtsim.errors import InputError
from rtsim.io.atomic import naming

__all__ = ["ChunkWriter", "csv_parts", "csv_text", "float_texts", "iter_columns", "read_columns"]

#: Rows parsed at a time when a CSV is read back (the parser's buffers stay small).
READ_ROWS = 65536

#: pandas 3 parses floats exactly by default (and deprecates ``float_precision``).
_PANDAS_3 = int(pd.__version__.split(".")[0]) >= 3


def _special_chars() -> frozenset[str]:
    """The characters that make the csv module quote a field as pandas calls it (QUOTE_MINIMAL,
    lineterminator os.linesep); asked of the module, since it changed between Pythons (a
    lone carriage return is quoted from 3.12 on)."""
    import csv

    found = set()
    for c in map(chr, range(128)):
        buf = io.StringIO()
        csv.writer(buf, lineterminator=os.linesep, quoting=csv.QUOTE_MINIMAL).writerow([c, "a"])
        if buf.getvalue().startswith('"'):
            found.add(c)
    return frozenset(found)


#: Characters that make the csv module (QUOTE_MINIMAL) quote a field.
_SPECIAL = _special_chars()
_BOOL_TEXT = {True: "True", False: "False"}
_STR = {str}


def column_kind(dtype: Any) -> str | None:
    """How `csv_text` formats a column of ``dtype``: ``f`` float64, ``i`` int64,
    ``b`` bool, ``s`` strings (``string``, ``str`` or object holding str / None / NaN), or
    None (pandas formats it)."""
    if dtype == np.float64:
        return "f"
    if dtype == np.int64:
        return "i"
    if dtype == np.bool_:
        return "b"
    if dtype == np.object_ or pd.api.types.is_string_dtype(dtype):
        return "s"
    return None


def _quote(v: str) -> str:
    if _SPECIAL.isdisjoint(v):
        return v
    if '"' in v:
        v = v.replace('"', '""')
    return f'"{v}"'


#: From this many rows a chunk is formatted by Arrow (`_arrow_cells`; its calls cost a few
#: µs each, so a short chunk is formatted in Python).
ARROW_MIN = 64
#: Rows formatted by one round of Arrow calls (a chunk's text stays far below 2 GB).
ARROW_ROWS = 16384
#: The magnitudes [lo, hi) where Arrow's shortest form of a float is ``repr``'s, less the
#: ``.0`` that ``repr`` adds to a whole number (Arrow writes 1e-05 as 0.00001 and 1e10 as
#: 1e+10; ``repr`` switches to an exponent below 1e-4 and from 1e16 on).
ARROW_RANGE = (1e-4, 1e10)
#: Whole numbers below this magnitude are written from their integer: ``repr`` of one is
#: ``str(int(x)) + ".0"`` up to 1e16, where it turns to an exponent (-0.0 aside).
WHOLE_MAX = 1e16


def _whole_texts(x: NDArray[np.float64]) -> Any:
    """``repr`` of whole numbers below `WHOLE_MAX` as Arrow strings: the digits of ten
    times the integer (Arrow's integer cast, 2-3x faster than a float's) with a point put
    before the last one (``40.0`` from ``400``); zeros as ``0.0`` and ``-0.0``."""
    import pyarrow as pa
    import pyarrow.compute as pc

    digits = pc.cast(pa.array(x.astype(np.int64) * 10), pa.string())
    s = pc.binary_replace_slice(digits, -1, -1, ".")
    zero = x == 0.0
    if zero.any():  # (its digits "0" would give ".0")
        s = pc.if_else(pa.array(zero), "0.0", s)
        neg = zero & np.signbit(x)
        if neg.any():
            s = pc.if_else(pa.array(neg), "-0.0", s)
    return s


def _float_cells_of(a: NDArray[np.float64], nan: str | None) -> Any:
    """``repr`` of every value of ``a`` (float64) as an Arrow string array (NaN as ``nan``
    when given).

    Three kinds of values: a whole number below `WHOLE_MAX` by `_whole_texts`; another
    within `ARROW_RANGE` by Arrow's float-to-string cast, which writes the same shortest
    round-trip digits as ``repr`` (both give the shortest string that reads back as the
    same double, the closest one of them; the range is where it writes them in ``repr``'s
    form, whole numbers aside); any other (NaN, infinities, tiny or huge values) by
    ``repr``. The more common of the first two is formatted over the whole array, the
    values of the other kinds apart (this function again), and their texts put in their
    places by one ``take``. (Tested against ``repr`` on random doubles of every magnitude
    and on the runs' own columns.)"""
    import pyarrow as pa
    import pyarrow.compute as pc

    lo, hi = ARROW_RANGE
    m = np.abs(a)
    with np.errstate(invalid="ignore"):  # (a signalling NaN's floor)
        whole = (np.floor(a) == a) & (m < WHOLE_MAX)
    plain = (m >= lo) & (m < hi) & ~whole
    n_whole = int(np.count_nonzero(whole))
    n_plain = int(np.count_nonzero(plain))
    if not (n_whole or n_plain):
        texts = [repr(x) for x in a.tolist()]
        if nan is not None:
            texts = [nan if t == "nan" else t for t in texts]
        return pa.array(texts, pa.string())
    if n_plain >= n_whole:
        base, fix = pc.cast(pa.array(a), pa.string()), ~plain
    else:
        base, fix = _whole_texts(np.where(whole, a, 0.0)), ~whole
    n = len(a)
    k = n - max(n_whole, n_plain)
    if not k:
        return base
    sub = _float_cells_of(a[fix], nan)
    at = np.arange(n)
    at[fix] = np.arange(n, n + k)
    return pc.take(pa.concat_arrays([base, sub]), pa.array(at))


def _arrow_floats(a: NDArray[np.float64], nan: str | None) -> Any:
    """``repr`` of every value of ``a`` (float64) as an Arrow string array (NaN as ``nan``
    when given): `_float_cells_of`."""
    return _float_cells_of(a, nan)


def float_texts(a: NDArray[np.float64]) -> list[str]:
    """``repr`` of every value of ``a`` (float64), as ``list(map(repr, a.tolist()))`` gives
    it: by Arrow from `ARROW_MIN` values on (`_arrow_floats`, ≈ 2-3× faster)."""
    if len(a) < ARROW_MIN:
        return list(map(repr, a.tolist()))
    return _arrow_floats(a, None).to_pylist()  # type: ignore[no-any-return]


def _texts(values: Any, kind: str) -> list[str] | None:
    """One column as the strings ``to_csv`` writes (None: a value `csv_text` does not
    format exactly as pandas, e.g. a number in a string column)."""
    if kind == "f":
        a = np.asarray(values, dtype=np.float64)
        out = list(map(repr, a.tolist()))
        nan = np.isnan(a)
        if nan.any():
            for i in np.flatnonzero(nan).tolist():
                out[i] = ""
        return out
    if kind == "i":
        return list(map(str, np.asarray(values, dtype=np.int64).tolist()))
    if kind == "b":
        return list(map(_BOOL_TEXT.__getitem__, np.asarray(values, dtype=bool).tolist()))
    vals = values.tolist() if isinstance(values, np.ndarray) else list(values)
    try:
        distinct = set(vals)  # (a run's names: a few, checked once each)
    except TypeError:  # (an unhashable value: the loop below)
        distinct = {None}  # type: ignore[arg-type]
    if set(map(type, distinct)) == _STR:  # every value a str: written as it is
        if _SPECIAL.isdisjoint("".join(distinct)):
            return vals
        return [_quote(v) for v in vals]
    else:
        out = []
        for v in vals:
            if type(v) is str:
                out.append(v)
            elif v is None or v is pd.NA or (type(v) is float and v != v):
                out.append("")
            else:
                return None
    if not _SPECIAL.isdisjoint("".join(out)):
        out = [_quote(v) for v in out]
    return out


def _arrow_cells(values: Any, kind: str) -> Any:
    """One column as `_texts` gives it, as an Arrow string array (None as `_texts`):
    floats by `_arrow_floats`, integers by Arrow's cast (the digits ``str`` writes),
    booleans as True/False, strings by `_texts`."""
    import pyarrow as pa
    import pyarrow.compute as pc

    if kind == "f":
        return _arrow_floats(_array(values, np.float64), "")
    if kind == "i":
        return pc.cast(pa.array(_array(values, np.int64)), pa.string())
    if kind == "b":
        return pc.if_else(pa.array(_array(values, np.bool_)), "True", "False")
    t = _texts(values, kind)
    return None if t is None else pa.array(t, pa.string())


def _array(values: Any, dtype: Any) -> NDArray[Any]:
    """``np.asarray(values, dtype)``; a sequence of Python numbers (a column of row tuples)
    converted one value after another by ``np.fromiter`` (the same values, without numpy
    discovering the sequence's shape and types first: about half the instructions)."""
    if isinstance(values, np.ndarray):
        return np.asarray(values, dtype=dtype)
    try:
        return np.fromiter(values, dtype, len(values))
    except (TypeError, ValueError):  # (None in a float column, say: asarray's NaN)
        return np.asarray(values, dtype=dtype)


def _arrow_block(columns: Sequence[Any], kinds: Sequence[str], sep: str) -> Any:
    """The rows of `csv_text` for ``columns`` (without the header) as UTF-8 bytes (an Arrow
    buffer): each column's cells (`_arrow_cells`) and the rows joined by Arrow, each row
    ended by ``sep``, the joined strings' data being the text itself; None as
    `csv_text`."""
    import pyarrow as pa
    import pyarrow.compute as pc

    floats = [i for i, k in enumerate(kinds) if k == "f"]
    done: dict[int, Any] = {}
    if len(floats) > 1:  # every float column formatted in one call (the calls cost more
        done = _float_cells(columns, floats)  # than the cells), then sliced (no copy)
    cells = []
    for i, (values, kind) in enumerate(zip(columns, kinds, strict=True)):
        c = done[i] if i in done else _arrow_cells(values, kind)
        if c is None:
            return None
        cells.append(c)
    try:  # (Arrow's CSV writer puts the cells as they are: half the join's time)
        return _written(cells, sep)
    except pa.ArrowInvalid:  # (a quoted cell, or an older pyarrow: `_written`)
        pass
    cells[-1] = pc.binary_join_element_wise(cells[-1], "", sep)  # (the last cell, sep)
    rows = pc.binary_join_element_wise(*cells, ",")
    _, offsets, data = rows.buffers()
    at = np.frombuffer(offsets, dtype=np.int32)[[rows.offset, rows.offset + len(rows)]]
    return data.slice(int(at[0]), int(at[1] - at[0]))


def _written(cells: list[Any], sep: str) -> Any:
    """The rows of ``cells`` (Arrow strings, one array per column, no nulls) joined by
    commas, each ended by ``sep``, as Arrow's CSV writer writes them without quoting (the
    cells as they are: the bytes of `_arrow_block`'s join); raises ``ArrowInvalid`` for a
    cell holding a quote, a comma or a line break, and where the writer cannot end rows by
    ``sep`` (an older pyarrow's `WriteOptions` has no ``eol``)."""
    import pyarrow as pa
    import pyarrow.csv as pcsv

    try:
        options = pcsv.WriteOptions(include_header=False, quoting_style="none", eol=sep)
    except TypeError as e:  # (pyarrow 14: no eol)
        raise pa.ArrowInvalid(str(e)) from e
    table = pa.Table.from_arrays(cells, names=[str(i) for i in range(len(cells))])
    out = pa.BufferOutputStream()
    pcsv.write_csv(table, out, options)
    return out.getvalue()


def _float_cells(columns: Sequence[Any], floats: list[int]) -> dict[int, Any]:
    """The cells of the float columns ``floats`` of ``columns`` (index -> Arrow strings),
    formatted in one `_float_cells_of` call: each distinct column once (the same bits give
    the same text: a copy of another column is its slice again) and a column of one value
    by that value, repeated (a run's constant columns, the jobs' arrival and release);
    values mostly whole (the jobs' times: a job's deadline is often the next one's
    release) each distinct one once, put in place by a ``take``."""
    import pyarrow as pa
    import pyarrow.compute as pc

    n = len(columns[0])
    arrays = [_array(columns[i], np.float64) for i in floats]
    keys = [a.tobytes() for a in arrays]
    slot: dict[bytes, tuple[int, int]] = {}  # (offset in the formatted values, how many)
    todo = []
    off = 0
    for a, key in zip(arrays, keys, strict=True):
        if key in slot:
            continue
        bits = a.view(np.int64)
        m = 1 if n and bool((bits == bits[0]).all()) else n
        slot[key] = (off, m)
        todo.append(a[:m])
        off += m
    a = np.concatenate(todo)
    with np.errstate(invalid="ignore"):  # (a signalling NaN's floor)
        repeats = 2 * int(np.count_nonzero(np.floor(a) == a)) > len(a)
    if repeats:  # mostly whole numbers (times on a grid): each distinct value once
        enc = pc.dictionary_encode(pa.array(a.view(np.int64)))  # (by bits: -0.0 is not 0.0)
        s = pc.take(_arrow_floats(enc.dictionary.to_numpy().view(np.float64), ""), enc.indices)
    else:
        s = _arrow_floats(a, "")
    made = {key: s.slice(o, n) if m == n else pa.repeat(s[o], n) for key, (o, m) in slot.items()}
    return {i: made[key] for i, key in zip(floats, keys, strict=True)}


def _each(columns: Sequence[Any], kinds: Sequence[str], cells: Any) -> list[Any] | None:
    """Every column's cells by ``cells`` (`_texts` or `_arrow_cells`); None if one is."""
    out = []
    for values, kind in zip(columns, kinds, strict=True):
        c = cells(values, kind)
        if c is None:
            return None
        out.append(c)
    return out


def csv_text(
    columns: Sequence[Any], kinds: Sequence[str], header: Sequence[str] | None = None
) -> str | None:
    """The rows (and ``header``, when given) of ``DataFrame.to_csv(index=False)`` for
    ``columns`` (equal-length sequences or arrays, one per column) of `column_kind`
    ``kinds``; None when a value is not one the fast path formats exactly (the caller then
    uses pandas)."""
    parts = csv_parts(columns, kinds, header)
    return None if parts is None else b"".join(parts).decode("utf-8")


def csv_parts(
    columns: Sequence[Any], kinds: Sequence[str], header: Sequence[str] | None = None
) -> list[Any] | None:
    """`csv_text` as UTF-8 bytes, in parts (bytes-like objects: Arrow's own buffers, not
    copied) to write one after another."""
    sep = os.linesep
    if len(columns) < 2:  # a lone empty field is quoted by the csv module: leave it to pandas
        return None
    n = len(columns[0])
    parts: list[Any] = []
    if header is not None:
        parts.append((",".join(_quote(str(h)) for h in header) + sep).encode("utf-8"))
    if n < ARROW_MIN:
        texts = _each(columns, kinds, _texts)
        if texts is None:
            return None
        if n:
            parts.append((sep.join(map(",".join, zip(*texts, strict=True))) + sep).encode())
    else:  # (by Arrow, ARROW_ROWS rows at a time: its strings hold up to 2 GB)
        for i in range(0, n, ARROW_ROWS):
            part = _arrow_block([c[i : i + ARROW_ROWS] for c in columns], kinds, sep)
            if part is None:
                return None
            parts.append(part)
    return parts


class ChunkWriter:
    """Append DataFrame chunks to one or more files (``.csv`` / ``.parquet``).

    ``paths``: where to write (the temporary paths of a staged output); ``empty``: a
    zero-row DataFrame with the table's columns and dtypes, written if no chunk comes (None:
    the producer sets `empty` before `close`).
    Call `write` per chunk and `close` once; ``rows`` counts what was written.
    """

    def __init__(self, paths: Sequence[str | os.PathLike[str]], empty: pd.DataFrame | None) -> None:
        self.paths = [Path(p) for p in paths]
        for p in self.paths:
            if p.suffix.lower() not in (".csv", ".parquet"):
                raise InputError(f"{p}: output must end in .csv or .parquet")
        self.empty = empty
        self.rows = 0
        self.chunks = 0
        self._parquet: dict[Path, Any] = {}
        self._handles: list[Any] = []
        self._closed = False
        self._kind_cache: list[str | None] | None = None
        import pyarrow.csv  # noqa: F401 (`_written`'s writer, loaded with the writer, ≈ 7 ms)

    def write(self, df: pd.DataFrame) -> None:
        """Append one chunk (columns and dtypes as ``empty``)."""
        if self.empty is not None and list(df.columns) != list(self.empty.columns):
            raise ValueError("chunk columns differ from the table's")
        self._append(
            df,
            lambda: [df[c].to_numpy() for c in df.columns],
            [column_kind(t) for t in df.dtypes],
            len(df),
        )

    def write_columns(self, columns: Mapping[str, Any]) -> None:
        """Append one chunk given as columns (name -> numpy array, or a list of strings, in
        ``empty``'s order): the same file as `write` of ``DataFrame(columns)``, without
        building that frame for a CSV."""
        names = self._names(columns)
        rows = len(next(iter(columns.values()))) if names else 0
        kinds = [
            column_kind(v.dtype) if isinstance(v, np.ndarray) else "s" for v in columns.values()
        ]
        self._append(
            lambda: pd.DataFrame(columns, columns=names),
            lambda: [columns[c] for c in names],
            kinds,
            rows,
        )

    def write_rows(self, rows: Sequence[tuple[Any, ...]]) -> None:
        """Append one chunk given as row tuples in ``empty``'s column order: the same file
        as `write` of ``DataFrame(rows).astype(empty.dtypes)``."""
        assert self.empty is not None, "ChunkWriter.write_rows needs the empty table"
        names = list(self.empty.columns)
        dtypes = dict(self.empty.dtypes)
        self._append(
            lambda: pd.DataFrame(list(rows), columns=names).astype(dtypes),
            lambda: list(zip(*rows, strict=True)) if rows else [()] * len(names),
            self._kinds(),
            len(rows),
        )

    def _names(self, columns: Mapping[str, Any]) -> list[str]:
        if self.empty is None:
            raise ValueError("ChunkWriter: the empty table (the schema) is not set")
        names = list(self.empty.columns)
        if list(columns) != names:
            raise ValueError("chunk columns differ from the table's")
        return names

    def _kinds(self) -> list[str | None]:
        if self._kind_cache is None:
            assert self.empty is not None
            self._kind_cache = [column_kind(t) for t in self.empty.dtypes]
        return self._kind_cache

    def _append(self, frame: Any, columns: Any, kinds: list[str | None], rows: int) -> None:
        """Write one chunk: ``frame`` a DataFrame or a function making it (pandas' CSV path,
        Parquet), ``columns`` a function giving the columns for `csv_text`."""
        df = frame if isinstance(frame, pd.DataFrame) else None
        text: list[Any] | None = None
        tried = None in kinds
        for p in self.paths:
            with naming(p):
                df, text, tried = self._append_to(p, df, frame, columns, kinds, text, tried)
        self.rows += rows
        self.chunks += 1

    def _append_to(
        self,
        p: Path,
        df: Any,
        frame: Any,
        columns: Any,
        kinds: list[str | None],
        text: list[Any] | None,
        tried: bool,
    ) -> tuple[Any, list[Any] | None, bool]:
        """One file's part of `_append`; returns (the frame, the CSV text, tried)."""
        if p.suffix.lower() == ".csv":
            if not tried:
                tried = True
                header = None
                if self.chunks == 0:
                    table = self.empty if df is None else df
                    assert table is not None  # (the empty table, or the frame written)
                    header = list(table.columns)
                text = csv_parts(columns(), kinds, header)  # type: ignore[arg-type]
            if text is not None:
                with open(p, "wb" if self.chunks == 0 else "ab") as fb:
                    for part in text:
                        fb.write(part)
            else:
                with open(p, "w" if self.chunks == 0 else "a", encoding="utf-8", newline="") as fh:
                    if df is None:
                        df = frame()
                    df.to_csv(fh, index=False, header=self.chunks == 0)
        else:
            if df is None:
                df = frame()
            self._write_parquet(p, df)
        return df, text, tried

    def _write_parquet(self, p: Path, df: pd.DataFrame) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.Table.from_pandas(df, preserve_index=False)
        writer = self._parquet.get(p)
        if writer is None:
            # the first chunk's schema, as to_parquet infers it for the whole table (string
            # columns held as objects have no type in an empty frame)
            # (a file Python opened: pyarrow takes a path only as UTF-8)
            fh = open(p, "wb")  # noqa: SIM115 - closed in close() or discard()
            self._handles.append(fh)
            writer = pq.ParquetWriter(fh, table.schema)
            self._parquet[p] = writer
        writer.write_table(table.cast(writer.schema))

    def close(self) -> None:
        """Finish the files (an empty table if no chunk was written) and fsync them."""
        if self._closed:
            return
        if self.chunks == 0:
            if self.empty is None:
                raise ValueError("ChunkWriter.close: no chunk and no empty table")
            self.write(self.empty)

        for p, w in self._parquet.items():
            with naming(p):
                w.close()
        for fh in self._handles:
            fh.close()
        for p in self.paths:
            with naming(p), open(p, "rb+") as fh:
                os.fsync(fh.fileno())
        self._closed = True

    def discard(self) -> None:
        """Close the files without finishing them (after an error: the run's staging is
        removed), so that no descriptor stays open on them."""
        for w in self._parquet.values():
            try:
                w.close()
            except Exception:  # noqa: S110 - a full disk, say: the file is dropped anyway
                pass
        for fh in self._handles:
            try:
                fh.close()
            except OSError:
                pass
        self._parquet, self._handles = {}, []
        self._closed = True

    def read(
        self, columns: Sequence[str] | None = None, dtypes: dict[str, Any] | None = None
    ) -> pd.DataFrame:
        """Columns of the table written (after `close`), from its first file."""
        return read_columns(self.paths[0], columns, dtypes)

    def iter_read(
        self, columns: Sequence[str] | None = None, chunk_rows: int = READ_ROWS
    ) -> Iterator[pd.DataFrame]:
        """The same columns as `read`, ``chunk_rows`` rows at a time (memory does
        not grow with the table)."""
        p = Path(self.paths[0])
        if p.suffix.lower() != ".parquet":
            yield from iter_columns(p, columns, chunk_rows)
            return
        import pyarrow.parquet as pq

        with open(p, "rb") as fh:  # (pyarrow takes a path only as UTF-8)
            pf = pq.ParquetFile(fh)
            cols = list(columns) if columns is not None else None
            for batch in pf.iter_batches(batch_size=chunk_rows, columns=cols):
                yield batch.to_pandas()


def iter_columns(
    path: str | os.PathLike[str],
    columns: Sequence[str] | None = None,
    chunk_rows: int = READ_ROWS,
    dtypes: dict[str, Any] | None = None,
) -> Iterator[pd.DataFrame]:
    """Columns of a CSV written by `ChunkWriter` (floats exact), ``chunk_rows`` rows
    at a time (row labels continue across chunks)."""
    exact: dict[str, Any] = {} if _PANDAS_3 else {"float_precision": "round_trip"}
    with pd.read_csv(
        Path(path),
        usecols=list(columns) if columns is not None else None,
        dtype=dtypes,
        keep_default_na=False,
        na_values=[""],
        chunksize=chunk_rows,
        **exact,
    ) as reader:
        yield from reader


def read_columns(
    path: str | os.PathLike[str],
    columns: Sequence[str] | None = None,
    dtypes: dict[str, Any] | None = None,
) -> pd.DataFrame:
    """Columns of a CSV written by `ChunkWriter` (floats exact, parsed in chunks of
    `READ_ROWS` rows), or of a Parquet file."""
    p = Path(path)
    if p.suffix.lower() == ".parquet":
        with open(p, "rb") as fh:  # (pyarrow takes a path only as UTF-8)
            return pd.read_parquet(fh, columns=list(columns) if columns is not None else None)
    parts = list(iter_columns(p, columns, READ_ROWS, dtypes))
    if len(parts) == 1:
        return parts[0]
    return pd.concat(parts, ignore_index=True)
