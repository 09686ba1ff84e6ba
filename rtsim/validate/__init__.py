"""Validation of the analysis against the simulator, and response-time histograms.

- `run_validation` (``rtsim validate``): w_sch, w_rta and w_sim for the paper's set over
  (n, r_H), response times at w_sch against the exact WCRT, random UUniFast sets; a table,
  figures and ``report.md`` (`rtsim.validate.runner`).
- `write_histograms` with a source from `from_simulation`,
  `from_scenario_dir` or `from_sweep_point` (``rtsim histogram``).

The pure parts (bounds per task, the w_sim search, the checker) live in
`rtsim.analysis.validation`.
"""

from rtsim.validate.histogram import (
    JobSource,
    from_scenario_dir,
    from_simulation,
    from_sweep_point,
    histogram_table,
    write_histograms,
)
from rtsim.validate.runner import (
    FULL,
    QUICK,
    ValidationConfig,
    ValidationOutcome,
    run_validation,
)

__all__ = [
    "FULL",
    "JobSource",
    "QUICK",
    "ValidationConfig",
    "ValidationOutcome",
    "from_scenario_dir",
    "from_simulation",
    "from_sweep_point",
    "histogram_table",
    "run_validation",
    "write_histograms",
]
