"""Progress of runs: a SimPy process that wakes every so much simulated time and reports how
far the run has come (`start_ticker`), and the progress bars of the command line
(``tqdm.auto`` on standard error: `progress_bar`, `SimulationBar`).

The ticker only reads (the clock, and what ``share`` reads); its wake-ups are events of their
own that no other process waits for, so a run with it makes the same decisions at the same
instants as a run without it (the CPU's clock jumps stop at a tick and resume after it:
`rtsim.sim.cpu`).
"""

from __future__ import annotations

import os
import signal
import sys
from collections.abc import Callable
from typing import Any

__all__ = [
    "Progress",
    "start_ticker",
    "TICKS",
    "progress_enabled",
    "progress_bar",
    "whole",
    "SimulationBar",
]

#: Reports per run (one per percent).
TICKS = 100

#: ``progress(share, t_ms)``: the share of the run done (0..1) and the simulated time (ms).
Progress = Callable[[float, float], Any]


def start_ticker(
    env: Any, every_ms: float, share: Callable[[float], float], progress: Progress
) -> Any:
    """Start a process on ``env`` that calls ``progress(share(now), now)`` every
    ``every_ms`` simulated ms (it never ends by itself: run the environment until a time
    or another process). Returns the process."""
    step = float(every_ms)
    if not step > 0:
        raise ValueError(f"progress: the tick must be positive, got {every_ms!r}")

    def tick() -> Any:
        while True:
            yield env.timeout(step)
            now = float(env.now)
            progress(min(1.0, max(0.0, share(now))), now)

    return env.process(tick())


def progress_enabled(args: Any = None) -> bool:
    """Whether to show progress bars: never with ``args.quiet`` (``-q``);
    ``RTSIM_PROGRESS=1``/``0`` decides; else when standard error is a terminal."""
    if getattr(args, "quiet", False):
        return False
    forced = os.environ.get("RTSIM_PROGRESS", "").strip()
    if forced in ("0", "1"):
        return forced == "1"
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):  # a closed or replaced stream
        return False


def progress_bar(
    args: Any, *, total: float | None, desc: str, unit: str = "it", **kwargs: Any
) -> Any:
    """A ``tqdm.auto`` bar on standard error, disabled (every call a no-op) unless
    `progress_enabled`."""
    from tqdm.auto import tqdm

    # no monitor thread: a process pool may fork after the bar opens (rtsim reproduce)
    tqdm.monitor_interval = 0
    return whole(
        lambda: tqdm(
            total=total,
            desc=desc,
            unit=unit,
            file=sys.stderr,
            leave=False,
            disable=not progress_enabled(args),
            dynamic_ncols=True,
            **kwargs,
        )
    )


#: The signals the command line turns into exceptions (Ctrl-C, and SIGTERM: `rtsim.cli`).
HELD = (signal.SIGINT, signal.SIGTERM)


def whole(make: Callable[[], Any]) -> Any:
    """``make()`` with SIGINT and SIGTERM held until it returns: a signal raised inside tqdm's
    ``__init__`` leaves a half-built bar whose ``__del__`` prints an ``AttributeError`` at
    exit, after the command's one line. A held signal is delivered when ``make`` returns
    (held in the calling thread: the command line's runs build their bars single-threaded)."""
    try:
        old = signal.pthread_sigmask(signal.SIG_BLOCK, HELD)
    except (AttributeError, ValueError, OSError):  # no pthread_sigmask, or not allowed here
        return make()
    try:
        return make()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


class SimulationBar:
    """A progress bar of one simulation run in percent, with the simulated seconds reached:
    the ``progress`` callback of [`rtsim.sim.simulate`][rtsim.sim.simulate] and
    [`rtsim.coupling.run_scenario`][rtsim.coupling.run_scenario]. A context manager (closes the
    bar)."""

    def __init__(self, args: Any, desc: str) -> None:
        self.bar = progress_bar(
            args,
            total=100,
            desc=desc,
            unit="%",
            bar_format="{desc}: {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}{postfix}]",
        )
        self.enabled = not self.bar.disable

    def __call__(self, share: float, t_ms: float) -> None:
        done = int(100 * share)
        if done > self.bar.n:
            self.bar.set_postfix_str(f"{t_ms / 1000.0:.0f} s simulated", refresh=False)
            self.bar.update(done - self.bar.n)
            if done >= 100:  # drawn once at the end even when the run beat tqdm's mininterval
                self.bar.refresh()

    def __enter__(self) -> SimulationBar:
        return self

    def __exit__(self, *exc: object) -> None:
        self.bar.close()
