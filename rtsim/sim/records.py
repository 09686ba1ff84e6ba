"""What a simulation run leaves behind: running per-task statistics, job records, the trace.

Per-task statistics ([`TaskStats`][rtsim.sim.records.TaskStats]) are updated as jobs finish and keep
O(1) memory per
task plus one counter per occupied histogram bin, so a long horizon runs in bounded memory
when per-job records are off. Job records are appended as plain tuples to a
`RowBuffer`, which turns every `CHUNK_ROWS` of them into a typed column chunk —
kept in memory (about 4x smaller than the tuples) or handed to a sink that writes it out
(``rtsim simulate --jobs``, ``rtsim scenario``: memory stays flat however long the run);
the execution-interval trace is kept as tuples and turned into a DataFrame once. The column
schemas are fixed: `JOB_COLUMNS` and `TRACE_COLUMNS`.

A job *misses* when it finishes later than its absolute deadline plus the coincidence window
(1e-9 ms, or 16 units in the last place of t from t = 2^19 ms on, where doubles are coarser:
docs/time.md), is aborted at its deadline, or its release is skipped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # (imported where a frame is made: pandas costs a command ~0.3 s to import)
    import pandas as pd

from rtsim.notebook import ResultDisplay

__all__ = [
    "CHUNK_ROWS",
    "EPS",
    "JOB_COLUMNS",
    "RowBuffer",
    "TRACE_COLUMNS",
    "ResponseHistogram",
    "TaskStats",
    "SimResult",
]

#: Time tolerance (ms): a finish later than deadline + EPS is a miss; events closer than EPS
#: are simultaneous (from t = 2^19 ms on, 16 ulps of t instead: cpu.coincidence, docs/time.md).
EPS = 1e-9

#: Job records per column chunk of a `RowBuffer`.
CHUNK_ROWS = 8192

#: Columns of ``SimResult.jobs`` (one row per release; a skipped release has no start/finish).
#: ``period`` is the period in force at the release (w for the window chain);
#: ``arrival`` is when the job arrived (offset + k·p), ``release`` when it became ready (up to
#: the task's jitter later); ``response`` = finish − arrival and the deadline counts from the
#: arrival. ``exec_time`` is the CPU time the job received (suspensions included under
#: ``suspension="cpu"``), ``preemptions`` how often it lost the CPU before finishing.
#: The keys are the columns, the values their dtypes in `jobs_frame`.
JOB_DTYPES: dict[str, str] = {
    "task": "string",
    "job": "int64",
    "release": "float64",
    "start": "float64",
    "finish": "float64",
    "response": "float64",
    "deadline": "float64",
    "period": "float64",
    "missed": "bool",
    "preemptions": "int64",
    "aborted": "bool",
    "skipped": "bool",
    "exec_time": "float64",
    "arrival": "float64",
}
JOB_COLUMNS: tuple[str, ...] = tuple(JOB_DTYPES)

#: Columns of ``SimResult.trace``: one row per stretch of one segment of one job.
#: ``kind`` is ``compute``, ``suspend`` or ``overhead`` (context switch); ``on_cpu`` is false
#: only for a suspension under ``suspension="idle"`` (the job waits, the CPU is free).
TRACE_COLUMNS: tuple[str, ...] = ("task", "job", "segment", "kind", "on_cpu", "start", "end")


@dataclass
class ResponseHistogram:
    """Response-time counts in bins of ``bin_width`` ms: bin i covers [i·w, (i+1)·w)."""

    bin_width: float
    counts: dict[int, int] = field(default_factory=dict)

    def add(self, value: float) -> None:
        """Count one response time."""
        i = int(value / self.bin_width)
        self.counts[i] = self.counts.get(i, 0) + 1

    @property
    def total(self) -> int:
        """Number of values counted."""
        return sum(self.counts.values())

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """(edges, counts) over the occupied range, as for ``numpy.histogram``."""
        if not self.counts:
            return np.array([0.0, self.bin_width]), np.zeros(1, dtype=np.int64)
        lo, hi = min(self.counts), max(self.counts)
        counts = np.array([self.counts.get(i, 0) for i in range(lo, hi + 1)], dtype=np.int64)
        edges = np.arange(lo, hi + 2, dtype=float) * self.bin_width
        return edges, counts

    def as_dict(self) -> dict[str, Any]:
        """JSON form: bin width and the sparse counts."""
        return {
            "bin_width": self.bin_width,
            "bins": {str(k): v for k, v in sorted(self.counts.items())},
        }


@dataclass
class TaskStats:
    """Running statistics of one task over the jobs released in [0, H)."""

    name: str
    priority: int
    released: int = 0
    completed: int = 0
    aborted: int = 0
    skipped: int = 0
    misses: int = 0
    max_response: float | None = None
    sum_response: float = 0.0
    max_backlog: int = 0
    preemptions: int = 0
    histogram: ResponseHistogram | None = None

    @property
    def mean_response(self) -> float | None:
        """Mean response time over completed jobs (late ones included)."""
        return self.sum_response / self.completed if self.completed else None

    def as_dict(self) -> dict[str, Any]:
        """The JSON entry of ``rtsim simulate --json``: ``jobs`` = completed jobs."""
        return {
            "name": self.name,
            "priority": self.priority,
            "released": self.released,
            "jobs": self.completed,
            "aborted": self.aborted,
            "skipped": self.skipped,
            "max_response": self.max_response,
            "mean_response": self.mean_response,
            "misses": self.misses,
            "max_backlog": self.max_backlog,
            "preemptions": self.preemptions,
        }


def _finite_or_none(x: Any) -> Any:
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


@dataclass(repr=False)
class SimResult(ResultDisplay):
    """The outcome of one run: per-task stats, optional job table and trace, run facts."""

    tasks: dict[str, TaskStats]
    horizon: float
    seed: Any
    suspension: str
    exec_model: str
    overhead: float
    end_time: float
    busy_time: float
    context_switches: int
    window: dict[str, Any] | None = None
    jobs: pd.DataFrame | None = None
    trace: pd.DataFrame | None = None
    jitter: str = "random"
    scheduler: str = "fp"
    resources: str | None = None
    blocking: dict[str, float] | None = None

    @property
    def misses(self) -> int:
        """Deadline misses over all tasks."""
        return sum(s.misses for s in self.tasks.values())

    def headline(self) -> dict[str, Any]:
        """The run's headline facts (the short ``repr``)."""
        return {
            "tasks": len(self.tasks),
            "horizon": self.horizon,
            "jobs": sum(s.completed for s in self.tasks.values()),
            "misses": self.misses,
            "busy_time": self.busy_time,
            "suspension": self.suspension,
            "exec_model": self.exec_model,
        }

    def summary_frame(self) -> pd.DataFrame:
        """Per-task statistics, one row per task (the same as `stats_frame`)."""
        return self.stats_frame()

    def stats_frame(self) -> pd.DataFrame:
        """Per-task statistics as a DataFrame (one row per task, priority order)."""
        import pandas as pd

        return pd.DataFrame([s.as_dict() for s in self.tasks.values()])

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict with a ``tasks`` list (the ``--json`` output)."""
        out: dict[str, Any] = {
            "horizon": self.horizon,
            "seed": self.seed if isinstance(self.seed, int | None) else str(self.seed),
            "suspension": self.suspension,
            "exec_model": self.exec_model,
            "overhead": self.overhead,
            "jitter": self.jitter,
            "scheduler": self.scheduler,
            "end_time": self.end_time,
            "busy_time": self.busy_time,
            "context_switches": self.context_switches,
            "misses": self.misses,
        }
        if self.window is not None:
            out["window"] = {k: _finite_or_none(v) for k, v in self.window.items()}
        out["tasks"] = [s.as_dict() for s in self.tasks.values()]
        if self.resources is not None:  # critical sections: the protocol, blocking per task
            out["resources"] = self.resources
            for t in out["tasks"]:
                t["max_blocking"] = (self.blocking or {}).get(t["name"], 0.0)
        return out


_list_append = list.append


class RowBuffer(list):  # type: ignore[type-arg]
    """Job records as tuples, turned into a column chunk every ``chunk_rows`` rows.

    A list (the CPU appends to it as to a list) whose rows are converted by ``to_frame``
    (`jobs_frame`) and passed to ``sink`` (a callable taking a DataFrame, or an
    object with ``write_rows`` given the tuples: `flush`), or kept in
    `chunks` when there is no sink. `frame` returns the whole table (no sink);
    `flush` hands over what is left.
    """

    def __init__(self, to_frame: Any, sink: Any = None, chunk_rows: int | None = None) -> None:
        super().__init__()
        self.to_frame = to_frame
        self.sink = sink
        self.chunk_rows = int(chunk_rows or CHUNK_ROWS)
        self.chunks: list[pd.DataFrame] = []
        self.flushed = 0

    def append(self, row: tuple[Any, ...]) -> None:  # type: ignore[override]
        """Add one record (a tuple in column order)."""
        _list_append(self, row)  # (list.append itself: no super() object per record)
        if len(self) >= self.chunk_rows:
            self.flush()

    def flush(self) -> None:
        """Turn the rows held into a chunk (to the sink, or kept); an empty buffer is a no-op.
        A sink with a ``write_rows`` method (`rtsim.io.columns.ChunkWriter`) is given
        the row tuples themselves: it formats them as columns, without a DataFrame."""
        if not len(self):
            return
        self.flushed += len(self)
        write_rows = getattr(self.sink, "write_rows", None)
        if write_rows is not None:
            write_rows(self)
            self.clear()
            return
        df = self.to_frame(self)
        self.clear()
        if self.sink is not None:
            self.sink(df)
        else:
            self.chunks.append(df)

    def frame(self) -> pd.DataFrame:
        """Every record kept (without a sink) as one DataFrame."""
        self.flush()
        if not self.chunks:
            return self.to_frame([])
        if len(self.chunks) == 1:
            return self.chunks[0]
        import pandas as pd

        return pd.concat(self.chunks, ignore_index=True)


def jobs_frame(rows: list[tuple[Any, ...]]) -> pd.DataFrame:
    """Job records (tuples in `JOB_COLUMNS` order) as a typed DataFrame: each column
    converted by itself (`np.fromiter`, the task names as a ``string`` array: the frame
    ``DataFrame(rows).astype(JOB_DTYPES)`` gives, in half its time); a value that is not
    a number of its column's type (None, say) through that frame."""
    import pandas as pd

    if len(rows):
        try:
            data: dict[str, Any] = {}
            for (name, dtype), col in zip(JOB_DTYPES.items(), zip(*rows, strict=True), strict=True):
                if dtype == "string":
                    data[name] = pd.array(list(col), dtype="string")
                else:
                    data[name] = np.fromiter(col, dtype, len(col))
            return pd.DataFrame(data)
        except (TypeError, ValueError):
            pass
    df = pd.DataFrame(rows, columns=list(JOB_COLUMNS))
    return df.astype(JOB_DTYPES)


def trace_frame(rows: list[tuple[Any, ...]]) -> pd.DataFrame:
    """Trace rows (tuples in `TRACE_COLUMNS` order) as a typed DataFrame."""
    import pandas as pd

    df = pd.DataFrame(rows, columns=list(TRACE_COLUMNS))
    return df.astype(
        {
            "task": "string",
            "job": "int64",
            "segment": "string",
            "kind": "string",
            "on_cpu": "bool",
            "start": "float64",
            "end": "float64",
        }
    )
