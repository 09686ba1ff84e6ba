"""Samples a run keeps for exact percentiles, held in bounded memory (docs/reliability.md).

A [`ValueSpill`][rtsim.coupling.spill.ValueSpill] takes rows of ``width`` floats (one per
window: a value per follower, or several) into a small buffer and, when a ``path`` is given,
appends every full buffer to that binary scratch file (native float64, row after row);
without a path the buffers stay in memory as float64 arrays (8 B a value). Its rows are read
back in chunks of a bounded number of rows.

[`p95_max_columns`][rtsim.coupling.spill.p95_max_columns] computes from those chunks what
[`p95_max_rows`][rtsim.coupling.physical.p95_max_rows] computes from whole arrays — each
column's p95 (numpy's ``percentile``, its default linear method) and maximum, and those of
every column's values together — to the bit, in memory bounded by a chunk and
`COLLECT_LIMIT` values: the two order statistics around the 95th percentile's virtual index
``0.95·(N − 1)`` are found by a radix selection on the values' order-preserving 64-bit keys,
16 bits per pass over the chunks, until the candidates left fit in memory and are sorted.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from rtsim.io.atomic import naming

__all__ = ["COLLECT_LIMIT", "SPILL_ROWS", "ValueSpill", "p95_max_columns", "percentile95"]

Stats = dict[str, float] | None

#: Rows a spill buffers before it appends them to its file (and rows read back at a time).
SPILL_ROWS = 4_096
#: Candidates of a selection kept in memory at once: a key bucket holding at most this many
#: values is gathered and sorted instead of refined by another pass.
COLLECT_LIMIT = 65_536
#: Rows up to which `p95_max_columns` keeps the chunks it read in its first pass and selects
#: the order statistics from them at once (`np.partition`) instead of by further passes:
#: a lap's samples (a short run, or a sweep point) without the radix passes' ≈ 7 ms.
DIRECT_ROWS = 8_192
_SIGN = np.uint64(1 << 63)
_DIGIT = 16  # bits resolved per pass


class ValueSpill:
    """Rows of ``width`` floats, appended during a run and read back in chunks (module
    docstring). ``path``: the scratch file (made or truncated here, removed by `close`);
    None keeps the rows in memory. ``label``: the output a write error names."""

    def __init__(
        self, width: int, path: str | os.PathLike[str] | None = None, label: Any = None
    ) -> None:
        self.width = int(width)
        self.path = None if path is None else Path(path)
        self.label: str | os.PathLike[str] = label if label is not None else (path or "")
        self.buf: list[float] = []  # (a list's append is the loop's cheapest)
        self.limit = SPILL_ROWS * self.width
        self._kept: list[np.ndarray] = []  # the full buffers, without a path
        self._fh: Any = None
        self.rows = 0
        if self.path is not None:
            with naming(self.label):
                self._fh = open(self.path, "wb")  # noqa: SIM115 - closed by close()

    def full(self) -> None:
        """Hand over the buffer if it holds `SPILL_ROWS` rows (called after each row)."""
        if len(self.buf) >= self.limit:
            self.flush()

    def flush(self) -> None:
        """Append the buffered rows to the file (or keep them as an array)."""
        if not self.buf:
            return
        self.rows += len(self.buf) // self.width
        block = np.array(self.buf, dtype=np.float64)
        if self._fh is None:
            self._kept.append(block)
        else:
            with naming(self.label):
                self._fh.write(block.tobytes())
        self.buf = []

    def add_rows(self, rows: np.ndarray) -> None:
        """Append a block of rows (shape (m, width))."""
        self.flush()
        # (the block as it is, a copy of its own: what `flush` makes of its rows as a list,
        # without the round trip through Python floats)
        block = np.array(rows, dtype=np.float64).ravel()
        if not block.size:
            return
        self.rows += block.size // self.width
        if self._fh is None:
            self._kept.append(block)
        else:
            with naming(self.label):
                self._fh.write(block.tobytes())

    def chunks(self, rows: int = SPILL_ROWS) -> Iterator[np.ndarray]:
        """Every row in order, ``rows`` at a time at most: arrays of shape (m, width)."""
        if self._fh is not None:
            with naming(self.label):
                self._fh.flush()
                with open(self.path, "rb") as fh:  # type: ignore[arg-type]
                    while True:
                        part = np.fromfile(fh, dtype=np.float64, count=rows * self.width)
                        if not part.size:
                            break
                        yield part.reshape(-1, self.width)
        tail = np.array(self.buf, dtype=np.float64) if self.buf else None
        for kept in (*self._kept, *(() if tail is None else (tail,))):
            block = kept.reshape(-1, self.width)
            for i in range(0, len(block), rows):
                yield block[i : i + rows]

    def columns(self) -> list[np.ndarray]:
        """Each column whole (for tests and small runs: memory grows with the rows)."""
        parts = list(self.chunks())
        if not parts:
            return [np.zeros(0) for _ in range(self.width)]
        whole = np.concatenate(parts)
        return [whole[:, j].copy() for j in range(self.width)]

    def close(self) -> None:
        """Close and remove the scratch file (the rows are gone)."""
        if self._fh is not None:
            self._fh.close()
            self._fh = None
        if self.path is not None:
            self.path.unlink(missing_ok=True)
        self._kept = []
        self.buf = []


def percentile95(count: int, select: Callable[[int], float], top: float) -> float:
    """numpy's ``percentile(v, 95)`` (linear method) of ``count`` values, from
    ``select(k)``, their k-th smallest (0-based), and ``top``, their maximum: the virtual
    index 0.95·(count − 1), its floor ``k`` and fraction γ, then numpy's interpolation
    (``a + (b − a)·γ`` below γ = 0.5, ``b − (b − a)·(1 − γ)`` from it)."""
    virtual = (count - 1) * 0.95
    k = math.floor(virtual)
    gamma = virtual - k
    # (one value: numpy takes the last value twice)
    a, b = (top, top) if virtual >= count - 1 else (select(k), select(k + 1))
    diff = b - a
    return float(b - diff * (1.0 - gamma) if gamma >= 0.5 else a + diff * gamma)


def _keys(v: np.ndarray) -> np.ndarray:
    """Order-preserving unsigned keys of float64 values (no NaN; -0.0 taken as 0.0)."""
    u = (v + 0.0).view(np.uint64)  # (-0.0 + 0.0 is 0.0)
    neg = (u & _SIGN) != 0
    return np.where(neg, ~u, u | _SIGN)


def _value(key: int) -> float:
    """The float64 whose `_keys` key is ``key``."""
    u = np.uint64(key)
    raw = u & ~_SIGN if u & _SIGN else ~u
    return float(np.array([raw], dtype=np.uint64).view(np.float64)[0])


class _Query:
    """One order statistic being selected: its target, its rank among what is left, the
    key's high bits resolved so far, and the candidates gathered (last pass)."""

    def __init__(self, target: int, rank: int) -> None:
        self.target, self.rank = target, rank
        self.prefix, self.bits = 0, 0
        self.counts: np.ndarray | None = None
        self.gathered: list[np.ndarray] | None = None
        self.key: int | None = None

    def pick(self, keys: np.ndarray) -> np.ndarray:
        if not self.bits:
            return keys
        return keys[(keys >> np.uint64(64 - self.bits)) == np.uint64(self.prefix)]

    def take(self, keys: np.ndarray) -> None:
        sel = self.pick(keys)
        if self.gathered is not None:
            self.gathered.append(sel)
            return
        digit = (sel >> np.uint64(64 - _DIGIT - self.bits)) & np.uint64((1 << _DIGIT) - 1)
        assert self.counts is not None
        self.counts += np.bincount(digit.astype(np.intp), minlength=1 << _DIGIT)

    def settle(self) -> None:
        """After a pass: the digit holding the rank, or the key among the gathered."""
        if self.gathered is not None:
            got = np.sort(np.concatenate(self.gathered)) if self.gathered else np.zeros(0)
            self.key = int(got[self.rank])
            return
        assert self.counts is not None
        cum = np.cumsum(self.counts)
        d = int(np.searchsorted(cum, self.rank, side="right"))
        self.rank -= int(cum[d - 1]) if d else 0
        inside = int(self.counts[d])
        self.prefix, self.bits = (self.prefix << _DIGIT) | d, self.bits + _DIGIT
        if self.bits == 64:
            self.key = self.prefix
        elif inside <= COLLECT_LIMIT:
            self.gathered = []

    def start(self) -> None:
        if self.gathered is None:
            self.counts = np.zeros(1 << _DIGIT, dtype=np.int64)


