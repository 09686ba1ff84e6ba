"""The robot-group world: truth and the leader's estimates side by side (docs/model/world.md).

Plain numpy + filterpy, no engine: whoever owns time calls, in simulated **milliseconds**,
`World.advance` (the truth up to t), `World.scan` at a window's scan (beams, fixes, Hough
windows, lost tracks, the bound violations since the previous scan: a `Scan`),
`World.estimate` with it (the EKFs predict with the commands sent and update with the
fixes; the estimates centre the next windows, ``[localization] centre``) — or both at once,
`World.scan_estimate` (one compiled call in the compiled world) —, `World.command`
at the end of follower i's send segment (l-ψ or follow-the-leader on the leader's
estimate, held until the next command: a late window means stale commands) and
`World.set_leader_speed` (the target the leader's speed ramps toward).

**Initial state** (t = 0): the leader at ``start_s`` at V_Ld (or ``start_speed``); each
follower on its slot (l-ψ, in steady formation: `formation_velocity`) or its reference
point of the trace (follow-the-leader), holding that command without noise; each estimate
the truth plus N(0, init_position_sd²) per coordinate and N(0, init_heading_sd²) on the
heading. Followers are numbered from 1 in every method; arrays are indexed i − 1.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from rtsim.analysis.kinematics import (
    formation_velocity,
    relative_state,
)
from rtsim.errors import RtsimError
from rtsim.model.window import LASER_POINTS
from rtsim.world.compiled import (
    CompiledEstimates,
    CompiledFollowerEKF,
    CompiledTraceFollower,
    FollowerArrays,
    compiled_motion,
    kernels,
)
from rtsim.world.config import WorldConfig
from rtsim.world.ekf import FastFollowerEKF, FollowerEKF, make_filter
from rtsim.world.follower import FollowerGroup, control_targets, lpsi_command
from rtsim.world.formation import follower_model
from rtsim.world.ftl import TraceFollower
from rtsim.world.kernels import entry
from rtsim.world.leader import Leader
from rtsim.world.localization import ExpectedBeams, lost_cause
from rtsim.world.locmodels import Fix, HoughModel, localization_model
from rtsim.world.motionmodels import motion_model
from rtsim.world.normals import set_state, state_of
from rtsim.world.scan import Scan
from rtsim.world.scanstep import PY, FusedFields, FusedScan

__all__ = ["World", "Scan", "forget_starts"]

# the scan's per-follower arithmetic, the kernel sources' Python twins (`rtsim.world.scanstep`)
_TO_LEADER = PY["to_leader_xy"]
_TRUTH_CHANGE = PY["truth_change"]
_VIOLATIONS = PY["bound_violations"]
_FIX_ERROR = PY["fix_error"]

#: Standard normals `World._normals` takes from the stream at a time (its list of floats).
NORMAL_BLOCK = 512
#: Standard normals the world draws ahead from its generator at a time (`World._draw`): one
#: numpy call per ≈ 45 scans' laser noise instead of one per scan.
STREAM_BLOCK = 16_384

Array = NDArray[np.float64]
Pose = tuple[float, float, float]
XY = tuple[float, float]
Mark = tuple[int, float, Pose, tuple[float, float], Pose, float, float]


#: Followers' starting states on the leader's trace kept per process (`_initial_on_trace`)
INITIAL_KEPT = 16
_INITIAL: dict[tuple[Any, ...], tuple[Any, ...]] = {}
_INITIAL_LOCK = threading.Lock()


def _initial_on_trace(
    ftl: TraceFollower, n: int, s_l: float, pose: Pose, v_l: float
) -> NDArray[np.float64]:
    """The ``n`` followers' (x, y, heading, speed) on their references for the leader at
    ``s_l``, ``pose``, ``v_l`` (`TraceFollower.initial` of each in turn, which also sets the
    law's references), an (n, 4) array. A compiled law's are kept per process by the law's
    inputs (its path, the object itself: alive while kept) and the leader's start: a
    sweep's next point sets the same references and gets the same numbers without the
    search (≈ 0.13 ms of a Test 2 lap's set-up)."""
    if type(ftl) is not CompiledTraceFollower or not ftl.compiled:
        rows = [ftl.initial(k, s_l, pose, v_l) for k in range(n)]
        return np.array(rows, dtype=float).reshape(n, 4)
    key = (ftl.path, (*ftl.rho_d,), (*ftl.lateral,), ftl.gain, ftl.lookahead, n, s_l, pose, v_l)
    with _INITIAL_LOCK:
        hit = _INITIAL.get(key)
    if hit is None:
        rows = [ftl.initial(k, s_l, pose, v_l) for k in range(n)]
        hit = (tuple(rows), tuple(ftl._sr.tolist()), tuple(ftl._sf.tolist()))
        with _INITIAL_LOCK:  # (points may run in threads: a Dask worker's)
            _INITIAL[key] = hit
            while len(_INITIAL) > INITIAL_KEPT:
                del _INITIAL[next(iter(_INITIAL))]
    else:
        ftl._sr[:] = hit[1]
        ftl._sf[:] = hit[2]
    return np.array(hit[0], dtype=float).reshape(n, 4)


def forget_starts() -> None:
    """Forget the followers' starting states kept (`_initial_on_trace`)."""
    with _INITIAL_LOCK:
        _INITIAL.clear()


class World:
    """Leader, followers (truth), laser, Hough localization and one EKF per follower."""

    #: the stream's PCG64 state when the fused scan draws its own normals (`_draw`)
    _pcg: NDArray[np.uint64] | None = None

    def __init__(self, config: WorldConfig, rng: np.random.Generator) -> None:
        self.config = config
        self.rng = rng
        self._z: list[float] = []  # standard normals taken from the stream (see _normals)
        self._zi = 0
        self._stream = np.empty(0)  # standard normals drawn ahead from rng (see _draw)
        self._si = 0
        self.motion = motion_model(config.follower.motion_model)
        self.backend = config.resolved_backend()
        fast = self.backend == "compiled"
        # the leader's travel: the motion model's part, compiled in the compiled backend
        # (called directly: floats only)
        self._step = self.motion.step  # (the Python world's; the compiled one's estimates
        # carry it in `CompiledEstimates`' kernels)
        travel = compiled_motion(self.motion) if fast else self.motion.leader
        self.leader = Leader(
            config.path,
            config.leader_speed,
            config.start_s,
            accel_max=config.leader_accel_max,
            decel_max=config.leader_decel_max,
            travel=travel,
        )
        if config.start_speed is not None:  # a settled start below V_Ld
            self.leader.speed = self.leader.target_speed = config.start_speed
        form = config.formation
        self._rho_d = np.asarray(form.rho_d)
        self._beta_d = np.asarray(form.beta_d)
        fp = config.follower
        # the l-ψ law's control-point targets (`control_targets`), made at its first command
        # for the leader's curvature then (`_lpsi`; NaN: none yet): a run on the trace
        # follower never asks for them
        self._kappa_targets = math.nan
        self._targets_l: tuple[list[float], list[float]] = ([], [])
        xl, yl, hl = self.leader.pose
        v_l, w_l = self.leader.speed, self.leader.omega
        slots = form.xy()
        c, s = math.cos(hl), math.sin(hl)
        x = xl + c * slots[:, 0] - s * slots[:, 1]
        y = yl + s * slots[:, 0] + c * slots[:, 1]
        self._ftl: TraceFollower | None = None
        if follower_model(form.model).on_trace:
            ftl = CompiledTraceFollower if fast else TraceFollower
            self._ftl = ftl(config.path, form.rho_d, form.lateral, fp.gain_rho, fp.lookahead)
            init = _initial_on_trace(self._ftl, form.n, self.leader.s, (xl, yl, hl), v_l)
            x, y, th, v_f = init.T
            w0 = 0.0
        else:
            v_f, theta = formation_velocity(v_l, w_l, self._rho_d, self._beta_d)
            v_f = np.asarray(v_f, dtype=float)
            th = hl - np.asarray(theta, dtype=float)
            w0 = float(w_l)
        group = FollowerArrays if fast else FollowerGroup
        self.followers = group(x, y, th, v_f, fp)
        self.followers.cmd_w = [w0] * form.n
        self.followers.w = [w0] * form.n
        self._advance_both = self._advance_kernel() if fast else None
        self._t = 0.0
        self._est_t = 0.0
        #: the largest heading variance P_θθ (rad²) the filters carried from a scan's
        #: estimate over a predicted-centre window (`estimate`; 0 with another centre)
        self.max_heading_var = 0.0
        ep = config.ekf
        if self.backend == "filterpy" and ep.backend != "filterpy":
            ep = replace(ep, backend="filterpy")
        noise = rng.standard_normal((form.n, 3))
        poses = [
            (
                x[k] + ep.init_position_sd * noise[k, 0],
                y[k] + ep.init_position_sd * noise[k, 1],
                th[k] + ep.init_heading_sd * noise[k, 2],
            )
            for k in range(form.n)
        ]
        motion = self.motion
        self._filters = [
            CompiledFollowerEKF(pose, ep, motion) if fast else make_filter(pose, ep, motion)
            for pose in poses
        ]
        self._vhat = [float(v) for v in v_f]
        self._what = [w0] * form.n  # the turn rates the leader expects
        self._pieces: list[list[tuple[float, float, float]]] = [
            [(0.0, float(v_f[k]), w0)] for k in range(form.n)
        ]
        # per follower, the estimate carried to its last piece's start (`_hold`, None: none
        # since the last scan's estimate): (the piece's index, its start, the filter's
        # pose, (v̂, ω̂) it was carried from, the pose, v and ω there)
        self._marks: list[Mark | None] = [None] * form.n
        # the compiled backend's estimates: one array, the filters views of its rows, every
        # reader one compiled call (`CompiledEstimates`; the lists above stay unread)
        self._arr: CompiledEstimates | None = None
        if fast:
            self._arr = CompiledEstimates(
                self._filters,  # type: ignore[arg-type]
                list(zip(self._vhat, self._what, strict=True)),
                [p[0] for p in self._pieces],
                motion,
                ep,
                fp.max_accel,
            )
        # the Hough windows' centres with the ``previous`` centre: the estimates at the last
        # scan (at first, the initial ones) in the leader's frame then
        self._centre = self._to_leader(self.leader.pose, *self._estimated_xy())
        # the previous scan's truth in the leader's frame, ρ, β and odometers (`_changes`)
        self._prev: tuple[list[XY], list[float], list[float], list[float]] | None = None
        model = localization_model(config.localization.model)
        self.localization = model(config, form.n, rng, self._normals, fast, self._draw)
        thr = config.thresholds
        self._sep_limit = thr.T_rho * self._rho_d
        self._travel_limit = thr.T_eps * self._rho_d
        self._sep_limit_l: list[float] = self._sep_limit.tolist()
        self._travel_limit_l: list[float] = self._travel_limit.tolist()
        # per-run constants of the window's stages (the configuration is frozen)
        loc, sens = config.localization, config.sensing
        self._predicted = loc.centre == "predicted"
        self._visible = loc.search == "visible"
        self._r_F, self._max_range, self._min_pts = fp.radius, sens.max_range, sens.min_points
        self._r_H, self._T_beta = thr.r_H, thr.T_beta
        self._accel, self._step_ms = fp.max_accel, config.step_ms
        self._n = form.n
        # the compiled backend's scan with the hough model: one compiled call
        # (`rtsim.world.scanstep`; where the kernels' hypot is the interpreter's)
        self._fused: FusedScan | None = None
        if (
            self._arr is not None
            and type(self.localization) is HoughModel
            and kernels().exact_hypot
        ):
            self._fused = self._fused_scan(rng, motion)
        self._fixes_of: tuple[Scan, Array] | None = None  # the last fused scan's fixes
        #: the last fused scan's float rows as lists (`rtsim.world.scanstep.FLOAT_ROWS`: the
        #: followers' truth then, `TRUTH_ROW`, and the truth log's samples, `log_truth`);
        #: None before it and where the scan does not fuse
        self.scan_rows: list[list[float]] | None = None
        # the compiled backend's command with the compiled law: one call (`_fused_sender`;
        # not where the law stays Python, `CompiledTraceFollower.compiled`)
        self._ftl_fused = self._arr is not None and getattr(self._ftl, "compiled", False)
        self._fused_send: Callable[[int, float], tuple[float, float]] | None = None
        if self._ftl_fused:
            self._arr.fuse_ftl(self._ftl, fp, self.followers, self._step_ms, self.leader)  # type: ignore[union-attr, arg-type]
            self._fused_send = self._fused_sender()

    def _fused_scan(self, rng: np.random.Generator, motion: Any) -> FusedScan:
        """The compiled backend's scan with the hough model (`FusedScan`), drawing its
        normals from the stream's state where the stream is a PCG64 (`_draw`), with the
        law's geometry where the law runs compiled (the truth log's samples: `log_truth`)."""
        assert self._arr is not None
        if type(rng.bit_generator) is np.random.PCG64:
            self._pcg = state_of(rng.bit_generator)
        law = self._ftl
        geometry = law._G if getattr(law, "compiled", False) else None  # type: ignore[union-attr]
        limits = (self._sep_limit_l, self._travel_limit_l)
        fused = FusedScan(
            self.localization, self._n, motion, self._arr.E, limits, self._T_beta, self._pcg,
            geometry,
        )  # fmt: skip
        fused.ekf = tuple(float(v) for v in self._arr.ekf_args)
        return fused

    def _advance_kernel(self) -> Any:
        """The compiled world's `advance`: the followers', the leader's travel and its pose in
        one call (`rtsim.world.motion.world_advance`, the motion model's parts), on the
        path's arrays (`LeaderPath.arrays`, or the compiled law's, which hold them)."""
        law = self._ftl
        # (the law's geometry when it runs compiled: the same path, one array less to make)
        self._path_G = law._G if getattr(law, "compiled", False) else self.config.path.arrays()  # type: ignore[union-attr]
        args = (self.followers.S, 0, *(0.0,) * 9, self._path_G)  # type: ignore[attr-defined]
        return entry(kernels(self.motion).advance_world, args)

    # -- time ------------------------------------------------------------------------
    @property
    def t_ms(self) -> float:
        """Current simulated time of the truth (ms)."""
        return self._t

    @property
    def n(self) -> int:
        return self.config.formation.n

    def advance(self, t_ms: float) -> None:
        """Integrate the truth to ``t_ms``: the leader exactly along its path, the followers
        with their held commands in exact arcs, sub-stepped at ``step_ms`` while a wheel
        speed ramps toward its command for longer than one step."""
        both = self._advance_both
        t0 = self._t
        if both is not None and t_ms > t0:  # (the compiled world's, in one call)
            ld, fol = self.leader, self.followers
            dt = (t_ms - t0) / 1000.0  # (`_advance_leader`'s)
            # (``n``: the formation's, the group's columns, read without its property)
            ld.speed, ld.s, x, y, h = both(
                fol.S, self._n, t_ms, self._step_ms, self._accel, ld.speed, ld.target_speed,  # type: ignore[attr-defined]
                ld.accel_max, ld.decel_max, dt, ld.s, self._path_G,
            )  # fmt: skip
            ld.path.remember(ld.s, (x, y, h))  # (its pose, which the scan and the decision read)
            self._t = t_ms
            fol.moved(t_ms)  # type: ignore[attr-defined]  # (every follower there)
            return
        if t_ms != t0:  # (the world is often at t_ms already)
            self._advance_leader(t_ms)
        self.followers.advance_all(t_ms, self._step_ms)

    def _advance_leader(self, t_ms: float) -> None:
        if t_ms < self._t - 1e-9:
            raise RtsimError(f"world cannot go back in time: {t_ms} ms < {self._t} ms")
        if t_ms > self._t:
            self.leader.advance((t_ms - self._t) / 1000.0)
            self._t = t_ms

    # -- leader ----------------------------------------------------------------------
    @property
    def leader_desired_speed(self) -> float:
        return self.leader.desired_speed

    @property
    def leader_speed(self) -> float:
        """The leader's actual speed V_L now (cm/s)."""
        return self.leader.speed

    @property
    def leader_target_speed(self) -> float:
        """The speed the leader is ramping toward (cm/s): the last `set_leader_speed`."""
        return self.leader.target_speed

    def set_leader_speed(self, v: float, t_ms: float | None = None) -> None:
        """Set the leader's target speed ∈ [0, V_Ld] from ``t_ms`` (default: now); its actual
        speed ramps toward it at most ``leader_accel_max`` / ``leader_decel_max``."""
        if t_ms is not None:
            self._advance_leader(t_ms)
        self.leader.set_speed(v)

    @property
    def leader_pose(self) -> Pose:
        return self.leader.pose

    @property
    def leader_omega(self) -> float:
        return self.leader.omega

    def segment_at(self) -> tuple[Literal["straight", "turn"], float]:
        """("straight" | "turn", signed curvature κ in 1/cm) of the leader's current segment."""
        return self.leader.segment()

    @property
    def lap_length(self) -> float:
        return self.config.path.lap_length

    @property
    def lap_time(self) -> float:
        """Seconds per lap at the desired speed V_Ld."""
        return self.config.path.lap_time(self.leader.desired_speed)

    # -- estimates -------------------------------------------------------------------
    @property
    def filters(self) -> tuple[FollowerEKF | FastFollowerEKF, ...]:
        """The leader's filters, one per follower (index i − 1)."""
        return tuple(self._filters)

    def covariances(self) -> list[list[float]]:
        """Each filter's covariance P (its nine entries row by row, floats), as the filters
        hold it now (one read of the array in the compiled backend)."""
        if self._arr is not None:
            return self._arr.covariances()
        return [np.asarray(f.P, dtype=float).ravel().tolist() for f in self._filters]

    def _propagate(self, k: int, t_ms: float) -> tuple[Pose, float, float]:
        """Estimate of follower index k at t_ms (mean only), its expected speed and turn rate
        (by the motion model's ``step`` over each command piece held before ``t_ms``).

        Carried from follower k's mark (`_hold`) when it holds and ``t_ms`` is not before
        it: the same steps on the same numbers as from the filter, the pieces before the
        mark's ending where the next begins whatever ``t_ms`` (they are in time order)."""
        if self._arr is not None:
            return self._arr.carry(k, t_ms)
        f = self._filters[k]
        pose = f.pose
        v, w = self._vhat[k], self._what[k]
        pieces = self._pieces[k]
        j0 = 0
        mark = self._marks[k]
        if mark is not None and t_ms >= mark[1] and mark[2] == pose and mark[3] == (v, w):
            j0, _, _, _, (x, y, th), v, w = mark
        else:
            x, y, th = pose
        step, a = self._step, self._accel
        last = len(pieces) - 1
        for j in range(j0, last + 1):
            t0, vc, wc = pieces[j]
            t1 = pieces[j + 1][0] if j < last else t_ms
            if t1 > t_ms:
                t1 = t_ms
            if t1 > t0:
                x, y, th, v, w, _ = step(x, y, th, v, w, vc, wc, a, (t1 - t0) / 1000.0)
        return (x, y, th), v, w

    def _carried(self, t_ms: float) -> tuple[list[float], list[float]]:
        """Every estimate carried to ``t_ms`` (`_propagate`): the positions' x and y."""
        if self._arr is not None:
            rows = self._arr.carry_all(t_ms)
            return [r[0] for r in rows], [r[1] for r in rows]
        prop = self._propagate
        xs, ys = [], []
        for k in range(len(self._filters)):
            (x, y, _), _, _ = prop(k, t_ms)
            xs.append(x)
            ys.append(y)
        return xs, ys

    def _estimated_xy(self) -> tuple[list[float], list[float]]:
        if self._arr is not None:
            E = self._arr.E
            return E[:, 0].tolist(), E[:, 1].tolist()
        poses = [f.pose for f in self._filters]
        return [p[0] for p in poses], [p[1] for p in poses]

    @staticmethod
    def _to_leader(leader: Pose, x: list[float], y: list[float]) -> list[tuple[float, float]]:
        xl, yl, hl = leader
        c, s = math.cos(hl), math.sin(hl)
        to_leader = _TO_LEADER
        return [to_leader(xl, yl, c, s, a, b) for a, b in zip(x, y, strict=True)]

    def estimated_pose(self, i: int) -> Pose:
        """The leader's estimate of follower i's pose (x, y, heading) now."""
        return self._propagate(i - 1, self._t)[0]

    def estimate_at(self, i: int, t_ms: float) -> tuple[Pose, float]:
        """The leader's estimate of follower i (from 1) carried to ``t_ms`` with the commands
        it holds: its pose (x, y, heading) and its expected speed (cm/s)."""
        pose, v, _ = self._propagate(i - 1, t_ms)
        return pose, v

    def estimates_at(self, t_ms: float) -> list[tuple[Pose, float]]:
        """Every follower's `estimate_at` (``t_ms``), in one compiled call in the compiled
        backend."""
        if self._arr is not None:
            return [((r[0], r[1], r[2]), r[3]) for r in self._arr.carry_all(t_ms)]
        return [self.estimate_at(i, t_ms) for i in range(1, self._n + 1)]

    def estimate_rows(self, t_ms: float, out: Any = None) -> Any:
        """Per follower [x, y, θ, v̂, ω̂, v_c, ω_c]: its `estimate_at` (``t_ms``), the turn
        rate the leader expects of it then and the command it holds (`held_command`), the
        decision's reads in one compiled call in the compiled backend (`est_carry`'s rows).
        With ``out`` (a float array of a row per follower, at least seven columns, C order)
        the rows are written into its first seven columns instead, and ``out`` returned."""
        arr = self._arr
        if out is not None:
            if arr is not None:  # (`est_carry` writes those seven columns of each row)
                arr._carry(arr.E, 0, t_ms, arr.accel, out)
            else:
                for k, row in enumerate(self.estimate_rows(t_ms)):
                    out[k, :7] = row
            return out
        if arr is not None:
            return arr.carry_all(t_ms)
        prop, held = self._propagate, self.held_command
        return [[*p, v, w, *held(k + 1)] for k in range(self._n) for p, v, w in (prop(k, t_ms),)]

    def expected_turn_rates(self, t_ms: float) -> tuple[float, ...]:
        """The turn rate the leader expects of each follower at ``t_ms`` (the motion model's
        state), for the rollout (`RolloutState.turns`); empty for the unicycle, whose turn
        rate is the held command's."""
        if not self.motion.subs:
            return ()
        return tuple(self._propagate(k, t_ms)[2] for k in range(self.n))

    def _normals(self, m: int) -> list[float]:
        """The next ``m`` standard normals of ``rng``'s stream as floats, taken from it
        (`_draw`) in blocks of `NORMAL_BLOCK` (a list sliced per command)."""
        i = self._zi
        j = i + m
        if j > len(self._z):
            self._z = self._z[i:] + self._draw(NORMAL_BLOCK).tolist()
            i, j = 0, m
        self._zi = j
        return self._z[i:j]

    def _draw(self, m: int) -> Array:
        """The next ``m`` standard normals of ``rng``'s stream (a view of the block drawn,
        which nothing writes), drawn ahead in blocks of `STREAM_BLOCK` (one numpy call per block
        instead of per scan). A Generator's ``standard_normal(N)`` is the concatenation of
        consecutive smaller draws, so every reader sees the numbers one call per request
        would give, in the order they ask; ``rng`` itself runs ahead by up to a block. Where
        the fused scan draws its normals in its kernel from the stream's state (``_pcg``),
        each request is drawn as asked, from and back to that state."""
        G = self._pcg
        if G is not None:
            bits = self.rng.bit_generator
            set_state(bits, G)
            out = self.rng.standard_normal(m)
            state_of(bits, G)
            return out
        i = self._si
        j = i + m
        if j > self._stream.shape[0]:
            self._stream = np.concatenate(
                (self._stream[i:], self.rng.standard_normal(max(STREAM_BLOCK, m)))
            )
            i, j = 0, m
        self._si = j
        return self._stream[i:j]

    # -- the scan --------------------------------------------------------------------
    def scan(self, t_ms: float) -> Scan:
        """Sample the truth at ``t_ms`` (advancing to it): beams, fixes, Hough windows,
        lost tracks and re-acquisitions, and the violations observed since the last scan."""
        self.advance(t_ms)
        if self._fused is not None:
            return self._scan_fused(t_ms)
        lp = self.leader.pose
        fol = self.followers
        truth_l = self._to_leader(lp, fol.x, fol.y)
        model = self.localization
        pts, sensed = model.sense(truth_l)
        if self._predicted:
            # the estimates carried to the scan with the commands held, in the leader's
            # frame now (the leader knows its own motion; never the followers' truth)
            centre = self._to_leader(lp, *self._carried(t_ms))
        else:
            centre = list(self._centre)
        r_F, max_range = self._r_F, self._max_range
        # the beams the leader expects from its own prediction (search = "visible"), counted
        # when a model first reads them (only for a window without a fix)
        expected = ExpectedBeams(centre, r_F, max_range) if self._visible else None
        fixes, voted = model.locate(sensed, truth_l, pts, centre, expected)
        cols, errors, changes, violations = self._changes(truth_l, fol.odometer, fixes)
        return self._scan_of(
            t_ms, lp, truth_l, centre, pts, cols, errors, changes, violations, voted
        )

    def _scan_of(
        self,
        t_ms: float,
        lp: Pose,
        truth_l: list[XY],
        centre: list[XY],
        pts: list[int],
        cols: tuple[list[XY], list[bool], list[bool], list[bool], list[bool], list[bool]],
        errors: list[float],
        changes: tuple[list[float], list[float], list[float], list[float]],
        violations: tuple[list[bool], list[bool], list[bool], list[bool]],
        voted: list[int] | None,
    ) -> Scan:
        """The `Scan` of these columns (``cols``: the fixes' fields; ``changes``: the truth's
        displacement, Δρ, travel and Δβ; ``violations``: the localization, separation, path
        diversion and bearing bounds', as `_changes` gives them), with each lost track's
        cause; the Python and the compiled scan both end here."""
        measured, in_ws, losts, searched, reacqs, neighbours = cols
        disps, d_rhos, travels, d_betas = changes
        v_loc, v_sep, v_path, v_bear = violations
        return Scan._of(
            t_ms,
            lp,
            {
                "points": pts,
                "measured": measured,
                "truth": truth_l,
                "centre": centre,
                "in_window": in_ws,
                "lost": losts,
                "reacquired": reacqs,
                "changes": {
                    "displacement": disps,
                    "d_rho": d_rhos,
                    "travel": travels,
                    "d_beta": d_betas,
                },
                "violations": {
                    "localization": v_loc,
                    "separation": v_sep,
                    "path_diversion": v_path,
                    "bearing": v_bear,
                },
                "searched": searched,
                "cause": self._causes(losts, neighbours, pts, truth_l),
                "voted": voted or None,
                "fix_error": errors,
                "neighbour": neighbours if voted else None,
                "cells": self.localization.cells,
            },
        )

    def _causes(
        self, losts: list[bool], neighbours: list[bool], pts: list[int], truth_l: list[XY]
    ) -> list[str]:
        """Why each follower's track was lost ("": it was not; `lost_cause`)."""
        if True not in losts:
            return [""] * len(losts)
        r_F, max_range, min_pts = self._r_F, self._max_range, self._min_pts
        return [
            ""
            if not lost
            else "neighbour"
            if nb
            else lost_cause(p >= min_pts, tr, r_F, max_range, min_pts)
            for lost, nb, p, tr in zip(losts, neighbours, pts, truth_l, strict=True)
        ]

    def scan_estimate(self, t_ms: float) -> Scan:
        """`scan` at ``t_ms``, then `estimate` with it: one compiled call for both in the
        compiled backend with the hough model when every window has its fix (`scan_step`'s
        mode 1); the scan."""
        if self._fused is None:
            scan = self.scan(t_ms)
            self.estimate(scan)
            return scan
        if t_ms < self._est_t:
            self._not_older(t_ms)  # (raises)
        self.advance(t_ms)
        return self._scan_fused(t_ms, True)

    @property
    def scan_array(self) -> Any:
        """The fused scan's float rows as its kernel writes them (`FLOAT_ROWS`: rewritten by
        every scan, so a reader that keeps them copies them), or None where the scan does
        not fuse."""
        fused = self._fused
        return None if fused is None else fused.T

    def log_truth(self, law: Any, rho_d: Sequence[float], guess: Sequence[float]) -> Any:
        """Make a truth log's samples in every scan from now on (the fused scan's call,
        `rtsim.world.scanstep.FusedScan.log_truth`; read from `scan_rows`) for a log on
        ``law`` — this world's follow-the-leader law or a clone of it (`TraceFollower.clone`:
        its geometry the same object) — with ρ_d and the first guesses per follower: the
        scan's arc lengths of the log's projections from now on (the law's ``_sf`` until
        then, copied in), or None where the scan does not make them (no fused scan, no
        compiled law, another law's geometry)."""
        fused = self._fused
        if fused is None or law is None:
            return None
        return fused.log_truth(getattr(law, "_G", None), law._sf, rho_d, guess)

    def _not_older(self, t_ms: float) -> None:
        """Refuse a scan at ``t_ms`` older than the estimates (`estimate`, `scan_estimate`)."""
        if t_ms < self._est_t:
            raise RtsimError(f"scan at {t_ms} ms is older than the estimates ({self._est_t} ms)")

    def _scan_fused(self, t_ms: float, estimate: bool = False) -> Scan:
        """`scan` (advanced to ``t_ms``) with the hough model in the compiled backend: the
        laser, the windows' centres, the Hough windows, the fixes and the truth's change in
        one compiled call (`FusedScan`), and with ``estimate`` the estimate too
        (`scan_estimate`). When every window has its fix (the rule), the scan's fields are
        the kernel's columns as lists, the pairs (fixes, truth, centres) zipped when first
        read (`FusedFields`); else `_scan_searched`, then the estimate."""
        ld = self.leader
        lp = ld.path.pose(ld.s)  # (`Leader.pose`: its path's memo, which `advance` set)
        fol = self.followers
        fused = self._fused
        model = self.localization
        assert fused is not None and self._arr is not None and isinstance(model, HoughModel)
        predicted = self._predicted
        if not predicted:
            fused.T[2:4] = np.array(self._centre).T
        W = fol.S  # type: ignore[attr-defined]  # (the truth's rows, `GROUP_ROWS`)
        # (the model's draw: in the kernel from the stream's state, else here)
        z = None if self._pcg is not None else self._draw(LASER_POINTS)
        E, a, var = self._arr.E, self._accel, self.max_heading_var
        est = fused.run(W, lp, z, E, t_ms, a, predicted, 1 if estimate else 0, var, predicted)
        T = self.scan_rows = fused.T.tolist()
        B = fused.B.tolist()
        pts, voted = fused.N.tolist()
        in_ws, losts, neighbours, unfixed, v_loc, v_sep, v_path, v_bear = B
        if True in unfixed:  # a window without a fix
            scan = self._scan_searched(t_ms, lp, T, B, pts, voted)
        else:
            n = len(pts)
            raw = FusedFields(
                points=pts,
                in_window=in_ws,
                lost=losts,
                reacquired=[False] * n,
                changes={
                    "displacement": T[9],
                    "d_rho": T[10],
                    "travel": T[11],
                    "d_beta": T[12],
                },
                violations={
                    "localization": v_loc,
                    "separation": v_sep,
                    "path_diversion": v_path,
                    "bearing": v_bear,
                },
                searched=[False] * n,
                voted=voted or None,
                fix_error=T[6],
                neighbour=neighbours if voted else None,
                cells=model.cells,
                # (every window has its fix: a lost track is a neighbour's, `_causes`,
                # asked for below)
                cause=[""] * n,
            )
            raw.T = T
            if True in losts:
                raw["cause"] = self._causes(losts, neighbours, pts, raw["truth"])
            scan = Scan._of(t_ms, lp, raw)
        if not estimate:
            self._fixes_of = (scan, fused.F)
            return scan
        if est < 0.0:  # (a window was searched for: its fix packed since)
            est = fused.run(W, lp, z, E, t_ms, a, predicted, 2, var, predicted)
        self._estimated(scan, est)
        return scan

    def _scan_searched(
        self,
        t_ms: float,
        lp: Pose,
        T: list[list[float]],
        B: list[list[bool]],
        pts: list[int],
        voted: list[int],
    ) -> Scan:
        """`_scan_fused`'s scan when a window has no fix (the kernel's columns ``T``, ``B``,
        ``pts``, ``voted`` as lists): each such window searched for as `HoughModel.locate`
        does, its fix packed for the estimate (`FusedScan.F`)."""
        fused, model = self._fused, self.localization
        assert fused is not None and isinstance(model, HoughModel)
        tx, ty, cx, cy, mx, my, errors, _, _, disps, d_rhos, travels, d_betas = T[:13]
        in_ws, losts, neighbours, unfixed, v_loc, v_sep, v_path, v_bear = B
        truth_l = list(zip(tx, ty, strict=True))
        centre = list(zip(cx, cy, strict=True))
        measured = list(zip(mx, my, strict=True))
        searched = [False] * len(pts)
        reacqs = [False] * len(pts)
        expected = ExpectedBeams(centre, self._r_F, self._max_range) if self._visible else None
        rf = model.rangefinder
        beams, F = (rf.px, rf.py, rf.owner), fused.F
        for k, u in enumerate(unfixed):
            if not u:
                continue
            fix, in_w, lost, search, reacq, nb = model._search(k, beams, centre[k], expected)
            measured[k], in_ws[k], losts[k], searched[k], reacqs[k] = (
                fix,
                in_w,
                lost,
                search,
                reacq,
            )
            neighbours[k] = nb
            if in_w or reacq:
                errors[k] = _FIX_ERROR(fix[0], fix[1], tx[k], ty[k])
            F[k] = (fix[0], fix[1], 1.0 if in_w else 2.0 if reacq else 0.0)
        changes = (disps, d_rhos, travels, d_betas)
        violations = (v_loc, v_sep, v_path, v_bear)
        cols = (measured, in_ws, losts, searched, reacqs, neighbours)
        return self._scan_of(
            t_ms, lp, truth_l, centre, pts, cols, errors, changes, violations, voted
        )

    def violations_of(self, changes: Array) -> NDArray[np.bool_]:
        """The violations scans with these ``changes`` flagged: ``changes`` an (m, 4, n) array
        of each scan's displacement, |Δρ|, travel and |Δβ| per follower (`Scan.changes`,
        `rtsim.coupling.recorder.changes_array`), the flags an (m, 4, n) bool array in
        `rtsim.analysis.kinematics.BOUND_KINDS` order: `bound_violations` with this world's
        thresholds, over every scan at once (the comparisons each scan made, to the bit)."""
        disp, d_rho, travel, d_beta = changes.transpose(1, 0, 2)
        flags = _VIOLATIONS(
            disp, d_rho, travel, d_beta, self._r_H, self._sep_limit, self._travel_limit,
            self._T_beta,
        )  # fmt: skip
        return np.stack(flags, axis=1)

    def _changes(
        self, truth_l: list[XY], odometer: list[float], fixes: list[Fix]
    ) -> tuple[
        tuple[list[XY], list[bool], list[bool], list[bool], list[bool], list[bool]],
        list[float],
        tuple[list[float], list[float], list[float], list[float]],
        tuple[list[bool], list[bool], list[bool], list[bool]],
    ]:
        """The fixes' fields as lists (`Fix`: fix, in window, lost, searched, re-acquired,
        neighbour), each fix's distance from the truth (inf: none), the truth's change since
        the previous scan (zeros at the first) and the violations it makes, per bound kind
        (`_scan_of`'s order); remembers this scan's truth for the next. (One loop: at a few
        followers a comprehension per list costs more than the arithmetic.)"""
        inf = math.inf
        change, violated, error = _TRUTH_CHANGE, _VIOLATIONS, _FIX_ERROR
        odo = list(odometer)
        prev = self._prev
        first = prev is None
        if prev is None:
            p_truth, p_rho, p_beta, p_odo = truth_l, odo, odo, odo  # (unread at the first)
        else:
            p_truth, p_rho, p_beta, p_odo = prev
        r_H, T_beta = self._r_H, self._T_beta
        sep_lim, trav_lim = self._sep_limit_l, self._travel_limit_l
        measured: list[XY] = []
        in_ws: list[bool] = []
        losts: list[bool] = []
        searched: list[bool] = []
        reacqs: list[bool] = []
        neighbours: list[bool] = []
        errors, rhos, betas = [], [], []
        disps, d_rhos, travels, d_betas = [], [], [], []
        v_loc, v_sep, v_path, v_bear = [], [], [], []
        for k, (tx, ty) in enumerate(truth_l):
            fix, in_w, lost, search, reacq, neighbour = fixes[k]
            measured.append(fix)
            in_ws.append(in_w)
            losts.append(lost)
            searched.append(search)
            reacqs.append(reacq)
            neighbours.append(neighbour)
            if in_w or reacq:
                mx, my = fix
                errors.append(error(mx, my, tx, ty))
            else:
                errors.append(inf)
            px, py = p_truth[k]
            rho, beta, disp, d_rho, travel, d_beta = change(
                tx, ty, odo[k], px, py, p_rho[k], p_beta[k], p_odo[k], first
            )
            rhos.append(rho)
            betas.append(beta)
            disps.append(disp)
            d_rhos.append(d_rho)
            travels.append(travel)
            d_betas.append(d_beta)
            vl, vs, vp, vb = violated(
                disp, d_rho, travel, d_beta, r_H, sep_lim[k], trav_lim[k], T_beta
            )
            v_loc.append(vl)
            v_sep.append(vs)
            v_path.append(vp)
            v_bear.append(vb)
        self._prev = (truth_l, rhos, betas, odo)
        changes = (disps, d_rhos, travels, d_betas)
        violations = (v_loc, v_sep, v_path, v_bear)
        cols = (measured, in_ws, losts, searched, reacqs, neighbours)
        return cols, errors, changes, violations

    def estimate(self, scan: Scan) -> None:
        """EKF predict (commands held since the last estimate) and update from ``scan``'s fixes;
        the estimates at the scan centre the next Hough windows (``previous``) or are
        carried from there (``predicted``)."""
        t = scan.t_ms
        self._not_older(t)
        if self._arr is not None:
            self._estimate_arrays(scan)
            return
        a = self._accel
        xl, yl, hl = scan.leader_pose
        c, s = math.cos(hl), math.sin(hl)
        measured = scan.as_lists("measured")
        in_window = scan.as_lists("in_window")
        reacquired = scan.as_lists("reacquired")
        predicted = self._predicted
        all_pieces, vhat, what = self._pieces, self._vhat, self._what
        for k, f in enumerate(self._filters):
            pieces = all_pieces[k]
            v, w = vhat[k], what[k]
            last = len(pieces) - 1
            keep: list[tuple[float, float, float]] = []
            for j, piece in enumerate(pieces):
                t0, vc, wc = piece
                if t0 >= t:
                    keep.append(piece)
                    continue
                nxt = pieces[j + 1][0] if j < last else math.inf
                t1 = nxt if nxt < t else t
                v, w = f.predict_command(v, w, vc, wc, a, (t1 - t0) / 1000.0)
                if nxt > t:  # (the piece held at t: what follows it starts later)
                    keep.insert(0, (t, vc, wc))
            all_pieces[k] = keep or [(t, pieces[-1][1], pieces[-1][2])]
            vhat[k], what[k] = v, w
            if in_window[k]:
                mx, my = measured[k]
                f.update((xl + c * mx - s * my, yl + s * mx + c * my))
            elif reacquired[k]:
                mx, my = measured[k]
                f.reset_position((xl + c * mx - s * my, yl + s * mx + c * my))
            if predicted:
                var = f.heading_var
                if var > self.max_heading_var:
                    self.max_heading_var = var
        self._est_t = t
        self._marks = [None] * len(self._marks)
        if not predicted:  # (a predicted centre is carried from the estimates at each scan)
            self._centre = self._to_leader(scan.leader_pose, *self._estimated_xy())

    def _estimate_arrays(self, scan: Scan) -> None:
        """`estimate`'s loop and its ending as one compiled call on the compiled backend's
        estimates (`CompiledEstimates.scan`), with the fixes the fused scan packed when
        ``scan`` is its last (`_scan_fused`)."""
        fixes: list[float] | Array
        last = self._fixes_of
        if last is not None and last[0] is scan:
            fixes = last[1]
        else:
            fixes = []
            measured = scan.as_lists("measured")
            in_window = scan.as_lists("in_window")
            reacquired = scan.as_lists("reacquired")
            for (mx, my), w, r in zip(measured, in_window, reacquired, strict=True):
                fixes += (mx, my, 1.0 if w else 2.0 if r else 0.0)
        arr = self._arr
        assert arr is not None
        var = arr.scan(scan.t_ms, scan.leader_pose, fixes, self.max_heading_var, self._predicted)
        self._estimated(scan, var)

    def _estimated(self, scan: Scan, var: float) -> None:
        """The compiled estimate's ending: the heading variance's max ``var``, the estimates'
        time, and the next windows' centres (``previous``)."""
        self.max_heading_var = var
        self._est_t = scan.t_ms
        if not self._predicted:
            self._centre = self._to_leader(scan.leader_pose, *self._estimated_xy())

    # -- commands --------------------------------------------------------------------
    def command(self, i: int, t_ms: float) -> tuple[float, float]:
        """Compute follower i's (speed, turn rate) by l-ψ or follow-the-leader control on the
        leader's estimate at ``t_ms`` and apply it (with actuation noise) until the next command.

        Returns the command sent (saturated, before the actuation noise).
        """
        k = i - 1
        if not 0 <= k < self._n:
            raise IndexError(f"follower {i} does not exist (1..{self.n})")
        if self._fused_send is not None:  # (`_actuate`'s draws and realised command in it)
            return self._fused_send(k, t_ms)
        if t_ms != self._t:
            self._advance_leader(t_ms)
        fol = self.followers
        fol.advance(k, t_ms, self._step_ms)
        est = self._propagate(k, t_ms)
        x, y, th = est[0]
        ld = self.leader
        if self._ftl is not None:
            v, w = self._ftl.command(k, ld.s, ld.pose, ld.speed, x, y, th)
        else:
            v, w = self._lpsi(k, x, y, th)
        return self._hold(k, t_ms, fol.saturate(v, w), est)

    def sender(self) -> Callable[[int, float], tuple[float, float]] | None:
        """`command` as one Python call for a caller that sends many (the coupling's send
        hook): ``send(k, t_ms)`` is ``command(k + 1, t_ms)`` for follower index ``k`` (no
        index check). None where `command` does not fuse: the caller uses `command`."""
        return self._fused_send

    def _fused_sender(self) -> Callable[[int, float], tuple[float, float]]:
        """`command`'s path with the compiled law (`CompiledEstimates.fuse_ftl`): the
        actuation's two normals (as `_normals` takes them: its call when the block is used
        up), then the leader and the follower advanced, the estimate, the law, saturation,
        hold and actuation in one compiled call (`est_command_ftl`, on the followers' array;
        `_advance_leader`'s check first); returns the command sent. Made once per world: its
        lists and arrays are read through the objects that keep them where they can grow
        (``arr.E``)."""
        arr, ld, fol = self._arr, self.leader, self.followers
        assert arr is not None
        entry, run, last = arr._ftl_entry, arr._ftl_run, arr.last
        normals, leader_to, moved = self._normals, self._advance_leader, fol.moved  # type: ignore[attr-defined]

        def send(k: int, t_ms: float) -> tuple[float, float]:
            t0 = self._t
            if t_ms > t0:  # (the leader driven in the call: `_advance_leader`)
                dt = (t_ms - t0) / 1000.0
                self._t = t_ms
            else:
                leader_to(t_ms)  # (a time before the world's is refused)
                dt = 0.0
            i = self._zi
            z = self._z
            if i + 2 <= len(z):
                nv = z[i]
                nw = z[i + 1]
                self._zi = i + 2
            else:
                nv, nw = normals(2)
            v, w, held, ld.speed, ld.s = entry(
                k, t_ms, ld.s, ld.speed, ld.target_speed, dt, nv, nw, arr.E, *run
            )
            moved()  # (the follower and its command in the array)
            if held:  # (the command held is the one returned: one tuple)
                cmd = last[k] = (v, w)
                return cmd
            arr.hold(k, t_ms, v, w)  # (the row was full: held once it has grown)
            return v, w

        return send

    def _lpsi(self, k: int, x: float, y: float, th: float) -> tuple[float, float]:
        """Follower index k's l-ψ command (unsaturated) for its estimate (x, y, θ)."""
        ld = self.leader
        kappa = ld.curvature
        if kappa != self._kappa_targets:  # (NaN at first: made then)
            targets = control_targets(
                self._rho_d, self._beta_d, self.config.follower.control_offset, kappa
            )
            self._kappa_targets = kappa
            self._targets_l = (targets[0].tolist(), targets[1].tolist())
        l_d, psi_d = self._targets_l
        return lpsi_command(  # type: ignore[no-any-return]
            ld.pose, ld.speed, kappa * ld.speed, x, y, th, l_d[k], psi_d[k], self.config.follower
        )

    def _hold(
        self,
        k: int,
        t_ms: float,
        cmd: tuple[float, float],
        est: tuple[Pose, float, float] | None = None,
    ) -> tuple[float, float]:
        """Record follower index k's command for the estimates and apply it with noise;
        ``est``: `_propagate` (k, t_ms), kept as the mark where the new piece begins."""
        if self._arr is not None:
            self._arr.hold(k, t_ms, *cmd)
            return self._actuate(k, cmd)
        pieces = self._pieces[k]
        if pieces and pieces[-1][0] >= t_ms:
            pieces.pop()
        mark: Mark | None = None
        if est is not None and (not pieces or pieces[-1][0] < t_ms):
            (x, y, th), v, w = est
            f = self._filters[k]
            mark = (len(pieces), t_ms, f.pose, (self._vhat[k], self._what[k]), (x, y, th), v, w)
        self._marks[k] = mark
        v, w = cmd
        pieces.append((t_ms, v, w))
        return self._actuate(k, cmd)

    def _actuate(self, k: int, cmd: tuple[float, float]) -> tuple[float, float]:
        """Apply follower index k's command with its actuation noise (two normals drawn);
        returns it."""
        nv, nw = self._normals(2)
        self.followers.apply_drawn(k, cmd[0], cmd[1], nv, nw)
        return cmd

    @property
    def follow_law(self) -> TraceFollower | None:
        """The follow-the-leader law the commands use (None for l-ψ); read it, do not drive
        it (`TraceFollower.clone` for a copy to play commands ahead on)."""
        return self._ftl

    def held_command(self, i: int) -> tuple[float, float]:
        """The command (speed, turn rate) the leader last sent follower i, as its estimate
        holds it (before the actuation noise)."""
        if self._arr is not None:
            return self._arr.last[i - 1]
        _, v, w = self._pieces[i - 1][-1]
        return v, w

    # -- relative states and snapshots -----------------------------------------------
    def relative(
        self, i: int, source: Literal["truth", "estimate"] = "truth"
    ) -> tuple[float, float, float, float]:
        """(ρ, β, θ, V_F) of follower i now, docs/model/upper-bounds.md conventions, from the truth
        or from the
        leader's estimate (pose propagated to now, V_F the speed it expects)."""
        k = i - 1
        if not 0 <= k < self.n:
            raise IndexError(f"follower {i} does not exist (1..{self.n})")
        if source == "truth":
            fol = self.followers
            fol.advance(k, self._t, self.config.step_ms)
            pose: Pose = fol.pose(k)
            v_f = fol.v[k]
        elif source == "estimate":
            pose, v_f, _ = self._propagate(k, self._t)
        else:
            raise ValueError(f"source must be 'truth' or 'estimate', got {source!r}")
        rho, beta, theta = relative_state(self.leader.pose, pose)
        return rho, beta, theta, v_f

    def state(self) -> dict[str, Any]:
        """A plain snapshot: time, leader, true and estimated follower poses (lists)."""
        ld = self.leader
        xl, yl, hl = ld.pose
        kind, kappa = ld.segment()
        est = [self._propagate(k, self._t) for k in range(self.n)]
        fol = self.followers
        fol.advance_all(self._t, self.config.step_ms)
        return {
            "t_ms": self._t,
            "leader": {
                "x": xl,
                "y": yl,
                "heading": hl,
                "s": ld.s,
                "speed": ld.speed,
                "target_speed": ld.target_speed,
                "desired_speed": ld.desired_speed,
                "omega": ld.omega,
                "segment": kind,
                "curvature": kappa,
            },
            "truth": {
                "x": list(fol.x),
                "y": list(fol.y),
                "heading": list(fol.th),
                "speed": list(fol.v),
                "odometer": list(fol.odometer),
            },
            "estimate": {
                "x": [e[0][0] for e in est],
                "y": [e[0][1] for e in est],
                "heading": [e[0][2] for e in est],
                "speed": [e[1] for e in est],
            },
        }
