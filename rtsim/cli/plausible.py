"""Values that are valid but almost certainly a mistake of unit, refused with a one-line hint
naming the unit unless ``--force``.

The ranges of `rtsim.io.limits` refuse what cannot be meant (a negative radius, a
horizon of 1e15 ms); these checks catch what is easy to type by mistake: a horizon given in
seconds (``--horizon 60``: shorter than one processing window), a Hough radius in metres
(``--hough-radius 0.25``: a quarter of a centimetre), a duration in milliseconds
(``--duration 60000``: 16.7 simulated hours, beyond the six the work limits admit).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from rtsim.errors import InputError

__all__ = [
    "MIN_HOUGH_RADIUS_CM",
    "MAX_DURATION_S",
    "refuse",
    "check_hough_radius",
    "check_duration",
    "check_horizon",
    "check_scenario_units",
    "periods_ms",
    "short_horizon",
    "warn_short_horizon",
]

#: A Hough window smaller than this (cm) is far below a robot's size (the paper's is 25 cm).
MIN_HOUGH_RADIUS_CM = 1.0
#: A scenario longer than this (simulated seconds): six simulated hours, the longest run the
#: work limits admit by default; ``--duration 60000`` (60 s meant in ms) is 16.7 hours.
MAX_DURATION_S = 21_600.0


def refuse(args: Any, message: str) -> None:
    """Raise the one-line hint ``message`` unless ``args.force``."""
    if not getattr(args, "force", False):
        raise InputError(f"{message}; --force runs it anyway")


def check_hough_radius(args: Any, values: Iterable[float], option: str = "--hough-radius") -> None:
    """r_H below 1 cm: probably metres."""
    for r in values:
        if 0 < r < MIN_HOUGH_RADIUS_CM:
            refuse(
                args,
                f"{option} is in cm: {r:g} cm is under {MIN_HOUGH_RADIUS_CM:g} cm "
                f"(did you mean {r * 100:g} cm, given in metres?)",
            )


def check_duration(args: Any, seconds: float | None, option: str = "--duration") -> None:
    """A scenario duration over six simulated hours: probably milliseconds."""
    if seconds is not None and seconds > MAX_DURATION_S:
        refuse(
            args,
            f"{option} is in simulated seconds: {seconds:g} s is "
            f"{seconds / 3600:.1f} simulated hours, over {MAX_DURATION_S / 3600:g} "
            f"(did you mean "
            f"{seconds / 1000:g} s, given in ms?)",
        )


def check_horizon(
    args: Any,
    horizon: float,
    window: float | None,
    option: str = "--horizon",
    periods: Iterable[float] = (),
) -> None:
    """A horizon shorter than one processing window: probably seconds, refused. Shorter than
    the longest of ``periods`` (ms): `short_horizon`'s warning, on stderr once every
    input is checked (the task releases one job)."""
    if window is not None and 0 < horizon < window:
        refuse(
            args,
            f"{option} is in ms: {horizon:g} ms is shorter than one window "
            f"({window:.1f} ms) (did you mean {horizon * 1000:g} ms, given in "
            f"seconds?)",
        )
    args._short_horizon = short_horizon(horizon, periods, option)


def short_horizon(horizon: float, periods: Iterable[float], option: str = "--horizon") -> str:
    """The warning for a horizon shorter than the longest period (ms), or ``""``."""
    longest = max((float(p) for p in periods), default=0.0)
    if not 0 < horizon < longest:
        return ""
    return (
        f"rtsim: warning: {option} is in ms: {horizon:g} ms is shorter than the longest "
        f"period ({longest:g} ms), whose task releases one job (did you mean "
        f"{horizon * 1000:g} ms, given in seconds?)"
    )


def warn_short_horizon(args: Any) -> None:
    """Print `check_horizon`'s warning, if any, on stderr (unless ``--quiet``)."""
    import sys

    text = getattr(args, "_short_horizon", "")
    if text and not getattr(args, "quiet", False):
        print(text, file=sys.stderr)


def periods_ms(ts: Any, window: float | None) -> list[float]:
    """The task set's periods in ms (a per-window period in windows of ``window`` ms)."""
    return [
        float(t.period) * (window or 0.0) if t.per_window else float(t.period) for t in ts.tasks
    ]


def check_scenario_units(args: Any, scenario: Any) -> None:
    """The same hints for a scenario's file keys (also when set by ``--set``): ``sensing.r_H``
    in metres, ``duration`` in ms."""
    where = scenario.source or "<scenario>"
    check_hough_radius(args, [scenario.world.thresholds.r_H], f"{where}: sensing.r_H")
    if scenario.duration:
        check_duration(args, scenario.duration, f"{where}: duration")
