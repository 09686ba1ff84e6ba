"""Functions for ``kind = "call"`` sweeps in the sweep tests (importable by worker processes).

Not a test module: the tests put this directory on ``PYTHONPATH`` for subprocesses.
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np


def _log(params: dict[str, Any]) -> None:
    path = os.environ.get("RTSIM_SWEEP_TEST_LOG")
    if path:
        with open(path, "a", encoding="utf-8") as fh:
            fh.write(f"{params['i']}\n")


#: Points with i >= GATE_FROM wait for the file ``$RTSIM_SWEEP_TEST_GATE`` (when set) to exist.
GATE_FROM = 4


def slow(params: dict[str, Any], options: dict[str, Any], seed: int) -> dict[str, Any]:
    """Sleep, log the call (``$RTSIM_SWEEP_TEST_LOG``), return values derived from the inputs.

    With ``$RTSIM_SWEEP_TEST_GATE`` set, points from :data:`GATE_FROM` on first wait (up to
    60 s) for that file: a sweep interrupted in a test cannot have finished on a loaded
    machine before the signal arrives."""
    gate = os.environ.get("RTSIM_SWEEP_TEST_GATE")
    if gate and params["i"] >= GATE_FROM:
        deadline = time.monotonic() + 60
        while not os.path.exists(gate) and time.monotonic() < deadline:
            time.sleep(0.01)
    time.sleep(float(options.get("sleep", 0.0)))
    _log(params)
    return {"double": 2 * params["i"], "draw": float(np.random.default_rng(seed).random())}


def flaky(params: dict[str, Any], options: dict[str, Any], seed: int) -> dict[str, Any]:
    """Raise for ``i == options["fail_at"]``, else as :func:`slow`."""
    if params["i"] == options["fail_at"]:
        raise ValueError(f"point i={params['i']} is broken on purpose")
    return slow(params, options, seed)


def echo(params: dict[str, Any], options: dict[str, Any], seed: int) -> dict[str, Any]:
    """Return the parameters, the options and the seed as metrics."""
    out: dict[str, Any] = {f"p.{k}": v for k, v in params.items()}
    out.update({f"o.{k}": v for k, v in options.items()})
    out["s"] = seed
    return out


def nested(params: dict[str, Any], options: dict[str, Any], seed: int) -> dict[str, Any]:
    """Not flat: a point must fail with a clear message."""
    return {"a": {"b": 1}}


def odd(params: dict[str, Any], options: dict[str, Any], seed: int) -> dict[str, Any]:
    """Metrics that break a results table unless checked, chosen by ``params["case"]``."""
    case = params["case"]
    if case == "big":
        return {"x": 2**64}
    if case == "clash":
        return {1: 1.0, "1": 2.0}
    if case == "text":
        return {"x": "seven"}
    if case == "bool":
        return {"x": True}
    if case == "numpy":
        return {"x": np.int64(7), "y": np.float32(0.5), "z": np.bool_(True)}
    if case == "inf":
        return {"x": float("inf"), "y": float("-inf"), "z": float("nan")}
    if case == "renamed":  # "case" is the grid column: metric.case twice in the table
        return {"case": 1, "metric.case": 2}
    if case == "shadow":
        return {"case": 1}
    if case == "array":
        return {"x": np.arange(3)}
    return {"x": 1.5}


def die(params: dict[str, Any], options: dict[str, Any], seed: int) -> dict[str, Any]:
    """Kill this worker (SIGKILL) at ``i == options["die_at"]``; with ``options["once"]``
    (a file path) only the first time (the file marks it)."""
    import signal

    if params["i"] == options["die_at"]:
        once = options.get("once")
        if not once or not os.path.exists(once):
            if once:
                open(once, "w").close()
            os.kill(os.getpid(), signal.SIGKILL)
    time.sleep(float(options.get("sleep", 0.0)))
    return {"double": 2 * params["i"]}


def stuck_thread(params: dict[str, Any], options: dict[str, Any], seed: int) -> dict[str, Any]:
    """As :func:`slow`, after starting a non-daemon thread that never ends (the interpreter's
    exit would wait for it for ever)."""
    import threading

    threading.Thread(target=threading.Event().wait, name="stuck-by-the-point").start()
    return slow(params, options, seed)
