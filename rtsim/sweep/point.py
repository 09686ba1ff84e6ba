"""Running one sweep point on any worker: the kind's metrics, or the error, as a record.

Kept free of pandas and the engine so that process and Dask workers import little.
"""

from __future__ import annotations

import math
import os
import signal
import socket
import time
from collections.abc import Mapping
from fnmatch import fnmatchcase
from typing import Any

from rtsim.sweep.kinds import KINDS, PointInput

__all__ = ["execute_point", "select_metrics", "RESERVED", "worker_init"]

#: The results table's own columns after the grid's, in order: names a metric may not take
#: (grid names are checked by the engine).
RESERVED = ("seed", "point_seed", "status", "error")


#: Seconds between two checks that a worker's parent (the sweep) is still alive.
PARENT_POLL_S = 0.5


def worker_init(parent: int | None = None) -> None:
    """Worker-process initializer: Ctrl-C goes to the parent, which stops the workers
    (SIGTERM); a SIGTERM handler inherited from the parent by ``fork`` is undone; and the
    worker exits as soon as its parent ``parent`` (a pid) is gone, even killed with
    SIGKILL, rather than wait forever for work (`watch_parent`)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if parent is not None:
        watch_parent(parent)


def watch_parent(parent: int, poll_s: float = PARENT_POLL_S) -> None:
    """Start a daemon thread that ends this process (``os._exit(70)``) once its parent
    process is no longer ``parent``: an orphan is re-parented (to init or a subreaper), so
    ``os.getppid()`` changes."""
    import threading

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(poll_s)
        os._exit(70)

    threading.Thread(target=watch, name="rtsim-parent-watch", daemon=True).start()


_INT64 = (-(2**63), 2**63 - 1)


def _scalar(name: str, v: Any) -> Any:
    """A metric value as a Python bool, int, float or str (numpy scalars unwrapped; None is
    NaN, "no value"); anything else, or an integer beyond 64 bits, raises."""
    if hasattr(v, "item") and not isinstance(v, bool | int | float | str):
        try:
            v = v.item()  # numpy scalars (a numpy array of one element too: refused below)
        except (ValueError, TypeError):
            pass
    if v is None:
        return math.nan
    if not isinstance(v, bool | int | float | str):
        raise TypeError(f"metric '{name}' is not a scalar: {type(v).__name__}")
    if isinstance(v, int) and not isinstance(v, bool) and not _INT64[0] <= v <= _INT64[1]:
        raise ValueError(f"metric '{name}': integer {v} does not fit a 64-bit column")
    return v


def select_metrics(metrics: Mapping[str, Any], keep: tuple[str, ...] | None) -> dict[str, Any]:
    """The metrics matching ``keep`` (names or glob patterns; None keeps all), in kind order.

    A plain name in ``keep`` that the kind did not produce is an error, as are two names that
    are equal as text (``1`` and ``"1"``), a value that is not a scalar and an integer beyond
    64 bits: the point fails with that error, the sweep goes on.
    """
    if not isinstance(metrics, Mapping):
        raise TypeError(f"a point must return a dict of metrics, got {type(metrics).__name__}")
    out: dict[str, Any] = {}
    for k, v in metrics.items():
        name = str(k)
        if name in out:
            raise ValueError(f"metric names {name!r} clash (two keys with the same text)")
        out[name] = _scalar(name, v)
    for k in out:
        if k in RESERVED:
            raise ValueError(f"metric name '{k}' is reserved for a results column")
    if keep is None:
        return out
    for pat in keep:
        if not any(c in pat for c in "*?[") and pat not in out:
            raise KeyError(f"metric '{pat}' was not produced (got {', '.join(out) or 'none'})")
    return {k: v for k, v in out.items() if any(fnmatchcase(k, p) for p in keep)}


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def execute_point(point: PointInput, keep: tuple[str, ...] | None = None) -> dict[str, Any]:
    """Run ``point``'s kind; never raises for an ordinary exception (it is recorded).

    Returns ``{"index", "status": "ok"|"failed", "error", "metrics", "timing"}``; ``error``
    is one line (``ExceptionType: message``), empty when ok. Timings are wall-clock and are
    kept out of the results table.
    """
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        metrics = select_metrics(KINDS.resolve(point.kind, "sweep.kind").fn(point), keep)
        status, error = "ok", ""
    except Exception as exc:  # noqa: BLE001 - a failing point is recorded, the sweep goes on
        metrics, status, error = {}, "failed", _one_line(exc)
    return {
        "index": point.index,
        "status": status,
        "error": error,
        "metrics": metrics,
        "timing": {
            "wall_s": time.perf_counter() - t0,
            "cpu_s": time.process_time() - c0,
            "host": socket.gethostname(),
            "pid": os.getpid(),
        },
    }
