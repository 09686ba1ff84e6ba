"""Values that are valid but almost certainly a mistake of unit, refused with a one-line hint
naming the unit unless ``--force``.

The ranges of :mod:`rtsim.io.limits` refuse what cannot be meant (a negative radius, a
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
    args: Any, horizon: float, window: float | None, option: str = "--horizon"
) -> None:
    """A horizon shorter than one processing window (or, without one, than the longest
    period): probably seconds."""
    if window is not None and 0 < horizon < window:
        refuse(
            args,
            f"{option} is in ms: {horizon:g} ms is shorter than one window "
            f"({window:.1f} ms) (did you mean {horizon * 1000:g} ms, given in "
            f"seconds?)",
        )
