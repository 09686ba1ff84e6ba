"""The world's arithmetic compiled with numba: the ``compiled`` backend (``[world] backend``).

The Python classes stay the reference; the classes here are subclasses that hand the same
expressions, in the same order, to compiled kernels, so the results are bit for bit the
Python ones (tests run both paths and compare whole runs):

- `CompiledFollowerGroup`: a follower's held command integrated to a time
  (`rtsim.world.motion.follower_advance` compiled) in one call;
- `CompiledFollowerEKF`: the EKF's predict and update
  (`rtsim.world.ekf.ekf_predict` and `ekf_update` compiled);
- `CompiledTraceFollower`: the follow-the-leader reference search, projection and
  control law (`TraceFollower.command`) in one call per command, and the projection
  alone (`TraceFollower.project`, the truth log's cross-track error).

(The controller's rollout runs compiled on this law: `rtsim.control.compiled_rollout`.)

Only the operations whose compiled result is the interpreter's are compiled: + − × ÷,
``sqrt``, ``sin``, ``cos``, ``atan2``, ``abs``, ``copysign`` and ``%`` (numba calls the same C
library for the functions and follows Python's rules for ``%``). CPython computes
``math.hypot`` with an algorithm of its own; the kernels carry that algorithm
(`rtsim.world.kernels._hypot`), checked against ``math.hypot`` when they load — where
this interpreter disagrees, the controller and the rollout run in Python instead; numba has
no ``math.remainder``, and the kernels carry CPython's (exact, with fmod).

numba is imported on first use (`available`); kernels are compiled once per machine
and cached on disk (keyed by a hash of their sources: `rtsim.world.jit`), so a later
process loads them in milliseconds.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rtsim.world.ekf import EkfParams, FastFollowerEKF
from rtsim.world.follower import FollowerGroup
from rtsim.world.ftl import TraceFollower
from rtsim.world.kernels import available, kernels
from rtsim.world.motionmodels import MotionModel
from rtsim.world.path import LeaderPath

__all__ = [
    "CompiledFollowerEKF",
    "CompiledFollowerGroup",
    "CompiledTraceFollower",
    "available",
    "kernels",
]


class CompiledFollowerGroup(FollowerGroup):
    """[`FollowerGroup`][rtsim.world.compiled.FollowerGroup] whose `advance` runs compiled."""

    @staticmethod
    def _kernel(motion: MotionModel) -> Any:
        return kernels(motion).advance_follower


class CompiledFollowerEKF(FastFollowerEKF):
    """`FastFollowerEKF` whose predict and update run compiled."""

    def __init__(
        self, pose: tuple[float, float, float], params: EkfParams, motion: Any = None
    ) -> None:
        super().__init__(pose, params, motion)
        ker = kernels()
        self._predict = ker.ekf_predict
        self._update = ker.ekf_update

    @staticmethod
    def _command_kernel(motion: Any) -> Any:
        return kernels(motion).ekf_command


class CompiledTraceFollower(TraceFollower):
    """`TraceFollower` whose `command` runs compiled (the Python one when the
    kernel cannot decide a comparison exactly: module docstring)."""

    def __init__(
        self, path: LeaderPath, rho_d: Any, lateral: Any, gain: float, lookahead: float
    ) -> None:
        super().__init__(path, rho_d, lateral, gain, lookahead)
        self._s0 = np.array(path._s0, dtype=float)
        self._poses = np.array(path._poses, dtype=float).reshape(-1, 3)
        self._kappa = np.array(path._kappa, dtype=float)
        self._lateral = np.array(self.lateral, dtype=float)
        self._ahead = np.array(self.ahead, dtype=np.int64)
        self._spacing = np.array(self.spacing, dtype=float)
        self._from_lists()
        self.fallbacks = 0  # commands handed back to Python

    def clone(self) -> CompiledTraceFollower:
        """A copy with its own search starts, compiled too (`TraceFollower.clone`)."""
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new._s_ref = list(self._s_ref)
        new._s_f = list(self._s_f)
        new._sr = self._sr.copy()
        new._sf = self._sf.copy()
        new.fallbacks = 0
        return new

    # the last references and projections live in two arrays (NaN: none yet) that the
    # kernel updates; the Python class's lists are kept equal to them after every command
    # (a copy of the law, or a Python method, sees the same state)
    def _to_lists(self) -> None:
        self._s_ref = [None if math.isnan(s) else s for s in self._sr.tolist()]
        self._s_f = [None if math.isnan(s) else s for s in self._sf.tolist()]

    def _from_lists(self) -> None:
        nan = math.nan
        self._sr = np.array([nan if s is None else s for s in self._s_ref], dtype=float)
        self._sf = np.array([nan if s is None else s for s in self._s_f], dtype=float)

    def project(self, k: int, x: float, y: float, guess: float) -> float:
        """`TraceFollower.project` in one kernel call (the same Newton steps)."""
        s = self._sf[k]
        if math.isnan(s):
            s = float(guess)
        s = kernels().project(
            self._s0, self._poses, self._kappa, self.path.lap_length, self.lateral[k], s, x, y
        )
        self._sf[k] = s
        self._s_f[k] = s
        return s  # type: ignore[no-any-return]

    def initial(
        self, k: int, s_l: float, leader: tuple[float, float, float], v_l: float
    ) -> tuple[float, float, float, float]:
        self._to_lists()
        out = super().initial(k, s_l, leader, v_l)
        self._from_lists()
        return out

    def command(
        self,
        k: int,
        s_l: float,
        leader: tuple[float, float, float],
        v_l: float,
        x: float,
        y: float,
        th: float,
    ) -> tuple[float, float]:
        ker = kernels()
        if not ker.exact_hypot:  # this interpreter's hypot is not the kernels': Python
            self.fallbacks += 1
            out = super().command(k, s_l, leader, v_l, x, y, th)
            self._from_lists()
            return out
        xl, yl, hl = leader
        out = ker.ftl_exact(
            self._s0,
            self._poses,
            self._kappa,
            self.path.lap_length,
            self._lateral,
            self._ahead,
            self._spacing,
            self._sr,
            self._sf,
            self.gain,
            self.lookahead,
            k,
            s_l,
            xl,
            yl,
            hl,
            v_l,
            x,
            y,
            th,
        )
        self._to_lists()
        return out  # type: ignore[no-any-return]
