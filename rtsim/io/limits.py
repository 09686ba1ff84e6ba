"""The accepted range of every numeric command-line option, the `Range` type, and the
size limit of input files.

Each range is finite (or says where ``inf`` is meaningful), physically sensible and has a
unit and a reason; a value outside it is refused, with one line that names the option:
``--horizon: 1e+15 ms is outside (0, 1e+09] ms (...)``. The ranges of the keys of input files
are metadata of their models (`rtsim.config`); ``docs/input_ranges.md`` is generated
from both (`rtsim.config.docs`). A new numeric option joins with one line::

    register("option: --horizon", 0, 1e9, "ms", "why this range", lo_open=True)

With ``RTSIM_STRICT_RANGES=1`` (the test suite sets it) a numeric option that has no range
raises `UnregisteredKey`, so an option added without one fails the tests.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any

from rtsim._numbers import is_int, is_real
from rtsim.errors import InputError

__all__ = [
    "Range",
    "REGISTRY",
    "register",
    "check",
    "strict",
    "UnregisteredKey",
    "read_input",
    "too_large",
    "MAX_INPUT_BYTES",
    "WINDOW_N",
    "WINDOW_R_H",
]


class UnregisteredKey(RuntimeError):
    """A numeric input key has no registered range (raised only in strict mode)."""


@dataclass(frozen=True)
class Range:
    """The accepted values of one key: ``lo`` to ``hi`` in ``unit``, each end open or
    closed; ``inf``: ``inf`` itself is accepted too (it means "none")."""

    key: str
    lo: float
    hi: float
    unit: str
    why: str
    lo_open: bool = False
    hi_open: bool = False
    inf: bool = False
    integer: bool = False

    def interval(self) -> str:
        """``(0, 1000]``."""
        lo = "(" if self.lo_open else "["
        hi = ")" if self.hi_open else "]"
        return f"{lo}{self.lo:g}, {self.hi:g}{hi}"

    def text(self) -> str:
        """``(0, 1000] cm/s``."""
        extra = " or inf" if self.inf else ""
        unit = f" {self.unit}" if self.unit else ""
        kind = " (integer)" if self.integer else ""
        return f"{self.interval()}{unit}{extra}{kind}"

    def admits(self, value: float) -> bool:
        if self.inf and value == math.inf:
            return True
        if not math.isfinite(value):
            return False
        above = value > self.lo if self.lo_open else value >= self.lo
        below = value < self.hi if self.hi_open else value <= self.hi
        return above and below


#: Every registered range, by key.
REGISTRY: dict[str, Range] = {}


def register(
    key: str,
    lo: float,
    hi: float,
    unit: str,
    why: str,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    inf: bool = False,
    integer: bool = False,
) -> Range:
    """Add (or replace) the range of ``key``; both ends must be finite."""
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
        raise ValueError(f"{key}: a range needs finite lo <= hi, got {lo}, {hi}")
    r = Range(key, float(lo), float(hi), unit, why, lo_open, hi_open, inf, integer)
    REGISTRY[key] = r
    return r


def strict() -> bool:
    """Whether an unregistered numeric key is an error (``RTSIM_STRICT_RANGES=1``)."""
    return os.environ.get("RTSIM_STRICT_RANGES", "") not in ("", "0")


def check(
    key: str,
    value: Any,
    where: str,
    error: type[InputError] = InputError,
    magnitude_only: bool = False,
) -> None:
    """Refuse ``value`` of ``key`` outside its range: an InputError ``<where>: <problem>``.

    Not a number: nothing to check here (the parser says what it expects). An unregistered
    key passes, except in strict mode. ``magnitude_only``: only a finite value above the
    range, or positive and below it, is refused (a sign, a zero, an infinity or an unknown
    key is left to the parser's message).
    """
    if not is_real(value):
        return
    r = REGISTRY.get(key)
    if r is None:
        if strict() and not magnitude_only:  # (an unknown key: the parser's error stands)
            raise UnregisteredKey(
                f"{key}: numeric input without a range; register it in "
                "rtsim/io/limits.py (one line)"
            )
        return
    v = float(value)
    if magnitude_only and not (r.hi < v < math.inf or 0 < v < r.lo):
        return
    if not r.admits(v):
        unit = f" {r.unit}" if r.unit else ""
        shown = str(int(value)) if is_int(value) else f"{v:.6g}"
        raise error(f"{where}: {shown}{unit} is outside {r.text()} ({r.why})")


#: The largest input file rtsim reads (task sets, scenarios, sweep files are a few kB).
MAX_INPUT_BYTES = 16 * 1024 * 1024


def read_input(path: str | os.PathLike[str], what: str, max_bytes: int = MAX_INPUT_BYTES) -> bytes:
    """The bytes of input file ``path``, read at most ``max_bytes`` + 1 of them: a larger
    file (or an endless one, ``/dev/zero``) is an InputError naming it, and so is a FIFO or
    a socket (opened without waiting for a writer: reading one would block). OSError
    passes."""
    import stat

    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0)
    with open(path, "rb", opener=lambda p, _: os.open(p, flags)) as fh:
        mode = os.fstat(fh.fileno()).st_mode
        if stat.S_ISFIFO(mode) or stat.S_ISSOCK(mode):
            raise InputError(
                f"{os.fspath(path)}: a FIFO or socket, not a {what} file; give a regular file"
            )
        return too_large(fh.read(max_bytes + 1), path, what, max_bytes)


def too_large(
    data: bytes, path: str | os.PathLike[str], what: str, max_bytes: int = MAX_INPUT_BYTES
) -> bytes:
    """``data`` (read with a limit of ``max_bytes`` + 1), or an InputError if it is over."""
    if len(data) > max_bytes:
        raise InputError(
            f"{os.fspath(path)}: larger than {max_bytes // (1024 * 1024)} MiB; not a {what} file"
        )
    return data


# ----------------------------------------------------------------------- the ranges
_MS_MAX = 1e9  # ms: 11.6 days, beyond any run rtsim is made for

_OP = "option: "
register(_OP + "--horizon", 0, _MS_MAX, "ms", "11.6 days of simulated time", lo_open=True)
register(_OP + "--window", 1e-3, _MS_MAX, "ms", "as a task period")
register(_OP + "--overhead", 0, 1e4, "ms", "as the task-set key overhead")
register(_OP + "--granularity", 0, _MS_MAX, "ms", "a time step", lo_open=True)
register(_OP + "--followers", 1, 1000, "followers", "as window.n", integer=True)
register(_OP + "--hough-radius", 0, 1e4, "cm", "as window.r_H", lo_open=True)
register(_OP + "--duration", 0, 1e6, "s", "as the scenario key duration", lo_open=True)
register(_OP + "--seed", 0, 2**63 - 1, "", "a non-negative 63-bit integer", integer=True)
register(_OP + "--workers", 1, 4096, "processes", "local worker processes", integer=True)
register(_OP + "--windows", 1, 2e6, "windows", "as the work limit on windows", integer=True)
register(
    _OP + "--utilization", 0, 100, "", "total utilization (above 1 on purpose only)", lo_open=True
)
register(_OP + "--tasks", 1, 1e4, "tasks", "tasks per generated set", integer=True)
register(_OP + "--count", 1, 1e6, "sets", "generated task sets", integer=True)
register(_OP + "--random-sets", 0, 1e6, "sets", "random sets checked", integer=True)
register(_OP + "--point", 0, 1e5, "", "a point index (a grid has at most 1e5 points)", integer=True)
register(_OP + "--histograms", 0, 1e4, "", "histogram sets written", integer=True)
register(_OP + "--bins", 1, 1e5, "bins", "histogram bins", integer=True)
register(_OP + "--dpi", 50, 1200, "dots/inch", "resolution of PNG figures", integer=True)
register(_OP + "--fps", 1, 240, "frames/s", "an animation frame rate", integer=True)
register(_OP + "--every", 1, 1e6, "windows", "one frame per this many windows", integer=True)
register(_OP + "--start", 0, 1e6, "s", "as --duration")
register(_OP + "--end", 0, 1e6, "s", "as --duration")

# The two keys of a task set's [window] that callers change on a built task set
# (TaskSet.with_window, window_bounds(n=, r_H=), a scenario's follower count): the model's
# WindowSpec checks them itself, and the task-set file's model takes its ranges from here.
WINDOW_N = register(
    "taskset: window.n",
    1,
    1000,
    "followers",
    "the laser (361 beams) cannot tell more followers apart",
    integer=True,
)
WINDOW_R_H = register(
    "taskset: window.r_H",
    0,
    1e4,
    "cm",
    "a Hough window of at most 100 m (the laser's range is 80 m)",
    lo_open=True,
)
