"""The traced peak of a call (tracemalloc), for the memory tests. Not a test module."""

from __future__ import annotations

import gc
import tracemalloc
from collections.abc import Callable
from typing import Any


def traced_peak(fn: Callable[[], Any]) -> int:
    """The largest traced allocation total (bytes) while ``fn()`` runs, after a collection."""
    gc.collect()
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
