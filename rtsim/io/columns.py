"""Tables written in chunks: CSV appends and Parquet row groups, so a long run's records
never have to be in memory at once.

A :class:`ChunkWriter` takes DataFrame chunks with one fixed schema and appends each to its
files (``.csv``: the header once, then rows; ``.parquet``: one row group per chunk through
``pyarrow.parquet.ParquetWriter``). The CSV bytes are exactly those of ``DataFrame.to_csv``
on the whole table (pandas formats each value on its own: the shortest repr of a float,
``True``/``False``, an empty cell for NaN); the Parquet file holds the same table and the
same pandas dtypes as ``DataFrame.to_parquet``, in row groups.

:func:`read_columns` reads columns back, floats exactly (pandas 3's default parser;
``float_precision="round_trip"`` before), for summaries and figures drawn after the run.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from rtsim.errors import InputError

__all__ = ["ChunkWriter", "iter_columns", "read_columns"]

#: Rows parsed at a time when a CSV is read back (the parser's buffers stay small).
READ_ROWS = 65536

#: pandas 3 parses floats exactly by default (and deprecates ``float_precision``).
_PANDAS_3 = int(pd.__version__.split(".")[0]) >= 3


class ChunkWriter:
    """Append DataFrame chunks to one or more files (``.csv`` / ``.parquet``).

    ``paths``: where to write (the temporary paths of a staged output); ``empty``: a
    zero-row DataFrame with the table's columns and dtypes, written if no chunk comes (None:
    the producer sets :attr:`empty` before :meth:`close`).
    Call :meth:`write` per chunk and :meth:`close` once; ``rows`` counts what was written.
    """

    def __init__(self, paths: Sequence[str | os.PathLike[str]],
                 empty: pd.DataFrame | None) -> None:
        self.paths = [Path(p) for p in paths]
        for p in self.paths:
            if p.suffix.lower() not in (".csv", ".parquet"):
                raise InputError(f"{p}: output must end in .csv or .parquet")
        self.empty = empty
        self.rows = 0
        self.chunks = 0
        self._parquet: dict[Path, Any] = {}
        self._closed = False

    def write(self, df: pd.DataFrame) -> None:
        """Append one chunk (columns and dtypes as ``empty``)."""
        if self.empty is not None and list(df.columns) != list(self.empty.columns):
            raise ValueError("chunk columns differ from the table's")
        for p in self.paths:
            if p.suffix.lower() == ".csv":
                with open(p, "w" if self.chunks == 0 else "a", encoding="utf-8",
                          newline="") as fh:
                    df.to_csv(fh, index=False, header=self.chunks == 0)
            else:
                self._write_parquet(p, df)
        self.rows += len(df)
        self.chunks += 1

    def _write_parquet(self, p: Path, df: pd.DataFrame) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.Table.from_pandas(df, preserve_index=False)
        writer = self._parquet.get(p)
        if writer is None:
            # the first chunk's schema, as to_parquet infers it for the whole table (string
            # columns held as objects have no type in an empty frame)
            writer = pq.ParquetWriter(p, table.schema)
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
        for w in self._parquet.values():
            w.close()
        for p in self.paths:
            with open(p, "rb+") as fh:
                os.fsync(fh.fileno())
        self._closed = True

    def read(self, columns: Sequence[str] | None = None,
             dtypes: dict[str, Any] | None = None) -> pd.DataFrame:
        """Columns of the table written (after :meth:`close`), from its first file."""
        return read_columns(self.paths[0], columns, dtypes)


def iter_columns(path: str | os.PathLike[str], columns: Sequence[str] | None = None,
                 chunk_rows: int = READ_ROWS, dtypes: dict[str, Any] | None = None
                 ) -> Iterator[pd.DataFrame]:
    """Columns of a CSV written by :class:`ChunkWriter` (floats exact), ``chunk_rows`` rows
    at a time (row labels continue across chunks)."""
    exact: dict[str, Any] = {} if _PANDAS_3 else {"float_precision": "round_trip"}
    with pd.read_csv(Path(path), usecols=list(columns) if columns is not None else None,
                     dtype=dtypes, keep_default_na=False, na_values=[""], chunksize=chunk_rows,
                     **exact) as reader:
        yield from reader


def read_columns(path: str | os.PathLike[str], columns: Sequence[str] | None = None,
                 dtypes: dict[str, Any] | None = None) -> pd.DataFrame:
    """Columns of a CSV written by :class:`ChunkWriter` (floats exact, parsed in chunks of
    :data:`READ_ROWS` rows), or of a Parquet file."""
    p = Path(path)
    if p.suffix.lower() == ".parquet":
        return pd.read_parquet(p, columns=list(columns) if columns is not None else None)
    parts = list(iter_columns(p, columns, READ_ROWS, dtypes))
    if len(parts) == 1:
        return parts[0]
    return pd.concat(parts, ignore_index=True)
