"""``summary.json`` of a scenario run as strict JSON: null where docs/outputs.md says so.

The in-memory summary
([`rtsim.coupling.scenario_run.summarize`][rtsim.coupling.scenario_run.summarize]) holds floats; a
run
with no finished window has no minimum and no maximum (NaN), and a run in which no bound
was ever finite has an infinite ``min_msb_over_wsch``. In the file those are ``null``:

- ``min_msb_over_wsch``: null when no window finished, or when every motion and sensing
  bound was infinite (nothing limited the window);
- ``min_speed_ratio``, ``max_response``: null when no window finished;
- ``max_violation_ratio.<kind>``: null when that kind was never measured;
- ``leader_accel_max``, ``leader_decel_max``: null when the limit is infinite (the
  scenario left it out or wrote ``inf``: the leader's speed steps at once).

Any other non-finite value is a bug and raises
([`rtsim.io.atomic.NonFiniteJSON`][rtsim.io.atomic.NonFiniteJSON]).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

__all__ = ["NULLABLE", "summary_json"]

#: Top-level summary fields (and tables of fields) that are null when not finite.
NULLABLE = (
    "min_msb_over_wsch",
    "min_speed_ratio",
    "max_response",
    "max_violation_ratio",
    "leader_accel_max",
    "leader_decel_max",
)


def _null(v: Any) -> Any:
    if isinstance(v, Mapping):
        return {k: _null(x) for k, x in v.items()}
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def summary_json(summary: Mapping[str, Any]) -> dict[str, Any]:
    """A copy of ``summary`` with the `NULLABLE` fields' non-finite values as None."""
    return {k: _null(v) if k in NULLABLE else v for k, v in summary.items()}
