"""The world's arithmetic compiled with numba: the ``compiled`` backend (``[world] backend``).

The Python classes stay the reference; the classes here are subclasses that hand the same
expressions, in the same order, to compiled kernels, so the results are bit for bit the
Python ones (tests run both paths and compare whole runs):

- `FollowerArrays`: the followers' truth as one array, integrated (`follower_advance`) in one
  call for all (`CompiledFollowerGroup`: on lists, one call per follower);
- `CompiledEstimates`: the leader's estimates as one array the world owns, each reader one
  compiled call (`rtsim.world.estimates`); `CompiledFollowerEKF` views a row of it;
- `CompiledTraceFollower`: the follow-the-leader law's equations (`rtsim.world.ftl`:
  a command in one call, the projection and the trace's point for the truth log's
  cross-track error);
- `compiled_motion`: the leader's travel.

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

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from rtsim.world.ekf import EkfParams, FastFollowerEKF, _squares
from rtsim.world.estimates import BASE, HELD_ROOM, Q, new_estimates
from rtsim.world.follower import FollowerGroup, FollowerParams
from rtsim.world.ftl import _PY_POINT, _PY_REFERENCE, TraceFollower
from rtsim.world.kernels import available, built_entry, entry, kernels
from rtsim.world.leader import Leader
from rtsim.world.motion import GCV, GCW, GODO, GROUP_ROWS, GT, GTH, GV, GW, GX, GY, actuated
from rtsim.world.motionmodels import MotionModel
from rtsim.world.path import LeaderPath, geometry_arrays

__all__ = [
    "CompiledEstimates",
    "CompiledFollowerEKF",
    "CompiledFollowerGroup",
    "CompiledTraceFollower",
    "FollowerArrays",
    "available",
    "compiled_motion",
    "kernels",
]


class CompiledFollowerGroup(FollowerGroup):
    """[`FollowerGroup`][rtsim.world.compiled.FollowerGroup] whose `advance` runs compiled
    (its lists, a follower per call: `rtsim.world.motion.follower_advance`). The compiled
    world's own group is `FollowerArrays`, whose class makes one of these when called alone
    (as the rollout makes a group to play commands ahead on)."""

    @staticmethod
    def _kernel(motion: MotionModel) -> Any:
        # called directly (`entry`): twelve floats at every call; compiled (or loaded) when
        # a group is first made, once per motion model
        subs = motion.subs
        fn = _ADVANCE_ONE.get(subs)
        if fn is None:
            fn = _ADVANCE_ONE[subs] = built_entry(kernels(motion).advance_follower, (0.0,) * 12)
        return fn


#: `CompiledFollowerGroup`'s kernel per motion model (its substitutions)
_ADVANCE_ONE: dict[Any, Any] = {}


#: how many rows a follower group's state has (`rtsim.world.motion.GROUP_ROWS`)
ROWS = len(GROUP_ROWS)


class _RowList(list[float]):
    """A follower group's field as a list of floats: its row of the state array as it is
    now (read, do not resize), which writes an item assigned to it through to the array
    (``fol.cmd_v[k] += dv`` does what it does on `FollowerGroup`'s lists)."""

    __slots__ = ("_group", "_i")

    def __init__(self, group: FollowerArrays, i: int) -> None:
        super().__init__(group.S[i].tolist())
        self._group, self._i = group, i

    def __setitem__(self, k: Any, value: Any) -> None:
        group = self._group
        current = group._rows[self._i] is self  # (a list read before the array moved is not)
        group.S[self._i, k] = value
        group.changed()
        super().__setitem__(k, value)
        if current:
            group._rows[self._i] = self  # (the others read the array again)

    def _resized(self, *args: Any, **kw: Any) -> Any:
        raise TypeError(
            "a follower group's field is a row of its state array: assign an item or the row"
        )

    append = extend = insert = pop = remove = clear = sort = reverse = _resized
    __delitem__ = __iadd__ = __imul__ = _resized


class _Row:
    """A field of `FollowerArrays` (row ``i`` of its state ``S``): read, a `_RowList`
    (made once per change of the array, `FollowerArrays.changed`); assigned a
    sequence of n floats, the row."""

    def __init__(self, i: int) -> None:
        self.i = i

    def __get__(self, obj: Any, cls: Any = None) -> Any:
        if obj is None:
            return self
        rows = obj._rows
        row = rows[self.i]
        if row is None:
            row = rows[self.i] = _RowList(obj, self.i)
        return row

    def __set__(self, obj: Any, value: Any) -> None:
        obj.S[self.i] = value
        obj.changed()


class FollowerArrays(CompiledFollowerGroup):
    """[`FollowerGroup`][rtsim.world.compiled.FollowerGroup] whose fields are the rows of one
    array ``S`` (`rtsim.world.motion.GROUP_ROWS`, a column per follower), which compiled
    kernels read and write: `advance` and `advance_all` are one compiled call
    (`rtsim.world.motion.group_advance`, the same `follower_advance` per follower), the scan
    reads ``W`` (the rows x, y, odometer) and the truth log ``xy``, as they are, and the
    compiled world integrates, drives and commands them inside its own kernels
    (`rtsim.world.motion.world_advance`, `rtsim.world.estimates.est_command_ftl`; it calls
    `changed` after). A field read is a list of floats, the row as it is until the array
    changes, whose items assigned write through (`_RowList`); assigned a sequence, the row.
    The Python rollout plays commands ahead on a `CompiledFollowerGroup` (`rollout_group`:
    lists, whose every step Python reads)."""

    @property
    def rollout_group(self) -> type[FollowerGroup]:
        return CompiledFollowerGroup

    x = _Row(GX)
    y = _Row(GY)
    odometer = _Row(GODO)
    th = _Row(GTH)
    v = _Row(GV)
    w = _Row(GW)
    cmd_v = _Row(GCV)
    cmd_w = _Row(GCW)
    t = _Row(GT)

    def __init__(
        self,
        x: Any,
        y: Any,
        th: Any,
        v: Any,
        params: FollowerParams,
        t_ms: float = 0.0,
    ) -> None:
        self.S = np.zeros((ROWS, len(x)))
        self._rows: list[Any] = [None] * ROWS  # (the fields read since the array changed)
        super().__init__(x, y, th, v, params, t_ms)
        self.W = self.S[: GODO + 1]  # (rows x, y, odometer: a view)
        self._xy = (self.S[GX], self.S[GY])
        self._t_all = float(t_ms)  # every follower's time is at least this (ms)

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)  # (copies and pickles: the array, not its views or lists)
        for name in ("W", "_xy", "_rows"):
            del state[name]
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._rows = [None] * ROWS
        self.W = self.S[: GODO + 1]
        self._xy = (self.S[GX], self.S[GY])

    def changed(self) -> None:
        """Say that ``S`` was written other than by the group's kernels (the fields are read
        from it again; every follower's time may be any: `advance_all` looks)."""
        self._rows = [None] * ROWS
        self._t_all = -math.inf

    def moved(self, t_all: float | None = None) -> None:
        """Say that a compiled kernel moved followers in ``S`` (the fields are read from it
        again); ``t_all``: every follower is at that time now (ms), else unchanged."""
        self._rows = [None] * ROWS
        if t_all is not None:
            self._t_all = t_all

    @staticmethod
    def _kernel(motion: MotionModel) -> Any:
        # called directly (`entry`): the state array, two ints and three floats at every call
        return entry(kernels(motion).advance_group, (np.zeros((1, 1)), 0, 0, *(0.0,) * 3))

    @property
    def n(self) -> int:
        return int(self.S.shape[1])

    @property
    def xy(self) -> tuple[Any, Any]:
        """The rows x and y of ``S`` (views: read, do not write)."""
        return self._xy

    def truth(self) -> tuple[list[float], list[float], list[float], list[float]]:
        x, y, _, th, v = self.S[: GV + 1].tolist()
        return x, y, th, v

    def pose(self, k: int) -> tuple[float, float, float]:
        x, y, _, th = self.S[: GTH + 1, k].tolist()
        return x, y, th

    def apply_drawn(self, k: int, v: float, w: float, nv: float, nw: float) -> tuple[float, float]:
        p = self.p
        sv, sw = actuated(v, w, nv, nw, p.speed_noise, p.turn_noise, p.max_speed, p.max_turn_rate)
        S = self.S
        S[GCV, k] = sv
        S[GCW, k] = sw
        self._rows = [None] * ROWS
        return sv, sw

    def advance(self, k: int, t_ms: float, step_ms: float) -> None:
        self._advance(self.S, k, k + 1, t_ms, step_ms, self.p.max_accel)
        self.moved()

    def advance_all(self, t_ms: float, step_ms: float) -> None:
        if t_ms <= self._t_all:  # (every follower is there: nothing to do)
            return
        S = self.S
        self._advance(S, 0, S.shape[1], t_ms, step_ms, self.p.max_accel)
        self.moved(t_ms)


