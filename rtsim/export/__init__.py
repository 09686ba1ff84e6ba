"""Exporters: each takes the tables a run already has and writes one format.

- :mod:`rtsim.export.perfetto` — the Chrome Trace Event Format (Perfetto, chrome://tracing).
"""

from rtsim.export.perfetto import trace_events, write_perfetto

__all__ = ["trace_events", "write_perfetto"]
