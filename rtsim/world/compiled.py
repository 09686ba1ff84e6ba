"""The world's arithmetic compiled with numba: the ``compiled`` backend (``[world] backend``).

The Python classes stay the reference; the classes here are subclasses that hand the same
expressions, in the same order, to compiled kernels, so the results are bit for bit the
Python ones (tests run both paths and compare whole runs):

- `CompiledFollowerGroup`: a follower's held command integrated to a time
  (`rtsim.world.motion.follower_advance` compiled) in one call;
- `CompiledFollowerEKF`: the EKF's predict and update
  (`rtsim.world.ekf.ekf_predict` and `ekf_update` compiled);
- `CompiledTraceFollower`: the follow-the-leader law's equations (`rtsim.world.ftl`:
  a command in one call, the projection and the trace's point for the truth log's
  cross-track error);
- `compiled_motion`: the leader's travel and one piece of its belief of a follower.

(The controller's rollout runs compiled on this law: `rtsim.control.compiled_rollout`.)

Only the operations whose compiled result is the interpreter's are compiled: + − × ÷,
``sqrt``, ``sin``, ``cos``, ``atan2``, ``abs``, ``copysign`` and ``%`` (numba calls the same C
library for the functions and follows Python's rules for ``%``). CPython computes
``math.hypot`` with an algorithm of its own; the kernels carry that algorithm
(`rtsim.world.exactmath.cpython_hypot`), checked against ``math.hypot`` when they load — where
this interpreter disagrees, the controller and the rollout run in Python instead; numba has
no ``math.remainder``, and the kernels carry CPython's (exact, with fmod).

numba is imported on first use (`available`); kernels are compiled once per machine and
cached on disk (keyed by a hash of their sources: `rtsim.world.jit`), so a later process
loads them in milliseconds; the classes call each build directly, not through numba's
dispatcher (`rtsim.world.kernels.entry`: the same machine code, no typing per call).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rtsim.world.ekf import EkfParams, FastFollowerEKF
from rtsim.world.follower import FollowerGroup
from rtsim.world.ftl import TraceFollower
from rtsim.world.kernels import available, entry, kernels
from rtsim.world.motionmodels import MotionModel
from rtsim.world.path import LeaderPath

__all__ = [
    "CompiledFollowerEKF",
    "CompiledFollowerGroup",
    "CompiledTraceFollower",
    "available",
    "compiled_motion",
    "kernels",
]


class CompiledFollowerGroup(FollowerGroup):
    """[`FollowerGroup`][rtsim.world.compiled.FollowerGroup] whose `advance` runs compiled."""

    @staticmethod
    def _kernel(motion: MotionModel) -> Any:
        # called directly (`entry`): twelve floats at every call
        return entry(kernels(motion).advance_follower, (0.0,) * 12)


def compiled_motion(motion: MotionModel) -> tuple[Any, Any]:
    """A motion model's ``step`` (the leader's belief over one held piece:
    `rtsim.world.motion.belief_step`) and ``leader`` (the leader's travel) compiled, each
    called directly (`entry`: floats at every call), for `rtsim.world.world.World`."""
    ker = kernels(motion)
    return entry(ker.belief_step, (0.0,) * 9), entry(ker.leader_travel, (0.0,) * 5)


class _Kernel:
    """A class attribute that reads kernel ``name`` of `kernels` on an instance's first use,
    compiles (or loads) it for ``args``' types and keeps its entry point on the instance
    (`entry`: every call passes those types): a kernel compiled only where it runs."""

    def __init__(self, name: str, args: tuple[Any, ...]) -> None:
        self.name, self.args = name, args

    def __get__(self, obj: Any, cls: Any = None) -> Any:
        if obj is None:
            return self
        fn = getattr(kernels(), self.name)
        fn(*self.args)
        fn = entry(fn, self.args)
        setattr(obj, self.attr, fn)
        return fn

    def __set_name__(self, owner: Any, name: str) -> None:
        self.attr = name


class CompiledFollowerEKF(FastFollowerEKF):
    """`FastFollowerEKF` whose predict and update run compiled (the predict without a
    command compiled at its first call: the shipped scenarios never make one)."""

    _predict = _Kernel("ekf_predict", (1.0,) * 16)

    def __init__(
        self, pose: tuple[float, float, float], params: EkfParams, motion: Any = None
    ) -> None:
        super().__init__(pose, params, motion)
        # (called directly, `entry`: floats at every call)
        self._update = entry(kernels().ekf_update, (0.0,) * 15)

    @staticmethod
    def _command_kernel(motion: Any) -> Any:
        return entry(kernels(motion).ekf_command, (0.0,) * 19)


class CompiledTraceFollower(TraceFollower):
    """`TraceFollower` whose equations run compiled, on arrays it owns (the Python twins, as
    `TraceFollower`, when the kernels' hypot is not this interpreter's: module docstring)."""

    def __init__(
        self, path: LeaderPath, rho_d: Any, lateral: Any, gain: float, lookahead: float
    ) -> None:
        super().__init__(path, rho_d, lateral, gain, lookahead)
        ker = kernels()
        if not ker.exact_hypot:  # this interpreter's hypot is not the kernels': Python
            return
        s0, poses, kappa, lap, lat, ahead, spacing = self.geometry
        self._G = (
            np.array(s0, dtype=float),
            np.array(poses, dtype=float),
            np.array(kappa, dtype=float),
            lap,
            np.array(lat, dtype=float),
            np.array(ahead, dtype=np.int64),
            np.array(spacing, dtype=float),
        )
        self._sr = np.array(self._sr, dtype=float)
        self._sf = np.array(self._sf, dtype=float)
        # (the arguments' types at every call: these arrays, an int k, floats)
        G, sr, sf, x = self._G, self._sr, self._sf, 0.0
        self._reference = entry(ker.ftl_reference, (G, sr, 0, x, x, x, x, x))
        self._command = entry(ker.ftl_command, (G, sr, sf, x, x, 0, x, x, x, x, x, x, x, x))
        self._project = entry(ker.ftl_project, (G, 0, x, x, x))
        self._point = entry(ker.trace_point, (G, 0, x))
