"""The world's arithmetic compiled with numba: the ``compiled`` backend (``[world] backend``).

The Python classes stay the reference; the classes here are subclasses that hand the same
expressions, in the same order, to compiled kernels, so the results are bit for bit the
Python ones (tests run both paths and compare whole runs):

- :class:`CompiledFollowerGroup`: a follower's held command integrated to a time (the
  exact arcs and speed-ramp sub-steps of :meth:`FollowerGroup.advance`) in one call;
- :class:`CompiledFollowerEKF`: the EKF's predict and update (:class:`FastFollowerEKF`'s
  float algebra);
- :class:`CompiledTraceFollower`: the follow-the-leader reference search, projection and
  control law (:class:`TraceFollower.command`) in one call per command.

Only the operations whose compiled result is the interpreter's are compiled: + − × ÷,
``sqrt``, ``sin``, ``cos``, ``atan2``, ``abs``, ``copysign`` and ``%`` (numba calls the same C
library for the functions and follows Python's rules for ``%``). CPython computes
``math.hypot`` with an algorithm of its own; the kernels carry that algorithm
(:func:`rtsim.world.kernels._hypot`), checked against ``math.hypot`` when they load — where
this interpreter disagrees, the controller and the rollout run in Python instead.

numba is imported on first use (:func:`available`); kernels are compiled once per machine
and cached on disk (``cache=True``), so a later process loads them in milliseconds.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rtsim.world.ekf import EkfParams, FastFollowerEKF
from rtsim.world.follower import FollowerGroup, FollowerParams
from rtsim.world.ftl import TraceFollower
from rtsim.world.kernels import available, kernels
from rtsim.world.path import LeaderPath

__all__ = [
    "CompiledFollowerEKF",
    "CompiledFollowerGroup",
    "CompiledTraceFollower",
    "available",
    "kernels",
]

# -- the classes the compiled backend builds -------------------------------------------------


class CompiledFollowerGroup(FollowerGroup):
    """:class:`FollowerGroup` whose :meth:`advance` runs compiled."""

    def __init__(
        self, x: Any, y: Any, th: Any, v: Any, params: FollowerParams, t_ms: float = 0.0
    ) -> None:
        super().__init__(x, y, th, v, params, t_ms)
        self._advance_kernel = kernels().advance_follower

    def advance(self, k: int, t_ms: float, step_ms: float) -> None:
        t0 = self.t[k]
        if t_ms <= t0:
            return
        (self.x[k], self.y[k], self.th[k], self.v[k], self.odometer[k]) = self._advance_kernel(
            self.x[k],
            self.y[k],
            self.th[k],
            self.v[k],
            self.cmd_v[k],
            self.cmd_w[k],
            self.p.max_accel,
            self.odometer[k],
            t0,
            t_ms,
            step_ms,
        )
        self.t[k] = t_ms


class CompiledFollowerEKF(FastFollowerEKF):
    """:class:`FastFollowerEKF` whose predict and update run compiled."""

    def __init__(self, pose: tuple[float, float, float], params: EkfParams) -> None:
        super().__init__(pose, params)
        ker = kernels()
        self._predict_kernel = ker.ekf_predict
        self._update_kernel = ker.ekf_update

    def predict(self, v: float, w: float, dt: float) -> None:
        if dt <= 0.0:
            return
        x = self.x
        (p00, p01, p02), (_, p11, p12), (_, _, p22) = self._p
        x[0], x[1], x[2], n00, n01, n02, n11, n12, n22 = self._predict_kernel(
            x[0], x[1], x[2], p00, p01, p02, p11, p12, p22, v, w, dt, *self._noise
        )
        self._p = [[n00, n01, n02], [n01, n11, n12], [n02, n12, n22]]

    def update(self, z: tuple[float, float]) -> None:
        x = self.x
        (p00, p01, p02), (p10, p11, p12), (p20, p21, p22) = self._p
        r = self._update_kernel(
            x[0],
            x[1],
            x[2],
            p00,
            p01,
            p02,
            p10,
            p11,
            p12,
            p20,
            p21,
            p22,
            self.r,
            float(z[0]),
            float(z[1]),
        )
        x[0], x[1], x[2] = r[0], r[1], r[2]
        self._p = [[r[3], r[4], r[5]], [r[6], r[7], r[8]], [r[9], r[10], r[11]]]


class CompiledTraceFollower(TraceFollower):
    """:class:`TraceFollower` whose :meth:`command` runs compiled (the Python one when the
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
        """A copy with its own search starts, compiled too (:meth:`TraceFollower.clone`)."""
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new._s_ref = list(self._s_ref)
        new._s_f = list(self._s_f)
        new._sr = self._sr.copy()
        new._sf = self._sf.copy()
        new.fallbacks = 0
        return new

    def roll(
        self, leader: Any, state: Any, events: list[tuple[float, int, int]], scans: int
    ) -> list[list[tuple[float, float, float, float, float]]] | None:
        """:meth:`rtsim.control.rollout.Rollout._run`'s event loop in one kernel call, on this
        law (a clone: its search starts move) and a group started from ``state``; returns
        the samples at the scans (per follower: x, y in the leader frame, ρ, β, odometer), or
        None when the compiled hypot is not this interpreter's (the caller runs Python)."""
        ker = kernels()
        if not ker.exact_hypot:
            return None
        p = state.params
        n = len(state.poses)
        pose = np.array(state.poses, dtype=float).reshape(n, 3)
        x, y, th = pose[:, 0].copy(), pose[:, 1].copy(), pose[:, 2].copy()
        v = np.array(state.speeds, dtype=float)
        held = np.array(state.held, dtype=float).reshape(n, 2)
        cmd_v, cmd_w = held[:, 0].copy(), held[:, 1].copy()
        odo = np.zeros(n)
        t_f = np.full(n, float(state.t_now))
        ev = np.array([e[0] for e in events], dtype=float)
        kind = np.array([e[1] for e in events], dtype=np.int64)
        who = np.array([e[2] for e in events], dtype=np.int64)
        out = np.zeros((scans, n, 3))
        ker.rollout(
            self._s0,
            self._poses,
            self._kappa,
            self.path.lap_length,
            leader.s,
            leader.speed,
            leader.target_speed,
            leader.accel_max,
            leader.decel_max,
            x,
            y,
            th,
            v,
            cmd_v,
            cmd_w,
            odo,
            t_f,
            p.max_accel,
            p.max_speed,
            p.max_turn_rate,
            p.speed_noise,
            p.turn_noise,
            float(state.step_ms),
            self._lateral,
            self._ahead,
            self._spacing,
            self._sr,
            self._sf,
            self.gain,
            self.lookahead,
            ev,
            kind,
            who,
            float(state.t_now),
            out,
        )
        self._to_lists()
        two_pi = 2.0 * math.pi
        return [
            [(tx, ty, math.hypot(tx, ty), math.atan2(ty, tx) % two_pi, od) for tx, ty, od in row]
            for row in out.tolist()
        ]

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