def _stats(count: int, nan: bool, top: float, select: Callable[[int], float]) -> Stats:
    """p95 and max of ``count`` values (None: none; NaN among them: NaN for both)."""
    if not count:
        return None
    if nan:
        return {"p95": math.nan, "max": math.nan}
    return {"p95": percentile95(count, select, top), "max": top}


def _direct(
    parts: list[list[tuple[int, np.ndarray]]],
    count: list[int],
    nan: list[bool],
    top: list[float],
    width: int,
) -> tuple[Stats, list[Stats]]:
    """`p95_max_columns` from its first pass's chunks (``parts``: each chunk's (target,
    values)) and its counts, NaN flags and maxima: each target's two order statistics by
    one `np.partition` of its values (+ 0.0: -0.0 taken as 0.0, as the keys do)."""
    stats: list[Stats] = []
    for t in range(width + 1):
        select: Callable[[int], float] = float  # (unused: no values, or the top taken twice)
        virtual = (count[t] - 1) * 0.95
        if count[t] and not nan[t] and virtual < count[t] - 1:
            k = math.floor(virtual)
            got = [a for p in parts for u, a in p if u == t]
            v = (got[0] if len(got) == 1 else np.concatenate(got)) + 0.0  # (a copy)
            v.partition([k, k + 1])  # (in place)
            select = v.item
        stats.append(_stats(count[t], nan[t], top[t], select))
    return stats[width], stats[:width]


