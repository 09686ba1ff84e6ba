"""Robot scenario files (TOML): the world, the task set it runs on, and every assumption.

Shape (units as in docs/model/index.md: cm, cm/s, s for ``duration``, ms for ``world.step_ms`` and
``adjust.cap``; every angular key is radians, or degrees when written with ``_deg``)::

    name = "test1"
    description = "Paper's Test 1: smooth turns"
    taskset = "barrel_robots"          # the packaged set, or a file path relative to this file
    preset = "recommended"             # the unsaid choices: "recommended" or "paper"
                                       # (rtsim.config.scenario.PRESETS)
    duration = 200                     # simulated s, exact; or instead:
    # until = "lap"                    # run until the followers complete the lap (default)

    [leader]
    speed = 25                         # V_Ld (cm/s)
    start = {x = 0, y = 0, heading_deg = 0}
    start_s = 0                        # optional: initial arc length along the path (cm)
    accel_max = 30                     # optional: speed ramp up (cm/s^2; default inf = a step)
    decel_max = 30                     # optional: speed ramp down (cm/s^2; default inf)
    path = [ {straight = 600}, {turn = "left", radius = 200, angle_deg = 90}, ... ]
    # or instead of path:
    shape = {kind = "rounded_rectangle", length = 600, width = 400, radius = 200,
             direction = "left"}       # straights of length/width, four 90-degree turns

    [formation]
    model = "follow-the-leader"        # (the default) or "l-psi": how followers are controlled
    followers = 2                      # l-psi: the chevron, pairs at 180 ± offset widening
                                       # outward; follow-the-leader: the line (rank p at
                                       # p*separation, 180 ± offset tucked inward), the
                                       # place each follower holds on straights
    separation = 390                   # rho_d of the first pair (cm)
    bearing_offset_deg = 15
    layout = "fan"                     # (the default) every follower at rho_d, bearings
                                       # fanned out (rtsim.world.formation); or "line"
    # or explicit slots instead of followers/separation/bearing_offset:
    # [[formation.slot]]
    # rho_d = 390
    # beta_d_deg = 195

    [follower]     radius, max_speed, max_accel, max_turn_rate(_deg), control_offset,
                   gain_rho, gain_beta, speed_noise, turn_noise(_deg), lookahead
    [sensing]      r_H, r_reacq, position_noise, min_points, max_range
    [ekf]          measurement_noise, speed_noise, turn_noise(_deg), position_drift,
                   heading_drift(_deg), init_position_sd, init_heading_sd(_deg), backend
    [thresholds]   T_rho, T_eps, T_beta(_deg), localization = "radial" | "full" | "predicted"
                   (default: "predicted" with [localization] centre = "predicted", else "radial")
    [adjust]       cap (ms, the largest window), floor (cm/s, the lowest leader speed),
                   predictor = "paper" | "formation" | "hybrid" | "commands"
                   (rtsim.control.predict), lower_bound = "w_sch" | "w_rta" | "w_susp",
                   decide = "end" | "before-send" (when in the window the decision is taken),
                   policy (default "plan"; rtsim.control.policy), predictor default "commands"
    [localization] centre = "predicted" | "previous", search = "visible" | "always" (defaults
                   first)
                   (where the Hough windows are centred; which lost followers are searched for)
    [world]        step_ms (integration step while a speed ramps)
    [assumptions]  key = "reason"      # every value the paper does not give

Every table but ``[leader]`` and ``[formation]`` is optional: the model choices left unsaid
are the ``preset``'s (the recommended model, as test1/test2, or the paper's), the numbers the
world's dataclasses' defaults.
Unknown keys are errors with a did-you-mean; every problem is one line of a
`ScenarioError`, ``<file>: <key>: <problem>``, all of them at once. The
path must close. The file is read and checked by `rtsim.config` (the model of the file
in `rtsim.config.scenario`, with every key's type, range and unit).
Initial state: see [`rtsim.world.World`][rtsim.world.World] (followers on their slots in steady
formation,
estimates = truth + N(0, init sd²)).
"""

from __future__ import annotations

from rtsim.config.scenario import (
    PACKAGED_SCENARIOS,
    PACKAGED_TASKSETS,
    AdjustConfig,
    Scenario,
    load_scenario,
    parse_scenario,
    scenario_bytes,
)
from rtsim.errors import ScenarioError  # noqa: F401  (re-exported: older imports)

__all__ = [
    "AdjustConfig",
    "Scenario",
    "load_scenario",
    "parse_scenario",
    "scenario_bytes",
    "PACKAGED_SCENARIOS",
    "PACKAGED_TASKSETS",
]
