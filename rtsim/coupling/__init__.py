"""Where the schedule and the world meet: one SimPy run (docs/model/adjustment.md,
docs/model/world.md)."""

from rtsim.coupling.recorder import (
    FOLLOWER_FIELDS,
    VIOLATION_FIELDS,
    WINDOW_COLUMNS,
    WindowRecord,
    WindowRecorder,
    window_columns,
)
from rtsim.coupling.scenario_run import (
    LAP_CAP_FACTOR,
    ScenarioInputs,
    ScenarioResult,
    run_scenario,
    summarize,
)

__all__ = [
    "FOLLOWER_FIELDS",
    "LAP_CAP_FACTOR",
    "VIOLATION_FIELDS",
    "WINDOW_COLUMNS",
    "ScenarioInputs",
    "ScenarioResult",
    "WindowRecord",
    "WindowRecorder",
    "run_scenario",
    "summarize",
    "window_columns",
]
