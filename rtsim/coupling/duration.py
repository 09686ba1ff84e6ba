"""How long a coupled run lasts, and the work limit that follows from it (one place).

A run with a duration runs for exactly that long, whether the duration comes from the call
(``duration_s``, ``--duration``), an override (``--set duration=30``) or the scenario file.
A run without one (the file's ``until = "lap"``, also the default) stops once the leader has
completed its lap — its arc length has grown by the path's lap length plus the largest ρ_d,
so the last follower has completed its own — and at the latest after `LAP_CAP_FACTOR`
lap times at the desired speed V_Ld (a leader slowed to the floor would otherwise run for
hours).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from rtsim.io.work import check_coupled
from rtsim.world.config import WorldConfig

__all__ = [
    "LAP_CAP_FACTOR",
    "RunLength",
    "check_scenario",
    "heading_warning",
    "run_length",
    "run_note",
]

#: With the default (one-lap) duration, the run stops at the latest after this many lap
#: times at V_Ld.
LAP_CAP_FACTOR = 3.0


@dataclass(frozen=True)
class RunLength:
    """The simulated time a run may take (``horizon_ms``); ``stop_s``: the leader's arc length
    (cm, from its start) after which it stops, reached no earlier than ``stop_ms`` (None: the
    run lasts the horizon)."""

    horizon_ms: float
    stop_s: float | None = None
    stop_ms: float = 0.0


def run_length(
    world: WorldConfig, duration_s: float | None, file_duration_s: float | None
) -> RunLength:
    """The run's length (module doc): ``duration_s`` as asked (s), else the scenario file's
    ``file_duration_s`` (s), else (None or 0) to the end of the lap."""
    if duration_s is None and file_duration_s:
        duration_s = file_duration_s
    if duration_s is not None:
        return RunLength(float(duration_s) * 1000.0)
    stop_s = world.path.lap_length + max(world.formation.rho_d)
    horizon_ms = LAP_CAP_FACTOR * stop_s / world.leader_speed * 1000.0
    return RunLength(horizon_ms, stop_s, 0.0)


def check_scenario(
    scenario: Any, duration_s: float | None, where: str, *, force: bool = False
) -> None:
    """Refuse a coupled run of ``scenario`` (an
    [`rtsim.config.scenario.Scenario`][rtsim.config.scenario.Scenario]) above the
    work limits (`rtsim.io.work.check_coupled`: windows over the chain's processing time
    g, world steps × followers), its length from `run_length`."""
    cfg = scenario.world
    length = run_length(cfg, duration_s, scenario.duration)
    win = scenario.load_taskset().window
    assert win is not None
    check_coupled(length.horizon_ms, win.g(), cfg.step_ms, cfg.n, where, force=force)


def run_note(summary: Mapping[str, Any], to_lap: bool) -> str | None:
    """One line on what a run did beyond what was asked, or None: a run to the end of the lap
    (``to_lap``: no duration anywhere, ``until = "lap"``) says how long that took, or that it
    reached the cap. ``summary``: the run's (``duration_s``, ``lap_time_s``, ``laps``)."""
    if not to_lap:
        return None  # a duration: exactly as asked
    ran = float(summary.get("duration_s") or 0.0)
    lap = summary.get("lap_time_s")
    if lap is None:
        return (
            f'until = "lap": stopped at {ran:.1f} s, the cap of {LAP_CAP_FACTOR:g} lap times '
            f"at V_Ld, before the leader completed its lap ({summary.get('laps', 0.0):.2f} laps)"
        )
    return (
        f'until = "lap": ran {ran:.1f} s to the end of the lap (the leader\'s took '
        f"{float(lap):.1f} s, the followers' {ran - float(lap):.1f} s more); "
        f"a duration (--duration S, --set duration=S) fixes the length"
    )


def heading_warning(heading: Mapping[str, Any]) -> str:
    """The warning for a broken heading assumption of the predicted-centre bound
    (summary.json ``assumptions.predicted_heading_sd``: ``assumed``, ``max_carried``, rad;
    docs/localization.md; ``filter_turn_noise`` below ``turn_noise``, rad/s: the filters
    model less turn noise than the followers have)."""
    model, true = heading.get("filter_turn_noise"), heading.get("turn_noise")
    if model is not None and true is not None and model < true:
        return (
            f"rtsim: warning: localization: the filters model a turn noise of "
            f"{math.degrees(model):.3g}°/s ([ekf] turn_noise), below the followers' "
            f"{math.degrees(true):.3g}°/s ([follower] turn_noise): their heading SD (up to "
            f"{math.degrees(heading['max_carried']):.3g}°) understates the error, so the "
            f"predicted-centre bound's assumed {math.degrees(heading['assumed']):.3g}° "
            f"([ekf] init_heading_sd) is not vouched for and the bound may be optimistic; set "
            f"[ekf] turn_noise to at least [follower] turn_noise"
        )
    return (
        f"rtsim: warning: localization: the predicted-centre bound assumed a heading SD of "
        f"{math.degrees(heading['assumed']):.3g}° ([ekf] init_heading_sd) and the filters "
        f"carried up to {math.degrees(heading['max_carried']):.3g}°: the bound may be "
        f"optimistic; lower the turn noise ([follower]/[ekf] turn_noise): raising "
        f"init_heading_sd raises the filters' too"
    )
