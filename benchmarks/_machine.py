"""What every benchmark prints first: the machine, the date, the versions (imported by the
scripts beside it, which run as ``python benchmarks/NAME.py``)."""

from __future__ import annotations

import datetime
import os
import platform
import sys
from typing import Any


def cpu_model() -> str:
    """The processor's model name (Linux), else the platform's word for it."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine() -> dict[str, Any]:
    """Machine, date (UTC), Python and the numeric libraries' versions."""
    import numpy as np
    import pandas as pd

    out: dict[str, Any] = {
        "date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "cpu": cpu_model(),
        "cores": os.cpu_count(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "pandas": pd.__version__,
        "load": round(os.getloadavg()[0], 2) if hasattr(os, "getloadavg") else None,
    }
    try:
        import numba

        out["numba"] = numba.__version__
    except ImportError:
        out["numba"] = None
    return out


def print_machine(file: Any = None) -> dict[str, Any]:
    """Print :func:`machine` as one line and return it."""
    m = machine()
    print("machine: " + ", ".join(f"{k} {v}" for k, v in m.items()), file=file or sys.stdout)
    return m
