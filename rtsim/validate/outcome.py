"""What ``rtsim validate`` runs (`ValidationConfig`, with the `QUICK` and
`FULL` presets) and what it returns (`ValidationOutcome`): the types the runner
and the report share, in a module of their own so that neither imports the other."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from rtsim.analysis.validation import SEARCH_TOL, Failure
from rtsim.errors import InputError
from rtsim.notebook import ResultDisplay, flatten

__all__ = ["ValidationConfig", "ValidationOutcome", "QUICK", "FULL", "DEFAULT_SCENARIO"]


@dataclass(frozen=True)
class ValidationConfig:
    """What to validate: the (n, r_H) grid, windows per run, scan size, random sets."""

    n: tuple[int, ...] = tuple(range(1, 11))
    r_H: tuple[float, ...] = (10.0, 20.0, 30.0, 40.0, 50.0)
    windows: int = 400
    scan: int = 20
    tol: float = SEARCH_TOL
    random_sets: int = 30
    hyperperiods: int = 10
    seed: int = 1
    name: str = "full"
    histogram_configs: int = 2
    taskset_path: str | None = None
    scenario_path: str | None = None  # None: DEFAULT_SCENARIO if it exists, else Test1()
    #: ``--set``: (dotted path, value) pairs, each changing the task set's key when its first
    #: part is a table (or shortcut) of the task set, else the scenario's (`split_overrides`)
    overrides: tuple[tuple[str, Any], ...] = ()

    def __post_init__(self) -> None:
        if not self.n or any(int(k) != k or k < 1 for k in self.n):
            raise InputError(f"validate: n must be positive integers, got {self.n}")
        if not self.r_H or any(not (math.isfinite(r) and r > 0) for r in self.r_H):
            raise InputError(f"validate: r_H must be positive, got {self.r_H}")
        if self.windows < 100:
            raise InputError(f"validate: windows must be at least 100, got {self.windows}")
        if self.random_sets < 0:
            raise InputError(f"validate: random sets must be >= 0, got {self.random_sets}")


#: Test 1's scenario file in a source checkout (installed as the packaged scenario ``test1``).
DEFAULT_SCENARIO = Path(__file__).resolve().parents[2] / "experiments" / "scenarios" / "test1.toml"

FULL = ValidationConfig()
QUICK = ValidationConfig(
    n=(1, 2, 4),
    r_H=(10.0, 30.0),
    windows=100,
    scan=6,
    random_sets=3,
    hyperperiods=5,
    name="quick",
    histogram_configs=1,
)


@dataclass(frozen=True, repr=False)
class ValidationOutcome(ResultDisplay):
    """The table, what was flagged, the summary, failed sweep points, and where it all is."""

    table: pd.DataFrame
    failures: list[Failure]
    summary: dict[str, Any]
    point_errors: list[str]
    out_dir: Path
    files: list[Path] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """No failure flagged and every sweep point ran."""
        return not self.point_errors and not any(f.severity == "failure" for f in self.failures)

    def headline(self) -> dict[str, Any]:
        """Verdict, size and where the report is (the short ``repr``)."""
        return {
            "ok": self.ok,
            "rows": len(self.table),
            "failures": sum(f.severity == "failure" for f in self.failures),
            "warnings": sum(f.severity != "failure" for f in self.failures),
            "point_errors": len(self.point_errors),
            "out_dir": str(self.out_dir),
        }

    def summary_frame(self) -> pd.DataFrame:
        """summary.json as one row (nested keys dotted)."""
        return pd.DataFrame([flatten(self.summary)])