def compiled_motion(motion: MotionModel) -> Any:
    """A motion model's ``leader`` (the leader's travel) compiled, called directly (`entry`:
    floats at every call), for `rtsim.world.world.World` (whose estimates carry the belief
    in `CompiledEstimates`' kernels)."""
    return entry(kernels(motion).leader_travel, (0.0,) * 5)


class _Kernel:
    """A class attribute that reads kernel ``name`` of `kernels` on an instance's first use,
    compiles (or loads) it for ``args``' types — a tuple, or a function of the instance —
    without running it, and keeps its entry point on the instance (`entry`: every call
    passes those types): a kernel compiled only where it runs."""

    def __init__(self, name: str, args: tuple[Any, ...] | Callable[[Any], tuple[Any, ...]]):
        self.name, self.args = name, args

    def __get__(self, obj: Any, cls: Any = None) -> Any:
        if obj is None:
            return self
        fn = getattr(kernels(getattr(obj, "_motion", None)), self.name)
        fn = built_entry(fn, self.args(obj) if callable(self.args) else self.args)
        setattr(obj, self.attr, fn)
        return fn

    def __set_name__(self, owner: Any, name: str) -> None:
        self.attr = name


class CompiledFollowerEKF(FastFollowerEKF):
    """`FastFollowerEKF` whose predict and update run compiled (the predict without a
    command compiled at its first call: the shipped scenarios never make one). Bound to a
    row of `CompiledEstimates` (`bind`), that row is its state: it reads the row, and each
    of its own steps loads it, runs and writes it back."""

    # (each compiled at its first call, then called directly, `entry`: floats at every call;
    # the world's own steps run in `CompiledEstimates`' kernels)
    _predict = _Kernel("ekf_predict", (1.0,) * 16)
    _update = _Kernel("ekf_update", (1.0,) * 15)
    _command = _Kernel("ekf_command", (1.0,) * 19)

    def __init__(
        self, pose: tuple[float, float, float], params: EkfParams, motion: Any = None
    ) -> None:
        self._motion = motion
        super().__init__(pose, params, motion)
        del self._command  # (the class's, for ``motion``)
        self._row: tuple[CompiledEstimates, int] | None = None

    @staticmethod
    def _command_kernel(motion: Any) -> Any:
        return None

    def bind(self, est: CompiledEstimates, k: int) -> None:
        """Keep the state in row ``k`` of ``est`` from now on (written with this filter's)."""
        self._row = (est, k)
        self._store()

    def _load(self) -> None:
        if self._row is not None:
            est, k = self._row
            r = est.E[k, :12].tolist()
            self.x = r[:3]
            self._q = tuple(r[3:])

    def _store(self) -> None:
        if self._row is not None:
            est, k = self._row
            est.E[k, :12] = (*self.x, *self._q)

    @property
    def pose(self) -> tuple[float, float, float]:
        self._load()
        return super().pose

    @property
    def P(self) -> Any:
        self._load()
        return super().P

    @property
    def heading_var(self) -> float:
        self._load()
        return super().heading_var

    def set_state(self, pose: tuple[float, float, float], P: Any) -> None:
        super().set_state(pose, P)
        self._store()

    def predict(self, v: float, w: float, dt: float) -> None:
        self._load()
        super().predict(v, w, dt)
        self._store()

    def predict_command(
        self, v: float, w: float, vc: float, wc: float, a: float, dt: float
    ) -> tuple[float, float]:
        self._load()
        out = super().predict_command(v, w, vc, wc, a, dt)
        self._store()
        return out

    def update(self, z: tuple[float, float]) -> None:
        self._load()
        super().update(z)
        self._store()

    def reset_position(self, z: tuple[float, float]) -> None:
        self._load()
        super().reset_position(z)
        self._store()


