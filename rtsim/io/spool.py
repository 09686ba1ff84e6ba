"""Record chunks kept on disk during a run and read back in order, in constant memory.

A `Spool` is a sink for `rtsim.sim.records.RowBuffer` (it has
``write_rows``): each chunk of row tuples is pickled to a scratch file as it comes, and
iterating the spool yields the chunks again, one at a time, as often as needed. It holds what
an export needs several passes over (the Perfetto trace: `rtsim.export.perfetto`) without
keeping a run's records in memory. The tuples come back exactly (floats bit for bit).

A `Tee` hands each chunk to several sinks (the ``--jobs`` file and a spool, say).
"""

from __future__ import annotations

import os
import pickle
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from rtsim.io.atomic import naming

__all__ = ["Spool", "Tee"]


class Spool:
    """Row chunks pickled to ``path`` (a scratch file, made or truncated here).

    `write_rows` appends a chunk; iterating yields the chunks written so far, in order
    (each a list of tuples); `close` removes the file. A context manager. A write
    error (a full disk) names ``label``, the output the spool is for (default ``path``).
    """

    def __init__(
        self, path: str | os.PathLike[str], label: str | os.PathLike[str] | None = None
    ) -> None:
        self.path = Path(path)
        self.label = self.path if label is None else Path(label)
        self._fh: Any = open(self.path, "wb")  # noqa: SIM115 - closed by close()
        self.rows = 0

    def write_rows(self, rows: Sequence[tuple[Any, ...]]) -> None:
        """Append one chunk of row tuples."""
        if not len(rows):
            return
        with naming(self.label):
            pickle.dump(list(rows), self._fh, protocol=pickle.HIGHEST_PROTOCOL)
            self._fh.flush()
        self.rows += len(rows)

    def __iter__(self) -> Iterator[list[tuple[Any, ...]]]:
        if self._fh is None:
            raise ValueError(f"{self.path}: the spool is closed")
        self._fh.flush()
        with open(self.path, "rb") as fh:
            while True:
                try:
                    yield pickle.load(fh)
                except EOFError:
                    return

    def close(self) -> None:
        """Close and remove the scratch file."""
        if self._fh is not None:
            self._fh.close()
            self._fh = None
        self.path.unlink(missing_ok=True)

    def __enter__(self) -> Spool:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


class Tee:
    """A sink that hands each chunk of rows to every one of ``sinks`` (None entries skipped)."""

    def __init__(self, *sinks: Any) -> None:
        self.sinks = [s for s in sinks if s is not None]

    def write_rows(self, rows: Sequence[tuple[Any, ...]]) -> None:
        """Give the chunk to each sink, in order."""
        for s in self.sinks:
            s.write_rows(rows)
