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
  alone (`TraceFollower.project`, the truth log's cross-track error);
- `CompiledRollout`: the leader's command-aware rollout
  (`rtsim.control.rollout.Rollout`) whole in one call per rollout, and the ``plan``
  policy's decision or the ``commands`` speed search in one call per decision (its rollouts
  handed back for the rollout's memo, as the Python policy leaves them there).

Only the operations whose compiled result is the interpreter's are compiled: + − × ÷,
``sqrt``, ``sin``, ``cos``, ``atan2``, ``abs``, ``copysign`` and ``%`` (numba calls the same C
library for the functions and follows Python's rules for ``%``). CPython computes
``math.hypot`` with an algorithm of its own; the kernels carry that algorithm
(`rtsim.world.kernels._hypot`), checked against ``math.hypot`` when they load — where
this interpreter disagrees, the controller and the rollout run in Python instead; numba has
no ``math.remainder``, and the kernels carry CPython's (exact, with fmod).

numba is imported on first use (`available`); kernels are compiled once per machine
and cached on disk (keyed by a hash of their sources: `rtsim.world.jit`), so a later
process loads them in milliseconds (the
rollout's only when a run first rolls out: `rtsim.world.kernels.warm_rollout`).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from rtsim.world import kernels as K
from rtsim.world.ekf import EkfParams, FastFollowerEKF
from rtsim.world.follower import FollowerGroup
from rtsim.world.ftl import TraceFollower
from rtsim.world.kernels import available, kernels
from rtsim.world.motionmodels import MotionModel, motion_model
from rtsim.world.path import LeaderPath

__all__ = [
    "CompiledRollout",
    "CompiledFollowerEKF",
    "CompiledFollowerGroup",
    "CompiledTraceFollower",
    "available",
    "kernels",
]


def as_changes(arr: Any) -> list[list[Any]]:
    """A [window, follower, change] array as the rollout's lists of tuples (the four changes
    and the closest approach, `rtsim.control.rollout.Changes`)."""
    return [[tuple(c) for c in win] for win in arr.tolist()]


# -- the classes the compiled backend builds -------------------------------------------------


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
        self._rollout_static: Any = None  # CompiledRollout's constant scalars, packed once

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

    def compiled_rollout(self, state: Any) -> CompiledRollout | None:
        """The compiled rollout of ``state`` (a `RolloutState`
        whose law is this one), or None when the compiled hypot is not this interpreter's
        (the caller plays the rollout in Python)."""
        return CompiledRollout(self, state) if kernels().exact_hypot else None

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


#: how many of RolloutScalars' fields change from one decision to the next (they come first)
_CHANGING = K.RolloutScalars._fields.index("lap")

#: rollouts of one search kept for the memo: v_floor, 7 scanned speeds and the bisection (5 at
#: ROLLOUT_TOL = 0.005; room for any tolerance down to 2^-50)
_SEARCH_RUNS = 64


class CompiledRollout:
    """`Rollout`'s arithmetic for one state in compiled calls:
    the state packed into arrays once (`RolloutScalars`, a row per
    follower, the pending sends NaN-padded), the law's search starts read at each call (the
    live law's, as the Python rollout clones it then).

    ``runs``: the rollouts every instance has run in this process (each kernel call's; read
    through `rtsim.control.rollout.rollouts_run`)."""

    runs: ClassVar[int] = 0

    def __init__(self, law: CompiledTraceFollower, state: Any) -> None:
        p, thr = state.params, state.thresholds
        motion = motion_model(p.motion_model)
        K.warm_rollout(motion)  # once per process: before the first rollout, not in a window
        self._law = law
        self._ker = kernels(motion)
        # the scalars that stay from one decision to the next, packed once per law (they
        # follow the five that change, in RolloutScalars' order)
        static = (p, thr, state.accel_max, state.decel_max, state.step_ms)
        cached = law._rollout_static
        if cached is None or any(a is not b for a, b in zip(cached[0], static, strict=True)):
            scalars = K.RolloutScalars(
                leader_s=0.0,  # the five that change: set per decision below
                leader_speed=0.0,
                v_ld=0.0,
                t_now=0.0,
                next_scan=0.0,
                lap=law.path.lap_length,
                accel=state.accel_max,
                decel=state.decel_max,
                max_accel=p.max_accel,
                max_speed=p.max_speed,
                max_turn=p.max_turn_rate,
                speed_noise=p.speed_noise,
                turn_noise=p.turn_noise,
                step=state.step_ms,
                gain=law.gain,
                lookahead=law.lookahead,
                r_H=thr.r_H,
                T_rho=thr.T_rho,
                T_eps=thr.T_eps,
                T_beta=thr.T_beta,
                predicted=1.0 if thr.localization == "predicted" else 0.0,
                predicted_ms=thr.predicted_ms,
            )
            cached = law._rollout_static = (static, [float(x) for x in scalars[_CHANGING:]], {})
        fs = np.array(
            [  # RolloutScalars' first five
                state.leader_s,
                state.leader_speed,
                state.v_ld,
                state.t_now,
                state.next_scan,
                *cached[1],
            ],
            dtype=float,
        )
        n = len(state.poses)
        # per follower, in F_* column order: x, y, θ, v, ω, held v, held ω, send offset, ρ_d
        # (a flat list: numpy reads it much faster than nested tuples)
        flat: list[float] = []
        turns = state.turns or [h[1] for h in state.held]
        for k in range(n):
            flat += state.poses[k]
            flat.append(state.speeds[k])
            flat.append(turns[k])
            flat += state.held[k]
            flat.append(state.send_offsets[k])
            flat.append(state.rho_d[k])
        fol = np.array(flat, dtype=float).reshape(n, K.F_SIZE)
        width = max([1, *map(len, state.pending)])
        if width == 1 and not any(state.pending):  # no sends pending: one array per n, kept
            pend = cached[2].get(n)
            if pend is None:
                pend = cached[2][n] = np.full((n, 1), math.nan)
        else:
            pend = np.full((n, width), math.nan)
            for k, times in enumerate(state.pending):
                pend[k, : len(times)] = times
        self._args = (
            fs,
            fol,
            pend,
            law._s0,
            law._poses,
            law._kappa,
            law._lateral,
            law._ahead,
            law._spacing,
        )
        self.n = n

    def pack(self) -> tuple[Any, ...]:
        """The kernels' ``P``: the state's arrays, the path's, the law's geometry and its
        search starts as they are now."""
        return (*self._args, self._law._sr, self._law._sf)

    def changes(self, v: float, windows: tuple[float, ...]) -> list[list[Any]]:
        """`Rollout.changes` uncached: per window, per follower the four changes."""
        out = np.empty((len(windows), self.n, 5))
        CompiledRollout.runs += 1
        self._ker.rollout_changes(float(v), np.array(windows, dtype=float), self.pack(), out)
        return as_changes(out)

    def decide(
        self,
        search_only: bool,
        keep: float,
        need: float,
        cap: float,
        v_floor: float,
        grid: int,
        tol: float,
        windows: int,
        w: float,
        contact: float = 0.0,
    ) -> tuple[tuple[float, ...], Any, list[tuple[float, tuple[float, ...], Any]]]:
        """`PlanPolicy`'s decision, or with ``search_only``
        `rtsim.control.adjust.search_rollout` over keep · (the smallest bound of
        ``windows`` windows of ``w`` ms; the contact bound at d_c = ``contact`` cm, 0: off),
        in one call (`rtsim.world.kernels._plan_decide`, on fresh
        buffers): ((w, V_L, method code, found, feasible), the rows
        at V_Ld and at V_L [2, follower, kind], and the rollouts it ran as (speed, window
        lengths, changes [window, follower, change]) for the rollout's memo)."""
        speeds = np.empty(_SEARCH_RUNS)
        lens = np.zeros(_SEARCH_RUNS, dtype=np.int64)
        changes = np.empty((_SEARCH_RUNS, int(windows), self.n, 5))
        rows = np.empty((2, self.n, 4))
        out = np.full(6, math.nan)
        runs = self._ker.plan_decide(
            bool(search_only),
            float(keep),
            float(need),
            float(cap),
            float(v_floor),
            int(grid),
            float(tol),
            float(w),
            self.pack(),
            speeds,
            lens,
            changes,
            rows,
            out,
            float(contact),
        )
        CompiledRollout.runs += runs
        runs = min(runs, _SEARCH_RUNS)
        w = float(w)
        horizon = (w,) * int(windows)
        ran: list[tuple[float, tuple[float, ...], Any]] = []
        for r, (v, code) in enumerate(
            zip(speeds[:runs].tolist(), lens[:runs].tolist(), strict=True)
        ):
            if code == 2:
                ran.append((v, (float(out[5]),), changes[r, :1]))
                continue
            ran.append((v, horizon, changes[r]))
            if code == 1:
                ran.append((v, (w,), changes[r, :1]))
        return tuple(out[:5].tolist()), rows, ran