class CompiledEstimates:
    """The leader's estimates of the ``n`` followers as one array ``E`` (rows:
    `rtsim.world.estimates`), the compiled world's state in place of its filters' floats and
    its lists of held commands: each of `rtsim.world.world.World`'s readers is one compiled
    call on it (bit for bit the Python rules). The filters become views of their rows.
    ``last``: per follower the command held last (speed, turn rate), a list for Python
    readers."""

    def __init__(
        self,
        filters: list[CompiledFollowerEKF],
        vw: list[tuple[float, float]],
        held: list[tuple[float, float, float]],
        motion: MotionModel,
        params: EkfParams,
        accel: float,
    ) -> None:
        n = len(filters)
        self.E = E = new_estimates(n, HELD_ROOM)
        for k, (v, w) in enumerate(vw):
            E[k, 12], E[k, 13], E[k, 14] = v, w, 1.0
            E[k, BASE : BASE + 3] = held[k]
        self.last = [(h[1], h[2]) for h in held]
        for k, f in enumerate(filters):
            f.bind(self, k)
        self.accel = accel
        self.ekf_args = (accel, *_squares(params), max(params.measurement_noise, 0.01) ** 2)
        self._motion = motion  # (the kernels' namespace of `_Kernel`'s)
        ker = kernels(motion)
        x = 0.0
        self._one, self._all = np.empty((1, 7)), np.empty((n, 7))  # (`est_carry`'s rows)
        self._carry = entry(ker.est_carry, (E, 0, x, x, self._all))
        self._ftl = ker.est_command_ftl

    # (compiled at its first call: the law's fused command, `est_command_ftl`, holds its
    # commands inside its kernel, and the shipped scenarios' runs never call this one)
    _hold = _Kernel("est_hold", lambda self: (self.E, 0, 0.0, 0.0, 0.0))
    # (compiled at its first call too: the fused scan runs `est_scan` inside its own kernel,
    # `rtsim.world.scanstep`, so the shipped scenarios' runs never call this one)
    _scan = _Kernel("est_scan", lambda self: (self.E, np.zeros((1, 3)), *(0.0,) * 11, True))

    def scan(
        self, t: float, lp: tuple[float, float, float], fixes: Any, var: float, track: bool
    ) -> float:
        """`World.estimate` for every follower (`est_scan`): ``fixes`` flat, (mx, my, 1 in
        its window, 2 re-acquired, else 0) per follower, or an (n, 3) array of them (read
        only); returns the heading variance's max."""
        F = fixes if isinstance(fixes, np.ndarray) else np.array(fixes).reshape(-1, 3)
        return self._scan(self.E, F, t, *self.ekf_args, *lp, var, track)  # type: ignore[no-any-return]

    def carry(self, k: int, t: float) -> tuple[tuple[float, float, float], float, float]:
        """Follower index ``k``'s estimate at ``t`` ms: (pose, v̂, ω̂) (`est_carry`)."""
        one = self._one
        self._carry(self.E, k, t, self.accel, one)
        x, y, th, v, w, _, _ = one.tolist()[0]
        return (x, y, th), v, w

    def carry_all(self, t: float) -> list[list[float]]:
        """Every estimate at ``t`` ms: per follower [x, y, θ, v̂, ω̂, v_c, ω_c] (`est_carry`)."""
        out = self._all
        self._carry(self.E, 0, t, self.accel, out)
        return out.tolist()  # type: ignore[no-any-return]

    def covariances(self) -> list[list[float]]:
        """Each row's covariance, its nine entries row by row."""
        return self.E[:, Q : Q + 9].tolist()  # type: ignore[no-any-return]

    def hold(self, k: int, t: float, v: float, w: float) -> None:
        """Hold (v, ω) from ``t`` ms in follower index ``k``'s row (`est_hold`), growing the
        array when the row is full."""
        while not self._hold(self.E, k, t, v, w):
            self._grow()
        self.last[k] = (v, w)

    def _grow(self) -> None:
        """Twice the room for held commands (the filters' views follow: they read ``E``)."""
        E = self.E
        grown = np.zeros((E.shape[0], BASE + 2 * (E.shape[1] - BASE)))
        grown[:, : E.shape[1]] = E
        self.E = grown

    def fuse_ftl(
        self,
        law: CompiledTraceFollower,
        params: FollowerParams,
        group: FollowerArrays,
        step_ms: float,
        leader: Leader,
    ) -> None:
        """Make `est_command_ftl` (called by `World.command`, `World._fused_sender`) drive
        the ``leader`` (its acceleration and deceleration limits), advance the follower's
        truth in ``group`` (sub-steps ``step_ms``), run the compiled follow-the-leader law
        ``law`` (its arrays), saturate to the followers' speed and turn-rate limits and
        realise the command with their actuation noise (``params``)."""
        p = params
        self._ftl_run = (self.accel, law._G, law._sr, law._sf, law.gain, law.lookahead)
        self._ftl_run += (p.max_speed, p.max_turn_rate, p.speed_noise, p.turn_noise)
        self._ftl_run += (group.S, step_ms, leader.accel_max, leader.decel_max)
        x = 0.0
        self._ftl_entry = entry(self._ftl, (0, *(x,) * 7, self.E, *self._ftl_run))

    _ftl_entry: Any = None
    _ftl_run: tuple[Any, ...] = ()