def p95_max_columns(
    chunks: Callable[[], Iterable[np.ndarray]], width: int, finite_only: bool = False
) -> tuple[Stats, list[Stats]]:
    """What `rtsim.coupling.physical.p95_max_rows` gives for the ``width`` columns of the
    rows ``chunks()`` yields (called once per pass; arrays of shape (m, width)): p95 and
    max of every value together, and of each column's. ``finite_only``: each column's
    finite values only (infinities and NaN left out). A column with a NaN gives NaN for
    both, as numpy does. Memory: a chunk and `COLLECT_LIMIT` keys per order statistic."""
    targets = width + 1  # each column, then all of them
    count = [0] * targets
    nan = [False] * targets
    top = [-math.inf] * targets

    def values(chunk: np.ndarray) -> Iterator[tuple[int, np.ndarray]]:
        cols = [chunk[:, j] for j in range(width)]
        if finite_only:
            cols = [c[np.isfinite(c)] for c in cols]
        yield from enumerate(cols)
        yield width, np.concatenate(cols) if cols else np.zeros(0)

    # pass 0's chunks' values (`values`), while within DIRECT_ROWS
    kept: list[list[tuple[int, np.ndarray]]] | None = []
    rows = 0
    for chunk in chunks():  # pass 0: counts, NaN, maxima
        parts = list(values(chunk))
        if kept is not None:
            rows += len(chunk)
            if rows <= DIRECT_ROWS:
                kept.append(parts)
            else:
                kept = None
        for t, v in parts:
            if not v.size:
                continue
            count[t] += v.size
            m = float(v.max())
            if m != m:
                nan[t] = True
            elif m > top[t]:
                top[t] = m
    if kept is not None:
        return _direct(kept, count, nan, top, width)
    queries: dict[tuple[int, int], _Query] = {}
    for t in range(targets):
        if count[t] and not nan[t]:
            virtual = (count[t] - 1) * 0.95
            if virtual < count[t] - 1:
                k = math.floor(virtual)
                queries[t, k] = _Query(t, k)
                queries[t, k + 1] = _Query(t, k + 1)
    while any(q.key is None for q in queries.values()):
        live = [q for q in queries.values() if q.key is None]
        for q in live:
            q.start()
        for chunk in chunks():
            keys = {t: _keys(v) for t, v in values(chunk) if any(q.target == t for q in live)}
            for q in live:
                q.take(keys[q.target])
        for q in live:
            q.settle()
    stats = [
        _stats(count[t], nan[t], top[t], lambda k, t=t: _value(queries[t, k].key))  # type: ignore[misc, arg-type]
        for t in range(targets)
    ]
    return stats[width], stats[:width]
