"""The paper's processing-window job T_w as a spec: constants and segment chain, and its cost
on numbers, e_hough (Eq 1) and g (Eq 5/6) (docs/model/index.md, docs/model/lower-bound.md;
`rtsim.analysis.window` holds the bounds built on them)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

from rtsim._numbers import is_int
from rtsim.errors import TaskSetError
from rtsim.io.limits import check
from rtsim.model.task import Segment, check_time

__all__ = ["LASER_POINTS", "TIMES", "WindowSpec", "e_hough", "g_window"]


#: Scan points of the laser rangefinder: 361 beams over 180°, 0.5° apart.
LASER_POINTS = 361
#: The chain's time constants (ms) of a `WindowSpec`, in the order of its fields.
TIMES: tuple[str, ...] = (
    "e_cal", "e_trans", "e_scan", "e_estimate", "e_send", "e_recv", "delta_t", "e_sched"
)  # fmt: skip


def e_hough(
    n: int, r_H: float, e_cal: float, e_trans: float, k: float, points: float | None = None
) -> float:
    """Localization time, Eq 1: π·r_H²·n·e_cal + min(361, k·n)·e_trans.

    ``points`` replaces the worst case min(361, k·n) with the scan points actually
    counted (the simulation's view, docs/model/lower-bound.md).
    """
    pts = min(LASER_POINTS, k * n) if points is None else points
    return math.pi * r_H**2 * n * e_cal + pts * e_trans


def g_window(
    n: int,
    e_hough_ms: float,
    e_scan: float,
    e_estimate: float,
    e_send: float,
    e_recv: float,
    delta_t: float,
    e_sched: float,
) -> float:
    """Processing time of one window, Eq 5/6.

    g = e_scan + e_hough + n·(e_recv + e_send + e_estimate) + Δt + e_sched.
    """
    return e_scan + e_hough_ms + n * (e_recv + e_send + e_estimate) + delta_t + e_sched


@dataclass(frozen=True)
class WindowSpec:
    """Constants of the processing-window chain (times in ms, r_H in cm).

    The chain, in order: scan → localization (Hough) → (estimate, send) per follower →
    radio round trip Δt (a suspension) → receive per follower → scheduler cost e_sched.
    ``rho_min`` (cm) is set when k is the geometric bound for followers at distance ≥ rho_min
    (``k = "geometric"`` in a file; k then holds that count, docs/model/lower-bound.md).
    ``jitter`` and ``offset`` (ms) are the window task's release jitter and first arrival,
    as for any task ([`Task`][rtsim.model.task.Task]): window job k arrives at
    offset + (the sum of the windows before it) and is released up to ``jitter`` later; its
    deadline (one window) counts from the arrival. Tasks with per-window periods count their
    offsets from the window's.
    """

    n: int
    r_H: float
    e_cal: float
    e_trans: float
    k: float
    e_scan: float
    e_estimate: float
    e_send: float
    e_recv: float
    delta_t: float
    e_sched: float
    priority: int
    name: str = "window"
    rho_min: float | None = None
    jitter: float = 0.0
    offset: float = 0.0

    def __post_init__(self) -> None:
        where = f"window '{self.name}'"
        if not is_int(self.n) or self.n < 1:
            raise TaskSetError(f"{where}: n must be a positive integer, got {self.n!r}")
        if not is_int(self.priority):
            raise TaskSetError(f"{where}: priority must be an integer, got {self.priority!r}")
        object.__setattr__(self, "n", int(self.n))
        object.__setattr__(self, "priority", int(self.priority))
        object.__setattr__(self, "r_H", check_time(where, "r_H", self.r_H))

        for field in ("n", "r_H"):  # the keys a caller changes (with_window, --followers)
            check(
                f"taskset: window.{field}", getattr(self, field), f"{where}: {field}", TaskSetError
            )
        object.__setattr__(self, "k", check_time(where, "k", self.k))
        if self.rho_min is not None:
            object.__setattr__(self, "rho_min", check_time(where, "rho_min", self.rho_min))
        for field in (*TIMES, "jitter", "offset"):
            value = check_time(where, field, getattr(self, field), allow_zero=True)
            object.__setattr__(self, field, value)

    def with_(self, **changes: Any) -> WindowSpec:
        """A copy with some constants changed (validated again)."""
        return replace(self, **changes)

    def e_hough(self, points: float | None = None) -> float:
        """Localization time, Eq 1 (worst case k·n points unless ``points`` is given)."""
        return e_hough(self.n, self.r_H, self.e_cal, self.e_trans, self.k, points)

    def g(self, e_hough_ms: float | None = None) -> float:
        """Processing time of one window, Eq 5/6."""
        eh = self.e_hough() if e_hough_ms is None else e_hough_ms
        return g_window(
            self.n,
            eh,
            self.e_scan,
            self.e_estimate,
            self.e_send,
            self.e_recv,
            self.delta_t,
            self.e_sched,
        )

    def segments(self, e_hough_ms: float | None = None) -> tuple[Segment, ...]:
        """The chain of one window job; its wcets add up to g (Eq 5)."""
        eh = self.e_hough() if e_hough_ms is None else e_hough_ms
        segs = [Segment("scan", self.e_scan, role="scan"), Segment("hough", eh, role="hough")]
        for i in range(1, self.n + 1):
            segs.append(Segment(f"estimate[{i}]", self.e_estimate, role="estimate", follower=i))
            segs.append(Segment(f"send[{i}]", self.e_send, role="send", follower=i))
        segs.append(Segment("radio", self.delta_t, "suspend", role="radio"))
        for i in range(1, self.n + 1):
            segs.append(Segment(f"recv[{i}]", self.e_recv, role="recv", follower=i))
        segs.append(Segment("sched", self.e_sched, role="sched"))
        return tuple(segs)

    def as_dict(self) -> dict[str, Any]:
        """Plain dict of the constants (for JSON and manifests); a geometric k is written as
        ``k = "geometric"`` with its ``rho_min`` (and ``k_value``, the count it stands for)."""
        out = asdict(self)
        for key in ("jitter", "offset"):  # written only when set (files from before stay)
            if not out[key]:
                del out[key]
        if self.rho_min is None:
            del out["rho_min"]
        else:
            out["k_value"], out["k"] = out["k"], "geometric"
        return out