class CompiledTraceFollower(TraceFollower):
    """`TraceFollower` whose equations run compiled, on arrays it owns (the Python twins, as
    `TraceFollower`, when the kernels' hypot is not this interpreter's: module docstring).
    ``compiled``: whether its equations run compiled (its arrays are the kernels')."""

    compiled = False

    def __init__(
        self, path: LeaderPath, rho_d: Any, lateral: Any, gain: float, lookahead: float
    ) -> None:
        super().__init__(path, rho_d, lateral, gain, lookahead)
        ker = kernels()
        if not ker.exact_hypot:  # this interpreter's hypot is not the kernels': Python
            return
        self._G = geometry_arrays(self.geometry)
        self._sr = np.array(self._sr, dtype=float)
        self._sf = np.array(self._sf, dtype=float)
        del self._command, self._project, self._reference, self._point  # (the class's)
        self.compiled = True

    def initial(
        self, k: int, s_l: float, leader: tuple[float, float, float], v_l: float
    ) -> tuple[float, float, float, float]:
        """`TraceFollower.initial` by the Python twins (bit for bit the kernels' numbers):
        once per follower at start-up, so a first run does not compile two entries for it."""
        if not self.compiled:
            return super().initial(k, s_l, leader, v_l)
        sr = self._sr.tolist()
        s_ref, v_ref = _PY_REFERENCE(self.geometry, sr, k, s_l, *leader, v_l)
        self._sr[:] = sr
        x, y, h = _PY_POINT(self.geometry, k, s_ref)
        self._sf[k] = s_ref
        return x, y, h, v_ref

    # (compiled at their first call; `initial` runs the Python twins)
    _reference = _Kernel("ftl_reference", lambda self: (self._G, self._sr, 0, *(0.0,) * 5))
    _point = _Kernel("trace_point", lambda self: (self._G, 0, 0.0))

    # (compiled at its first call: the compiled world runs the law's command fused into its
    # estimates' kernel, `est_command_ftl`, so the shipped scenarios' runs never call this one)
    _command = _Kernel(
        "ftl_command",
        lambda self: (self._G, self._sr, self._sf, 0.0, 0.0, 0, *(0.0,) * 8),
    )
    # (likewise: the truth log projects in its own kernel, `rtsim.coupling.physical`)
    _project = _Kernel("ftl_project", lambda self: (self._G, 0, 0.0, 0.0, 0.0))
