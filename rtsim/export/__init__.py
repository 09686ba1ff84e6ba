"""Exporters: each takes the tables a run already has and writes one format.

- `rtsim.export.perfetto` — the Chrome Trace Event Format (Perfetto, chrome://tracing).

`EXPORTERS` holds them by name (entry-point group ``rtsim.exporters``): a writer
``write(path, jobs, trace, *, tasks=None, windows=None, metadata=None) -> Path``.
"""

from collections.abc import Callable
from typing import Any

from rtsim.errors import InputError
from rtsim.export.perfetto import trace_events, write_perfetto
from rtsim.registry import Registry

__all__ = ["EXPORTERS", "trace_events", "write_perfetto"]


def _writer(obj: Any, spec: str, where: str) -> Callable[..., Any]:
    if not callable(obj):
        raise InputError(f"{where} is not an exporter (a callable write(path, jobs, trace, ...))")
    return obj  # type: ignore[no-any-return]


#: The trace exporters by name.
EXPORTERS: Registry[Callable[..., Any]] = Registry("exporter", "rtsim.exporters", _writer)
EXPORTERS.register("perfetto", write_perfetto)
