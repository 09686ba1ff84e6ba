"""The accepted range of every numeric input: task-set keys, scenario keys, CLI options.

Each range is finite (or says where ``inf`` is meaningful), physically sensible and has a
unit and a reason; a value outside it is refused when the input is read, with one line
that names the file and key (or the option): ``test2.toml: leader.speed: 5000 cm/s is
outside (0, 1000] cm/s (...)``. The table in ``docs/input_ranges.md`` is generated from
this registry (``python -m rtsim.io.limits > docs/input_ranges.md``; a test keeps them
equal).

Keys: ``taskset: <key>``, ``scenario: <key>`` (entries of a list, such as
``leader.path``, without an index; angles in radians: a ``_deg`` key is converted first)
and ``option: --<name>``. A new numeric key joins with one line::

    register("scenario: leader.speed", 0, 1000, "cm/s", "why this range", lo_open=True)

With ``RTSIM_STRICT_RANGES=1`` (the test suite sets it) a numeric key that has no range
raises :class:`UnregisteredKey`, so a key added without one fails the tests.
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any, TypeVar

from rtsim._numbers import is_int, is_real
from rtsim.errors import InputError

T = TypeVar("T")

__all__ = ["Range", "REGISTRY", "register", "check", "check_tree", "parse_checked", "strict",
           "UnregisteredKey", "render_markdown", "read_input", "MAX_INPUT_BYTES"]


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

    def text(self) -> str:
        """``(0, 1000] cm/s``."""
        lo = "(" if self.lo_open else "["
        hi = ")" if self.hi_open else "]"
        extra = " or inf" if self.inf else ""
        unit = f" {self.unit}" if self.unit else ""
        kind = " (integer)" if self.integer else ""
        return f"{lo}{self.lo:g}, {self.hi:g}{hi}{unit}{extra}{kind}"

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


def register(key: str, lo: float, hi: float, unit: str, why: str, *, lo_open: bool = False,
             hi_open: bool = False, inf: bool = False, integer: bool = False) -> Range:
    """Add (or replace) the range of ``key``; both ends must be finite."""
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
        raise ValueError(f"{key}: a range needs finite lo <= hi, got {lo}, {hi}")
    r = Range(key, float(lo), float(hi), unit, why, lo_open, hi_open, inf, integer)
    REGISTRY[key] = r
    return r


def strict() -> bool:
    """Whether an unregistered numeric key is an error (``RTSIM_STRICT_RANGES=1``)."""
    return os.environ.get("RTSIM_STRICT_RANGES", "") not in ("", "0")


def check(key: str, value: Any, where: str, error: type[InputError] = InputError,
          magnitude_only: bool = False) -> None:
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
            raise UnregisteredKey(f"{key}: numeric input without a range; register it in "
                                  "rtsim/io/limits.py (one line)")
        return
    v = float(value)
    if magnitude_only and not (r.hi < v < math.inf or 0 < v < r.lo):
        return
    if not r.admits(v):
        unit = f" {r.unit}" if r.unit else ""
        shown = str(int(value)) if is_int(value) else f"{v:.6g}"
        raise error(f"{where}: {shown}{unit} is outside {r.text()} ({r.why})")


def _leaves(data: Any, key: str, where: str) -> Iterator[tuple[str, Any, str]]:
    if isinstance(data, Mapping):
        for k, v in data.items():
            yield from _leaves(v, f"{key}.{k}" if key else str(k),
                               f"{where}.{k}" if where else str(k))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            yield from _leaves(v, key, f"{where}[{i + 1}]")
    else:
        yield key, data, where


def check_tree(kind: str, data: Mapping[str, Any], source: str,
               skip: tuple[str, ...] = (), magnitude_only: bool = False) -> None:
    """Check every numeric leaf of a parsed file (``kind``: ``taskset`` or ``scenario``)
    against ``<kind>: <dotted key>``; ``skip``: top-level tables not checked here;
    ``magnitude_only`` as in :func:`check`."""
    from rtsim.errors import ScenarioError, TaskSetError

    error = {"taskset": TaskSetError, "scenario": ScenarioError}.get(kind, InputError)
    if not isinstance(data, Mapping):
        return
    for key, value, where in _leaves(data, "", ""):
        if key.split(".")[0] in skip or isinstance(value, bool) or not is_real(value):
            continue
        if key.endswith("_deg"):
            key, value = key[:-4], math.radians(float(value)) if math.isfinite(value) else value
            where += " (in radians)"
        check(f"{kind}: {key}", value, f"{source}: {where}", error, magnitude_only)


def parse_checked(kind: str, parse: Callable[[], T], data: Mapping[str, Any], source: str,
                  skip: tuple[str, ...] = ("assumptions",)) -> T:
    """``parse()`` of a file's parsed ``data``, then every number checked (:func:`check_tree`).
    When the parse fails because a value is far out of range (an InputError), or an extreme
    value broke a computation (ArithmeticError, ValueError), the range error is raised
    instead, naming the key."""
    try:
        out = parse()
    except InputError:  # caused by a value far out of range? then say that
        check_tree(kind, data, source, skip=skip, magnitude_only=True)
        raise
    except (ArithmeticError, ValueError):  # an extreme value broke a computation: say which
        check_tree(kind, data, source, skip=skip)
        raise
    check_tree(kind, data, source, skip=skip)
    return out


#: The largest input file rtsim reads (task sets, scenarios, sweep files are a few kB).
MAX_INPUT_BYTES = 16 * 1024 * 1024


def read_input(path: str | os.PathLike[str], what: str,
               max_bytes: int = MAX_INPUT_BYTES) -> bytes:
    """The bytes of input file ``path``, read at most ``max_bytes`` + 1 of them: a larger
    file (or an endless one, ``/dev/zero``) is an InputError naming it, and so is a FIFO or
    a socket (opened without waiting for a writer: reading one would block). OSError
    passes."""
    import stat

    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0)
    with open(path, "rb", opener=lambda p, _: os.open(p, flags)) as fh:
        mode = os.fstat(fh.fileno()).st_mode
        if stat.S_ISFIFO(mode) or stat.S_ISSOCK(mode):
            raise InputError(f"{os.fspath(path)}: a FIFO or socket, not a {what} file; give "
                             f"a regular file")
        return too_large(fh.read(max_bytes + 1), path, what, max_bytes)


def too_large(data: bytes, path: str | os.PathLike[str], what: str,
              max_bytes: int = MAX_INPUT_BYTES) -> bytes:
    """``data`` (read with a limit of ``max_bytes`` + 1), or an InputError if it is over."""
    if len(data) > max_bytes:
        raise InputError(f"{os.fspath(path)}: larger than {max_bytes // (1024 * 1024)} MiB; "
                         f"not a {what} file")
    return data


def render_markdown() -> str:
    """``docs/input_ranges.md``: one table per kind of input."""
    lines = ["# Input ranges", "",
             "Every numeric input rtsim reads has a finite, physically sensible range; a value",
             "outside it is refused when the input is read (exit 2, one line naming the file",
             "and key, or the option). Generated from `rtsim/io/limits.py` by",
             "`python -m rtsim.io.limits > docs/input_ranges.md` (a test keeps them equal).",
             "Angles are radians (a `_deg` key is converted first). `inf` in a range: the key",
             "also takes `inf`, meaning none.", ""]
    titles = {"taskset": "Task-set files", "scenario": "Scenario files",
              "option": "Command-line options (and the same options in sweep files)"}
    for kind, title in titles.items():
        lines += [f"## {title}", "", "| key | range | why |", "|---|---|---|"]
        for key in sorted(k for k in REGISTRY if k.startswith(f"{kind}: ")):
            r = REGISTRY[key]
            lines.append(f"| `{key.split(': ', 1)[1]}` | {r.text()} | {r.why} |")
        lines.append("")
    return "\n".join(lines)


# ----------------------------------------------------------------------- the ranges
_MS_MAX = 1e9  # ms: 11.6 days, beyond any run rtsim is made for
_CM_MAX = 1e7  # cm: 100 km
_ANGLE = 20 * math.pi

_TS = "taskset: "
for _k in ("wcet", "bcet"):
    register(_TS + f"tasks.{_k}", 0, 1e7, "ms", "at most 2.8 h of CPU per job",
             lo_open=_k == "wcet")
register(_TS + "tasks.period", 1e-3, _MS_MAX, "ms", "1 µs (a timer tick) to 11.6 days")
register(_TS + "tasks.deadline", 1e-3, _MS_MAX, "ms", "as the period")
register(_TS + "tasks.offset", 0, _MS_MAX, "ms", "within 11.6 days of the start")
register(_TS + "tasks.jitter", 0, _MS_MAX, "ms", "as the offset")
register(_TS + "tasks.priority", -1e9, 1e9, "", "an integer rank", integer=True)
register(_TS + "overhead", 0, 1e4, "ms", "a context switch of at most 10 s")
register(_TS + "window.n", 1, 1000, "followers",
         "the laser (361 beams) cannot tell more followers apart", integer=True)
register(_TS + "window.priority", -1e9, 1e9, "", "an integer rank", integer=True)
register(_TS + "window.r_H", 0, 1e4, "cm", "a Hough window of at most 100 m (the laser's "
         "range is 80 m)", lo_open=True)
register(_TS + "window.e_cal", 0, 1e3, "ms", "per accumulator cell")
register(_TS + "window.e_trans", 0, 1e3, "ms", "per scan point")
register(_TS + "window.k", 0, 361, "points", "a follower returns at most the 361 beams",
         lo_open=True)
register(_TS + "window.k_value", 0, 361, "points", "as k", lo_open=True)
register(_TS + "window.rho_min", 25, 1e5, "cm", "beyond the follower radius r_F = 25 cm, "
         "within 1 km", lo_open=True)
for _k in ("e_scan", "e_estimate", "e_send", "e_recv", "delta_t", "e_sched"):
    register(_TS + f"window.{_k}", 0, 1e7, "ms", "a chain step of at most 2.8 h")
register(_TS + "window.offset", 0, _MS_MAX, "ms", "as a task's offset: the first window "
         "arrives then; per-window tasks count their offsets from it")
register(_TS + "window.jitter", 0, _MS_MAX, "ms", "as a task's jitter: each window job is "
         "released up to J after its arrival")

_SC = "scenario: "
register(_SC + "duration", 0, 1e6, "s", "up to 11.6 simulated days", lo_open=True)
register(_SC + "leader.speed", 0, 1000, "cm/s", "a ground robot at most 10 m/s", lo_open=True)
register(_SC + "leader.start_s", 0, _CM_MAX, "cm", "a position along the path (within one "
         "lap, checked against the path's length)")
for _k in ("x", "y"):
    register(_SC + f"leader.start.{_k}", -_CM_MAX, _CM_MAX, "cm", "within 100 km")
register(_SC + "leader.start.heading", -_ANGLE, _ANGLE, "rad", "ten turns either way")
register(_SC + "leader.path.straight", 0, _CM_MAX, "cm", "a straight of at most 100 km",
         lo_open=True)
register(_SC + "leader.path.radius", 1, _CM_MAX, "cm",
         "a turn tighter than 1 cm is a spin in place, not an arc")
register(_SC + "leader.path.angle", 0, _ANGLE, "rad", "up to ten full turns", lo_open=True)
for _k in ("length", "width"):
    register(_SC + f"leader.shape.{_k}", 0, _CM_MAX, "cm", "at most 100 km")
register(_SC + "leader.shape.radius", 1, _CM_MAX, "cm", "as a path turn's radius")
for _k in ("accel_max", "decel_max"):
    register(_SC + f"leader.{_k}", 0, 1e5, "cm/s²", "at most 100 g; inf: the speed steps",
             lo_open=True, inf=True)
register(_SC + "formation.followers", 1, 1000, "followers", "as window.n", integer=True)
register(_SC + "formation.separation", 0, 1e5, "cm", "at most 1 km (the laser sees 80 m)",
         lo_open=True)
register(_SC + "formation.bearing_offset", -_ANGLE, _ANGLE, "rad", "an angle")
register(_SC + "formation.slot.rho_d", 0, 1e5, "cm", "as separation", lo_open=True)
register(_SC + "formation.slot.beta_d", -_ANGLE, _ANGLE, "rad", "an angle")
register(_SC + "follower.radius", 0, 1e3, "cm", "a robot of at most 10 m", lo_open=True)
register(_SC + "follower.max_speed", 0, 1000, "cm/s", "as leader.speed", lo_open=True)
register(_SC + "follower.max_accel", 0, 1e5, "cm/s²", "at most 100 g", lo_open=True)
register(_SC + "follower.max_turn_rate", 0, 1e3, "rad/s", "inf: no limit", lo_open=True,
         inf=True)
register(_SC + "follower.control_offset", 0, 1e3, "cm", "a control point within 10 m",
         lo_open=True)
for _k in ("gain_rho", "gain_beta"):
    register(_SC + f"follower.{_k}", 0, 1e3, "1/s", "a controller gain", lo_open=True)
register(_SC + "follower.lookahead", 0, 1e4, "cm", "pure pursuit's look-ahead, within 100 m",
         lo_open=True)
register(_SC + "follower.speed_noise", 0, 1e3, "cm/s", "a noise standard deviation")
register(_SC + "follower.turn_noise", 0, 100, "rad/s", "a noise standard deviation")
register(_SC + "sensing.r_H", 0, 1e4, "cm", "as window.r_H", lo_open=True)
register(_SC + "sensing.r_reacq", 0, 1e5, "cm", "a search radius within 1 km", lo_open=True)
register(_SC + "sensing.position_noise", 0, 1e4, "cm", "a noise standard deviation")
register(_SC + "sensing.min_points", 1, 361, "points", "at most the 361 beams", integer=True)
register(_SC + "sensing.max_range", 0, 1e7, "cm", "inf: unlimited", lo_open=True, inf=True)
for _k, _u in (("measurement_noise", "cm"), ("speed_noise", "cm/s"),
               ("position_drift", "cm"), ("init_position_sd", "cm")):
    register(_SC + f"ekf.{_k}", 0, 1e4, _u, "a noise standard deviation")
for _k, _u in (("turn_noise", "rad/s"), ("heading_drift", "rad"),
               ("init_heading_sd", "rad")):
    register(_SC + f"ekf.{_k}", 0, 100, _u, "a noise standard deviation")
for _k in ("T_rho", "T_eps"):
    register(_SC + f"thresholds.{_k}", 0, 10, "", "a fraction of the desired separation",
             lo_open=True)
register(_SC + "thresholds.T_beta", 0, math.pi, "rad", "a bearing error below 180°",
         lo_open=True)
register(_SC + "adjust.cap", 0, _MS_MAX, "ms", "inf: no cap", lo_open=True, inf=True)
register(_SC + "adjust.floor", 0, 1000, "cm/s", "as leader.speed")
register(_SC + "adjust.margin", 0, 1, "", "the share μ of each predicted bound kept in reserve "
         "(policies margin, lookahead, noise-aware, safe)", hi_open=True)
register(_SC + "adjust.windows", 1, 100, "windows", "policies lookahead and safe: the "
         "horizon, in windows of w_sch")
register(_SC + "adjust.z", 0, 10, "σ", "policies noise-aware and safe: the padding of the "
         "predicted V_F, |ρ̇|, |β̇| in standard deviations")
register(_SC + "world.step_ms", 1e-3, 1e4, "ms", "1 µs to 10 s per integration step")

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
register(_OP + "--utilization", 0, 100, "", "total utilization (above 1 on purpose only)",
         lo_open=True)
register(_OP + "--tasks", 1, 1e4, "tasks", "tasks per generated set", integer=True)
register(_OP + "--count", 1, 1e6, "sets", "generated task sets", integer=True)
register(_OP + "--random-sets", 0, 1e6, "sets", "random sets checked", integer=True)
register(_OP + "--point", 0, 1e5, "", "a point index (a grid has at most 1e5 points)",
         integer=True)
register(_OP + "--histograms", 0, 1e4, "", "histogram sets written", integer=True)
register(_OP + "--bins", 1, 1e5, "bins", "histogram bins", integer=True)
register(_OP + "--dpi", 50, 1200, "dots/inch", "resolution of PNG figures", integer=True)
register(_OP + "--fps", 1, 240, "frames/s", "an animation frame rate", integer=True)
register(_OP + "--every", 1, 1e6, "windows", "one frame per this many windows", integer=True)
register(_OP + "--start", 0, 1e6, "s", "as --duration")
register(_OP + "--end", 0, 1e6, "s", "as --duration")


if __name__ == "__main__":  # pragma: no cover - exercised by the docs test via render
    sys.stdout.write(render_markdown() + "\n")
