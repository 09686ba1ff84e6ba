"""Schedule and world in one SimPy run (docs/model/adjustment.md, docs/model/world.md).

The virtual [`CPU`][rtsim.sim.cpu.CPU] runs the leader's task set (dead reckoning, the
window chain, the command task of period 2w) and drives the
[`World`][rtsim.world.world.World] from its hooks: a window's release takes the latest
decision's w and speed, its scan samples the world and updates the EKFs, its Hough stretch
costs Eq 1 for the beams counted, ``send[i]`` applies follower i's command, and its completion
runs the policy's ``decide`` ([`rtsim.control.decide`][rtsim.control.decide]). The rules of a
run (first window, execution times, overload, what is dropped): docs/scenarios.md; how long
it lasts: `rtsim.coupling.duration` and docs/configuration.md.
"""

from __future__ import annotations

import gc
import inspect
import math
import os
import secrets
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from itertools import repeat
from operator import attrgetter, is_
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
import simpy

import rtsim.coupling.duration as run_duration
from rtsim._numbers import is_int, is_real
from rtsim._suggest import did_you_mean
from rtsim.control.adjust import predicted_rows
from rtsim.control.compiled import PaperSearch
from rtsim.control.oracle import lap_oracle
from rtsim.control.policy import (
    AdjustOptions,
    PolicyInput,
    adjust_options,
    input_maker,
    policy_class,
)
from rtsim.control.predict import trusted_estimate
from rtsim.control.rollout import Rollout, rollout_state
from rtsim.coupling.duration import LAP_CAP_FACTOR, run_length
from rtsim.coupling.inputs import ScenarioInputs as ScenarioInputs
from rtsim.coupling.inputs import _inputs as _inputs
from rtsim.coupling.inputs import fitted_taskset
from rtsim.coupling.inputs import resolved as resolved
from rtsim.coupling.inputs import scenario_inputs as scenario_inputs
from rtsim.coupling.physical import PhysicalLog
from rtsim.coupling.prepared import run_constant, settled_world, window_bound
from rtsim.coupling.recorder import (
    CHANGE_KEYS,
    ScanChanges,
    StateRows,
    WindowRecord,
    WindowRecorder,
    changes_array,
    records_columns,
    records_frame,
)
from rtsim.coupling.summary import _name as _name
from rtsim.coupling.summary import formation_model as formation_model
from rtsim.coupling.summary import summarize as summarize
from rtsim.coupling.summary import summary_columns as summary_columns
from rtsim.coupling.tidy import followers_frame
from rtsim.errors import InputError
from rtsim.io.limits import check
from rtsim.io.work import check_coupled, check_seed
from rtsim.model.task import Segment
from rtsim.model.taskset import TaskSet
from rtsim.notebook import ResultDisplay, flatten
from rtsim.sim.cpu import Job
from rtsim.sim.execution import ExecSpec, uniforms
from rtsim.sim.progress import TICKS, start_ticker
from rtsim.sim.run import build_cpu
from rtsim.world.contact import closest_each, contact_distance
from rtsim.world.localization import counted_time, search_time
from rtsim.world.motionmodels import motion_model
from rtsim.world.scanstep import TRUTH_ROW
from rtsim.world.world import World

__all__ = [
    "ScenarioInputs",
    "ScenarioResult",
    "run_scenario",
    "scenario_inputs",
    "summarize",
    "LAP_CAP_FACTOR",
]

#: Relative overshoot left out of ``summary['violations_beyond_5pct']``.
VIOLATION_TOLERANCE = 0.05
#: The scans' counts whose Hough time a run keeps (`_Coupling._hough_of`) at most.
HOUGH_MEMO = 4096


class _Records(NamedTuple):
    """A run's complete window records, for the frame of a result that nobody has read yet
    (`_Frame`)."""

    recs: list[WindowRecord]
    n: int
    limits: tuple[tuple[float, ...], ...]

    def frame(self) -> pd.DataFrame:
        return records_frame(self.recs, self.n, self.limits)


class _Frame:
    """A result's ``windows``, built from its records when first read: a sweep point or a
    benchmark that reads only the summary does not pay for the followers' state, estimate
    and bound columns nor the DataFrame (≈ 4 ms of a Test 2 lap at n = 2). Reading it gives
    the frame built at once would have; until then the result holds the records."""

    def __init__(self, key: str) -> None:
        self.key = key  # (where the instance keeps it)

    def __get__(self, obj: Any, owner: type | None = None) -> Any:
        if obj is None:  # (no default: the dataclass's field stays required)
            raise AttributeError(self.key)
        value = obj.__dict__[self.key]
        if isinstance(value, _Records):
            value = obj.__dict__[self.key] = value.frame()
        return value

    def __set__(self, obj: Any, value: Any) -> None:
        obj.__dict__[self.key] = value


@dataclass(repr=False)
class ScenarioResult(ResultDisplay):
    """A coupled run: ``windows`` (windows.csv), ``jobs`` (job records or None), ``summary``
    (summary.json; ``windows`` is None when they were streamed to a ``window_sink``),
    ``timing`` (seconds: wall ``setup_s``, ``simulation_s``, ``tables_s``, and
    ``simulation_cpu_s``, the process CPU time of the loop — robust on a shared machine);
    ``trace`` (the execution trace, with ``record_trace=True``)."""

    windows: pd.DataFrame | None  # (a `_Frame`, set below)
    jobs: pd.DataFrame | None
    summary: dict[str, Any]
    timing: dict[str, float]
    inputs: ScenarioInputs
    trace: pd.DataFrame | None = None

    def headline(self) -> dict[str, Any]:
        """The run's headline facts (the short ``repr``)."""
        s = self.summary
        return {
            k: s.get(k)
            for k in (
                "scenario",
                "mode",
                "seed",
                "duration_s",
                "windows",
                "missed",
                "tracks_lost",
                "critical_share",
                "min_speed_ratio",
            )
        }

    def summary_frame(self) -> pd.DataFrame:
        """summary.json as one row (nested keys dotted), so runs concatenate into a table."""
        return pd.DataFrame([flatten(self.summary)])

    @property
    def followers(self) -> pd.DataFrame | None:
        """``windows`` in long form, one row per window and follower (position, estimate,
        fix error, each bound ``_pred``/``_true``, violations, lost: `rtsim.coupling.tidy`;
        ``followers.csv``); None when the windows were streamed to a sink."""
        return None if self.windows is None else followers_frame(self.windows)


# the field `windows` read and written through `_Frame` (set after the dataclass made its
# __init__, which assigns it: a data descriptor's __set__)
setattr(ScenarioResult, "windows", _Frame("_windows"))  # noqa: B010


class _Decision(NamedTuple):
    w: float
    v_leader: float
    msb_min: float
    binding: str
    method: str
    feasible: bool
    est: StateRows  # (the est columns' rows)
    # the decision's belief, to evaluate its bounds at another leader speed (_pred columns):
    # the followers' estimates, predictor options, and the rows it computed at two speeds
    fols: tuple[Any, ...] = ()
    kw: Mapping[str, Any] = {}
    known: tuple[tuple[float, Any], ...] = ()
    # each follower's closest approach among the estimates it decided on (the contact
    # columns' prediction when the decision has no rollout)
    near: tuple[float, ...] = ()


#: an instance made without its ``__init__`` (its fields set by the caller)
_BARE = object.__new__
_CHANGES = attrgetter("changes")

#: `_Decision` from its eleven fields in order (namedtuple's ``_make``: no Python ``__new__``)
_DECISION = _Decision._make


class _Coupling:
    """The run's state and the CPU hooks (internal; see the module docstring)."""

    def __init__(
        self,
        inp: ScenarioInputs,
        policy: str | None,
        seed: int,
        exec_model: ExecSpec,
        record_jobs: bool,
        horizon_ms: float,
        stop_s: float | None,
        stop_ms: float = 0.0,
        record_trace: bool = False,
        job_sink: Any = None,
        trace_sink: Any = None,
        force: bool = False,
    ) -> None:
        where = inp.source or inp.name or "scenario"
        cfg = self.cfg = self._given = inp.world
        ts = self.ts = fitted_taskset(inp.taskset, cfg, where)
        self.thr = cfg.thresholds
        # run_scenario(policy=) overrides the file's [adjust] policy
        adj = adjust_options(inp.adjust, f"{inp.source or 'scenario'}: adjust", policy)
        # the window's lower bound (w_sch unless [adjust] lower_bound says otherwise; the
        # column and summary keep the name w_sch): the CPU below runs the set's scheduler
        # ([scheduler] policy, fp by default) with Δt idle
        self.w_sch = window_bound(
            ts,
            adj.lower_bound,
            scheduler=ts.scheduler,
            suspension="idle",
            where=f"{where}: adjust",
            force=force,
        )
        if not math.isfinite(self.w_sch):
            raise InputError(f"{where}: {adj.lower_bound} is infinite")
        self.infeasible_note = self._unrestorable()
        if adj.cap is not None and adj.cap < self.w_sch:
            raise InputError(
                f"{where}: adjust.cap: {adj.cap:g} ms is below w_sch = {self.w_sch:.6g} ms (the "
                f"window could never reach the schedulability bound)"
            )
        self.v_ld = cfg.leader_speed
        self.v_floor = adj.floor_frac * cfg.leader_speed
        if cfg.start_on == "straight" and cfg.start_speed is None:
            # settled: at the speed the bounds allow at the start (V_Ld unless less)
            cfg = self.cfg = settled_world(cfg, self.w_sch)
        ss = np.random.SeedSequence(seed)
        world_ss, cpu_ss = ss.spawn(2)
        self.world = World(cfg, np.random.default_rng(world_ss))
        # the radio link's draws: a generator of its own, spawned after the world's and the
        # CPU's, so a run whose link draws nothing sees the same numbers as before it existed
        self.radio = cfg.radio
        self._radio_rng = np.random.default_rng(ss.spawn(1)[0]) if self.radio.varies else None
        self._take_policy(adj)
        self.n = cfg.n
        self.rho_d = [float(r) for r in cfg.formation.rho_d]
        self._contact_cm = contact_distance(cfg.follower.radius, cfg.formation.clearance)
        self.phys = PhysicalLog(
            self.n,
            self.rho_d,
            cfg.follower.radius,
            self.world.follow_law,
            clearance=cfg.formation.clearance,
        )
        self._phys_add = self.phys.adder()  # (`_on_scan`'s, its arguments bound once)
        self.beta_d = [float(b) for b in cfg.formation.beta_d]
        self.env = simpy.Environment()
        self.cpu, _ = build_cpu(
            ts,
            env=self.env,
            window=self._period,
            suspension="idle",
            exec_model=exec_model,
            seed=cpu_ss,
            record_jobs=record_jobs,
            record_trace=record_trace,
            job_sink=job_sink,
            trace_sink=trace_sink,
        )
        self._hook_window(where)
        self._start_state(horizon_ms, stop_s, stop_ms)
        self._record_limits()
        # each follower's send, ms after its window's scan (measured in the last window; the
        # chain's nominal offsets until then)
        self._send_offsets = self._nominal_offsets(ts)
        # (what `_on_send` reads, in one attribute: the clock, the open records, the fused
        # send or None, the offsets it measures, n, the link's loss)
        self._send_with = (self.env, self._open, self._send, self._send_offsets, self.n, self._loss)
        first = self._estimates(0.0)
        self.dec = first._replace(
            w=self.w_sch,
            v_leader=self._v_actual(),  # V_Ld, or a settled start's speed
            method="fixed",
            feasible=first.msb_min >= self.w_sch,
            known=first.known[:1],
        )

    def _take_policy(self, adj: AdjustOptions) -> None:
        """The run's policy and the decision's fixed inputs (`PolicyInput` without the
        followers and the leader's motion), from the validated ``[adjust]``."""
        cfg = self.cfg
        self.policy = adj.policy
        self.mode = str(self.policy.name)
        self.decide_at = adj.decide
        self._decide_at_end = self.decide_at == "end"
        self._before_send = self.decide_at == "before-send"
        predictor = adj.predictor
        # the paper's algorithm on the paper's predictor (its §3.3), whatever the file's
        # predictor is for its own policy, unless [adjust] paper_predictor = false
        if adj.paper_predictor and self.policy.name == "adjust":
            predictor = "paper"
        # the command-aware rollout (PolicyInput.rollout): the predictor "commands", or a
        # policy that asks for it (and then predicts with it)
        self._rollout = predictor == "commands" or bool(
            getattr(self.policy, "needs_rollout", False)
        )
        if self._rollout:
            predictor = "commands"
        # the estimates' FollowerEstimate rows: for the policy (unless its class sets
        # needs_followers = False and the rollout carries the estimates) and the _pred
        # columns of a decision without a rollout
        self._fols = not self._rollout or bool(getattr(self.policy, "needs_followers", True))
        # the rollout's per-run state (`rows_state`'s base, made at the first decision)
        self._ro_base: Any = None
        self._ro_make: Any = None  # (Rollout.decided of the base)
        self._ro_idle: tuple[tuple[float, ...], ...] = ()  # (its no-sends-pending tuple)
        # the motion model keeps a turn rate of its own (RolloutState.turns; empty: none)
        self._turn_state = bool(self.world.motion.subs)
        if (
            self.world.backend == "compiled"
            and type(predictor) is str
            and predictor == "paper"
            and self.thr.localization == "radial"
        ):
            predictor = PaperSearch()  # the same speeds, compiled
        self.predictor = predictor
        fixed: dict[str, Any] = {}
        self._path: tuple[tuple[float, ...], tuple[float, ...]] | None = None
        if getattr(self.policy, "needs_path", False):  # the leader's known path commands
            segs = cfg.path.segments
            starts = np.concatenate(([0.0], np.cumsum([g.length for g in segs])))
            self._path = (tuple(float(x) for x in starts), tuple(g.curvature for g in segs))
            fixed.update(accel_max=cfg.leader_accel_max, decel_max=cfg.leader_decel_max)
        self._noise = bool(getattr(self.policy, "needs_noise", False))
        if self._noise:  # the followers' actuation noise (PolicyInput.speed_noise, turn_noise)
            fixed.update(
                speed_noise=cfg.follower.speed_noise,
                turn_noise=cfg.follower.turn_noise,
                turn_error=motion_model(cfg.follower.motion_model).turn_error,
            )
        cap = adj.cap
        if cap is None and adj.cap_factor is not None:
            cap = float(adj.cap_factor) * self.w_sch
        self._input = PolicyInput(
            (),
            v_ld=self.v_ld,
            w_sch=self.w_sch,
            thresholds=self.thr,
            cap=cap,
            floor_frac=adj.floor_frac,
            floor_w=adj.floor_w,
            predictor=predictor,
            methods=adj.methods,
            scan_points=adj.scan_points,
            **fixed,
        )
        # each decision's: these fields set, the others the run's (a fast replace)
        self._make_input = input_maker(
            self._input, ("followers", "omega_l", "kappa", "v_now", "ahead", "pose_sd", "rollout")
        )
        # a policy that decides on the rollout alone (plan: `PlanPolicy.on_rollout`) skips
        # the PolicyInput per decision
        on_rollout = getattr(self.policy, "on_rollout", None) if self._rollout else None
        self._on_rollout = None if on_rollout is None else on_rollout(self._input)

    def _hook_window(self, where: str) -> None:
        """The window chain's constants and the CPU hooks that drive the world."""
        cfg, cpu = self.cfg, self.cpu
        win = self.ts.window
        assert win is not None  # (a scenario's task set has a [window])
        self.wname = win.name
        self._hough_args = (win.e_cal, win.e_trans, win.r_H)  # (`counted_time`'s)
        self._hough_memo: dict[tuple[int, Any, int, int], tuple[float, bool]] = {}
        self._search_ms = search_time(win.e_cal, win.e_trans, cfg.sensing.r_reacq)
        # Eq 1's assumption: a scan counts at most min(361, k·n) points (checked per window)
        self._points_assumed = min(361.0, win.k * win.n)
        # ... and its localization step at most Eq 1's time (the hough model counts the cells
        # its accumulators cover: the Gauss circle count, a few cells off π·r_H² either way)
        self._hough_assumed = win.e_hough()
        cpu.on("release", self._on_release, task=win.name)
        cpu.on("segment_start", self._on_scan, task=win.name, role="scan")
        cpu.on("segment_end", self._on_send, task=win.name, role="send")
        if self.decide_at == "before-send":
            cpu.on("segment_start", self._on_send_start, task=win.name, role="send")
        self._e_send = float(win.e_send)
        self._send = self.world.sender()  # (None: each send through World.command)
        self._loss = self.radio.loss if self.radio.loss > 0 else 0  # (0: no draw per send)
        # the link's draws (a round trip, a loss) in the order the hooks ask, taken ahead
        rng = self._radio_rng
        self._uniform = uniforms(rng).__next__ if rng is not None else None
        cpu.on("job_end", self._on_done, task=win.name)
        cpu.set_exec_time(win.name, "hough", self._hough_exec)
        self._delta_t = float(win.delta_t)
        if self.radio.min_ms is not None:
            if self.radio.min_ms > self._delta_t:
                raise InputError(
                    f"{where}: radio.min_ms: {self.radio.min_ms:g} ms is above the task set's "
                    f"delta_t ({self._delta_t:g} ms, the round trip's maximum)"
                )
            self._radio_span = (self.radio.min_ms, self._delta_t - self.radio.min_ms)
            cpu.set_exec_time(win.name, "radio", self._radio_exec)

    def _start_state(self, horizon_ms: float, stop_s: float | None, stop_ms: float) -> None:
        """The run's state before its first window: open records, the stop and the lap."""
        self._v_max = self._v_actual()  # highest leader speed since the last scan
        self._folded: dict[str, tuple[float, int]] = {}  # changes of records handed over
        self._open: dict[int, WindowRecord] = {}
        self._last_scanned: WindowRecord | None = None
        # n False, every record's lost and contact flags when none is set (one tuple for
        # the run: a record keeps no list of its own for them, `_on_scan`, `_close`)
        self._falses = (False,) * self.n
        self._hough_ms = 0.0
        self.horizon_ms = horizon_ms
        self._s0 = self.world.leader.s
        self._stop_s = stop_s  # arc length (cm) after which the run stops, or None
        self._stop_ms = stop_ms  # ... but not before this time
        self.stop = self.env.event()
        # the leader's first lap: (time ms, distance cm) at the last window completion before
        # it, then the interpolated completion time (ms)
        self._lap_cm = float(self.cfg.path.lap_length)
        self._lap_prev = (0.0, 0.0)
        self.lap_ms: float | None = None

    def _record_limits(self) -> None:
        """The four thresholds per follower (the violation ratios and the recorder's
        ``_true`` columns)."""
        rho_d = np.asarray(self.rho_d)
        thr = self.thr
        self._limits = (
            ("localization", "displacement", thr.r_H),
            ("separation", "d_rho", thr.T_rho * rho_d),
            ("path_diversion", "travel", thr.T_eps * rho_d),
            ("bearing", "d_beta", thr.T_beta),
        )
        # the same thresholds per follower, for the recorder's _true columns (kept per
        # process by the values they are made of: a sweep's next point makes none; n is
        # the spacings' count)
        self.rec = WindowRecorder(
            self.n,
            run_constant(
                ("limits", thr.r_H, thr.T_rho, thr.T_eps, thr.T_beta, tuple(self.rho_d)),
                lambda: tuple(
                    tuple(float(x) for x in np.broadcast_to(lim, self.n))
                    for _, _, lim in self._limits
                ),
            ),
        )
        self._records, self._chunk = self.rec.records, self.rec.chunk  # (`_on_release`)

    def _unrestorable(self) -> str | None:
        """A bound below w_sch whatever the leader's speed cannot be restored by slowing: the
        predicted-centre localization bound (docs/localization.md) depends on the noise and
        r_H alone. Then the leader does not park for it: the decisions leave it out (the
        world still loses what the window cannot hold), and the run reports it once (the
        returned note, summary.json ``infeasible_note``). None: no such bound."""
        thr = self.thr
        if thr.localization != "predicted" or not thr.predicted_ms < self.w_sch:
            return None
        self.thr = replace(thr, predicted_ms=math.inf)
        return (
            f"localization: the predicted-centre bound ({thr.predicted_ms:.4g} ms at r_H = "
            f"{thr.r_H:g} cm) is below w_sch ({self.w_sch:.4g} ms) at every leader speed: the "
            f"window is infeasible whatever V_L (r_H too small for the noise); the leader "
            f"does not slow for it and the run counts the tracks it loses"
        )

    def _heading_assumption(self) -> dict[str, Any]:
        """The predicted-centre bound's heading assumption (docs/localization.md): the heading
        SD it assumed (``[ekf] init_heading_sd``, rad), the largest the filters carried
        from a scan over a window (√P_θθ after the scan's update, rad,
        `rtsim.world.world.World.max_heading_var`), the turn noise the filters model
        (``[ekf] turn_noise``) and the followers' own (``[follower] turn_noise``, rad/s), and
        whether it held: the first SD bounds the second within `HEADING_SLACK` (the first
        scan's estimate carries P0 and one interval's drift), and the filters model at least
        the followers' turn noise (below it, P_θθ understates the heading error and cannot
        vouch for the assumption)."""
        assumed = float(self._given.ekf.init_heading_sd)
        carried = math.sqrt(self.world.max_heading_var)
        model = float(self._given.ekf.turn_noise)
        true = float(self._given.follower.turn_noise)
        held = carried <= assumed * (1.0 + HEADING_SLACK) and model >= true
        return {
            "assumed": assumed,
            "max_carried": carried,
            "filter_turn_noise": model,
            "turn_noise": true,
            "held": held,
        }

    # -- the decision ----------------------------------------------------------------
    def _nominal_offsets(self, ts: TaskSet) -> list[float]:
        """Each follower's send, ms after the scan starts, with the chain's WCETs and the
        Hough time of Eq 1 at its assumed points (before any window has run; made once per
        process for the window's values, `run_constant`: the run measures into its copy)."""
        win, n = ts.window, self.n

        def make() -> tuple[float, ...]:
            out: list[float] = []
            t = 0.0
            for seg in win.segments():  # type: ignore[union-attr]
                t += seg.wcet
                if seg.role == "send":
                    out.append(t)
            return (*out[:n], *[out[-1] if out else 0.0] * (n - len(out)))

        return list(run_constant(("sends", win, n), make))

    def _rollout_state(
        self,
        now: float,
        next_scan: float,
        pending: bool = False,
        rows: list[list[float]] | None = None,
    ) -> Any:
        """What the leader knows for its rollout at ``now``: the `Rollout` of a `RolloutState`
        (`rows_state` of the run's fixed fields, its state made when read: `Rollout.decided`);
        ``rows``: ``World.estimate_rows(now)`` if already read."""
        world = self.world
        if rows is None:
            rows = world.estimate_rows(now)
        make = self._ro_make
        if make is None:  # the fields that stay for the run (the others are set below)
            make = self._rollout_maker()
        ld = world.leader
        return make(
            now,
            ld.s,
            ld.speed,
            rows,  # (the held commands World.held_command's; turns expected_turn_rates)
            self._pending(now) if pending else self._ro_idle,
            next_scan if next_scan > now else now,  # (max(now, next_scan))
            tuple(self._send_offsets),
            self._turn_state,
        )

    def _rollout_maker(self) -> Any:
        """`Rollout.decided` of the run's base state (the `RolloutState` fields that stay for
        the run), made at the first decision and kept (``_ro_make``)."""
        cfg, world = self.cfg, self.world
        base = self._ro_base = rollout_state(
            cfg.path,
            world.follow_law,
            cfg.follower,
            cfg.step_ms,
            0.0,
            0.0,
            0.0,
            self.v_ld,
            cfg.leader_accel_max,
            cfg.leader_decel_max,
            (),
            (),
            (),
            (),
            0.0,
            (),
            self.thr,
            tuple(self.rho_d),
            self.w_sch,
            world.followers.rollout_group,
            tuple(self.beta_d),
            self._contact_cm,
        )
        make = self._ro_make = Rollout.decided(base)
        self._ro_idle = ((),) * self.n  # (no sends pending)
        # a policy that plans on the compiled rollout alone (`PlanPolicy.on_rollout`): the
        # rollout and its plan in one step a decision (`Rollout.planned`; `_estimates`)
        args = getattr(self._on_rollout, "plan_args", None)
        ctx = self._input  # (`Rollout.plan` plans on its base's V_Ld and w_sch only)
        same = (ctx.v_ld, ctx.w_sch) == (base.v_ld, base.w_sch)
        if args is not None and not self._fols and same:
            self._ro_step = Rollout.planned(base, self._turn_state, *args(base))
            self._ro_decision = self._on_rollout.decision  # type: ignore[union-attr]
        return make

    def _pending(self, now: float) -> tuple[tuple[float, ...], ...]:
        """The current window's sends still to come at its first send's start (``now``):
        follower i's at now + e_send + (its offset − the first's), the last window's spacing."""
        offs = self._send_offsets
        e, o0 = self._e_send, offs[0]
        return tuple([(now + e + (o - o0),) for o in offs])

    #: the rollout and the policy's plan on it in one step (`_rollout_maker`), or None
    _ro_step: Any = None
    #: with `_ro_step`, the policy's decision of its plan (`PlanPolicy.on_rollout`'s)
    _ro_decision: Any = None
    #: the fused scan's float rows (`rtsim.world.scanstep.FLOAT_ROWS`), which each record's
    #: truth copies (`_on_scan`), or None
    _scan_T: Any = None

    def _estimates(self, now: float, next_scan: float | None = None) -> _Decision:
        """Run the mode's decision on the leader's estimates at ``now``; ``next_scan``: when
        the window it governs scans (for the rollout; default now)."""
        world = self.world
        world.advance(now)
        ld = world.leader
        lp = ld.path.pose(ld.s)  # (World.leader_pose, `Leader.pose`: its path's memo)
        if self._ro_make is None and self._rollout:  # (the first decision: the run's maker)
            self._rollout_maker()
        kw: dict[str, Any]
        step = self._ro_step
        if step is not None:  # the policy plans on the compiled rollout alone: the
            # estimates' rows, the rollout and its plan in one step (`Rollout.planned`)
            if next_scan is None or not next_scan > now:  # (max(now, next_scan))
                next_scan = now
            ro, hit, rows = step(
                world.estimate_rows,
                now,
                ld.s,
                ld.speed,
                self._pending(now) if self._before_send and now > 0 else self._ro_idle,
                next_scan,
                tuple(self._send_offsets),
            )
            adj = self._ro_decision(hit)  # (the policy's `decision`, bound with the step)
            # (the est columns' rows: x, y, θ, V_F the first four rows of the pack's array
            # transposed, read when the table is made; one object a record, not its lists)
            state = StateRows(lp, rows.T, 0)
            fols: tuple[Any, ...] = ()
            kw = {"rollout": ro}
        else:
            # each follower's estimate propagated to now, its expected speed and turn rate
            # and its held command, in one pass (the same as World.estimated_pose(i) and
            # World.relative(i, "estimate")[3]; World.estimate_rows)
            rows = world.estimate_rows(now)
            # per follower (x, y, θ, ρ, β, θ_L − θ_F, V_F), the window's est columns (the
            # relative states made when read: StateRows; its poses read from the rows,
            # which no one changes)
            state = StateRows(lp, rows, None)
            fols = self._followers(state) if self._fols else ()
            # the predictor's options: for the policy's input and the _pred columns of a
            # decision without a rollout (one decided on the rollout alone reads only the
            # rollout)
            kw = {}
            if self._on_rollout is None:
                _, kappa = world.segment_at()
                kw.update(omega_l=world.leader_omega, kappa=kappa, v_now=self._v_actual())
            ro = None
            if self._rollout:  # (the _pred columns evaluate the same rollout: kw)
                ro = kw["rollout"] = self._rollout_state(
                    now,
                    now if next_scan is None else next_scan,
                    self._before_send and now > 0,
                    rows,
                )
            if self._on_rollout is not None:
                adj = self._on_rollout(ro)
            else:
                adj = self.policy.decide(
                    self._make_input(
                        fols,
                        kw["omega_l"],
                        kw["kappa"],
                        kw["v_now"],
                        () if self._path is None else self._ahead(),
                        self._pose_sd() if self._noise else (),
                        ro,
                    )
                )
        v_l = adj.v_leader
        if self.v_floor > v_l:  # (max(v_leader, v_floor): v_floor only when larger)
            v_l = self.v_floor
        # each follower's closest approach among the estimates: the contact prediction of a
        # decision without a rollout (`_close`; a rollout predicts its own)
        near: tuple[float, ...] = ()
        if ro is None:
            xs = [r[0] for r in rows]
            ys = [r[1] for r in rows]
            near = closest_each(xs, ys, lp[0], lp[1])
        return _DECISION(  # (_Decision's fields in order: the tuple made in C)
            (
                adj.w,
                v_l,
                adj.msb_min,
                adj.binding,
                adj.method,
                adj.feasible and v_l == adj.v_leader,
                state,
                fols,
                kw,
                ((self.v_ld, adj.rows), (adj.v_leader, adj.rows_after)),
                near,
            )
        )

    def _followers(self, state: Sequence[tuple[float, ...]]) -> tuple[Any, ...]:
        """The policy's `FollowerEstimate` per follower from the est columns ``state``."""
        rho_d, beta_d = self.rho_d, self.beta_d
        return tuple(
            [
                trusted_estimate(s[3], s[4], s[5], max(s[6], 0.0), rho_d[k], beta_d[k])
                for k, s in enumerate(state)
            ]
        )

    def _pose_sd(self) -> tuple[tuple[float, float], ...]:
        """Per follower (σ_p, σ_θ) from the leader's EKF covariance at its last update:
        σ_p = √((P_xx + P_yy)/2) cm, σ_θ = √P_θθ rad (PolicyInput.pose_sd)."""
        return tuple(
            [
                (math.sqrt(max(0.5 * (p[0] + p[4]), 0.0)), math.sqrt(max(p[8], 0.0)))
                for p in self.world.covariances()
            ]
        )

    def _ahead(self) -> tuple[tuple[float, float], ...]:
        """The leader's next path commands, one lap ahead: (distance to its start in cm, its
        curvature in 1/cm), nearest first (PolicyInput.ahead)."""
        starts, kappas = self._path  # type: ignore[misc]
        lap = starts[-1]
        u = self.world.leader.s % lap
        k = self.cfg.path.index(self.world.leader.s)
        n = len(kappas)
        out = []
        base = starts[k + 1] - u
        for j in range(1, n + 1):
            kk = (k + j) % n
            out.append((base, kappas[kk]))
            base += starts[kk + 1] - starts[kk]
        return tuple(out)

    def _predicted(self, d: _Decision, v: float) -> Any:
        """Decision ``d``'s bounds (rows) with the leader at speed ``v`` (the ``_pred``
        columns): the rows it computed when ``v`` is one of its speeds, else its predictor
        re-evaluated on its estimates."""
        for speed, rows in d.known:
            if speed == v:
                return rows
        ro = d.kw.get("rollout")
        if ro is not None:  # the commands predictor: its rows are the rollout's (bound_rows_at)
            return ro.rows(v)
        return predicted_rows(d.fols, v, thresholds=self.thr, predictor=self.predictor, **d.kw)

    # -- the leader's speed, as the world has it ---------------------------------------
    # The only two places that read it: with leader dynamics (speed ramps toward a target)
    def _v_actual(self) -> float:
        """The leader's actual speed now (cm/s)."""
        return self.world.leader_speed

    def _v_target(self) -> float:
        """The leader's target speed, the last decision's (cm/s); the leader ramps toward it
        within its accel_max / decel_max."""
        return self.world.leader_target_speed

    # -- hooks -----------------------------------------------------------------------
    def _period(self) -> float:
        return self.dec.w

    def _on_release(self, job: Job) -> None:
        world = self.world
        world.advance(self.env._now)  # (SimPy's clock: the CPU moves it the same way)
        ld = world.leader
        d = self.dec
        i = job.index
        # (positional, in WindowRecord's field order: a call with keywords costs more; the
        # segment's kind and curvature as the leader's path and arc length, which the table
        # reads: `rtsim.coupling.recorder.WindowRecord.segment`)
        rec = WindowRecord(
            i,
            job.release,
            job.period,
            self.w_sch,
            d.msb_min,
            d.binding,
            self.v_ld,
            ld.speed,  # (_v_actual)
            ld.target_speed,  # (_v_target)
            d.method,
            d.feasible,
            ld.path,  # type: ignore[arg-type]  # (its segment at ld.s: read with the table)
            ld.s,
            d.est,
        )
        rec.radio_ms = self._delta_t  # (a drawn round trip replaces it)
        rec.decision = d  # (until `_close` has read it)
        self._open[i] = rec
        self._records.append(rec)
        if not i % self._chunk:  # (the recorder's hand-over, at most once a chunk)
            self.rec.settle()

    def _on_scan(self, job: Job, seg: Segment) -> None:
        now = self.env._now
        world = self.world
        rec = self._open[job.index]
        if self._last_scanned is None:  # (before the first scan: the truth log's samples
            # made in the scan's call where the world makes them, `PhysicalLog.fuse`)
            self._phys_rows = self.phys.fuse(world)
            if self._phys_rows is not None:  # (the fused scan's float rows, `_on_scan`)
                self._scan_T = world.scan_array
        scan = world.scan_estimate(now)  # (scan, then estimate)
        # the scan's fields as its lists, read once (not a property call each: `Scan.fields`)
        raw = scan.fields()
        rec.scan_t = now
        # (the scan's lists are its own, made for it and never changed: the record keeps
        # them as they are, no copy; a fix error or neighbour list of None is the table's
        # inf or False for every follower)
        voted = raw["voted"]
        if voted is None:
            voted = raw["points"]
        rec.voted = voted
        points = rec.points = sum(voted)  # (scan.hough_points, scan.total_points)
        searched = sum(raw["searched"])  # (scan.n_searched)
        # (hough_time on the counts just made: each counted once; `_hough_of`, by its counts)
        key = (len(voted), raw["cells"], points, searched)
        got = self._hough_memo.get(key)
        if got is None:
            got = self._hough_of(key)
        self._hough_ms = rec.hough_ms = got[0]
        rec.assumption_broken = got[1]
        lost = raw["lost"]
        if True in lost:  # (else tracks_lost, searches, ... keep their 0)
            rec.lost = lost
            rec.tracks_lost = sum(lost)  # (scan.n_lost)
            rec.lost_by_cause = tuple(scan.lost_by_cause().values())
            rec.searches = searched
            rec.reacquisitions = scan.n_reacquired
        else:  # (none lost: the run's one tuple of n False, not the scan's list kept)
            rec.lost = self._falses
        rec.fix_error = raw["fix_error"]
        rec.neighbour = raw["neighbour"]
        lp = rec.leader = scan.leader_pose
        # the followers' truth now (the scan has just advanced every follower to now;
        # copies, the poses zipped when read) and the truth log's samples
        put = self._phys_rows
        if put is not None:  # (both as the scan's call made them: its rows)
            # (a copy of the scan's float rows: this record's truth and the previous one's
            # changes read from one array, no lists kept: `StateRows`, `ScanChanges`)
            rows = self._scan_T.copy()
            rec.truth = StateRows(lp, rows, TRUTH_ROW)
            T: Any = world.scan_rows  # (the same rows as lists)
            near = rec.near = put(T)
        else:
            fol = world.followers
            x, y, th, v = fol.truth()
            rec.truth = StateRows(lp, zip(x, y, th), v)  # noqa: B905
            near = rec.near = self._phys_add(lp, *fol.xy)
            rows = None
        if self._last_scanned is not None:
            self._close(scan, near, raw, rows)
        self._last_scanned = rec
        self._v_max = world.leader.speed  # (_v_actual)

    def _hough_of(self, key: tuple[int, Any, int, int]) -> tuple[float, bool]:
        """A scan's Hough time (`counted_time`) from its counts ``key`` (followers, cells,
        points, searches) and whether it broke Eq 1's assumption (more points than it
        assumes, or more time without the searches), kept for the next scan with the same
        counts (a few hundred kinds in a run; cleared when they pass `HOUGH_MEMO`)."""
        n, cells, points, searched = key
        search_ms = self._search_ms
        hough_ms = counted_time(n, cells, points, searched, *self._hough_args, search_ms)
        broken = (
            points > self._points_assumed
            or hough_ms - searched * search_ms > self._hough_assumed + 1e-9
        )
        memo = self._hough_memo
        if len(memo) >= HOUGH_MEMO:
            memo.clear()
        got = memo[key] = (hough_ms, broken)
        return got

    def _close(
        self, scan: Any, near: Sequence[float] = (), raw: Any = None, rows: Any = None
    ) -> None:
        """Close the previous window's observation interval with ``scan``'s violations (and
        ``near``, each follower's closest approach at it; ``raw``: the scan's `Scan.fields`
        when the caller has them; ``rows``: a copy of the fused scan's float rows, whose
        changes the record keeps, `ScanChanges`)."""
        last = self._last_scanned
        if last is None:
            return
        if raw is None:
            raw = scan.fields()
        # (the scan's mappings are its own, made for it and never changed: kept, no copy)
        last.viol = raw["violations"]
        if rows is None:
            last.changes = raw["changes"]
        else:  # (`ScanChanges(rows)` without its __init__'s call)
            ch = last.changes = _BARE(ScanChanges)
            ch.rows = rows
        # the bounds the window's decision predicts at the highest speed the leader had in
        # the interval the changes span (the world has advanced to the scan)
        v = self.world.leader.speed  # (_v_actual)
        v_max = last.v_leader_max = v if v > self._v_max else self._v_max  # (max)
        d = last.decision
        last.decision = None  # (the record keeps no decision: its rollout is large)
        ro = d.kw.get("rollout")
        near_pred = None
        for speed, rows in d.known:  # (`_predicted`'s rows it computed, inline)
            if speed == v_max:
                last.pred = rows
                break
        else:
            if ro is not None:  # (`_predicted`'s rollout: its changes read once for the
                # bounds and the closest approaches)
                last.pred, near_pred = ro.rows_closest(v_max)
            else:
                last.pred = self._predicted(d, v_max)
        # contact: the truth over the window's two scans against 2·r_F + clearance, and the
        # decision's prediction (its rollout's at the same speed, else its estimates)
        if near and last.near:
            # (min(a, b) is a unless b < a, NaN included; the break x < d_c. One loop:
            # map(min, ...) parses its arguments at every call and a comprehension is a
            # function call, ≈ 1.7x the instructions at n = 2)
            d_c = self._contact_cm
            near_true: list[float] = []
            broke = False
            for a, b in zip(last.near, near):  # noqa: B905
                x = b if b < a else a
                near_true.append(x)
                if x < d_c:
                    broke = True
            last.near_true = near_true  # (the list as it is: made for the record)
            # (no break, the rule: the run's one tuple of n False, no list a record)
            last.viol_contact = [x < d_c for x in near_true] if broke else self._falses
        # (the rollout's closest approaches: a list made for the call, kept as it is)
        if near_pred is None:
            near_pred = ro.closest(v_max) if ro is not None else d.near
        last.near_pred = near_pred

    def violation_ratios(
        self,
        tolerance: float = VIOLATION_TOLERANCE,
        complete: list[WindowRecord] | None = None,
        changes: np.ndarray | None = None,
    ) -> tuple[dict[str, float], dict[str, int]]:
        """Per bound kind over the kept windows: the largest observed change / its threshold,
        and the (window, follower) pairs whose change exceeds the threshold by more than
        ``tolerance`` (a violation count that leaves out overshoots of a few per cent).
        ``complete``: the kept records that are complete, when the caller has them, and
        ``changes`` their `changes_array` (every one of them closed, `_tables`)."""
        if self._folded and tolerance != VIOLATION_TOLERANCE:
            raise ValueError("records were handed over: only the default tolerance is known")
        recs = self.rec.records if complete is None else complete
        left = self._fold(recs, tolerance, None if complete is None else changes)
        ratios: dict[str, float] = {}
        beyond: dict[str, int] = {}
        for kind, _, _ in self._limits:
            parts = [p[kind] for p in (self._folded, left) if kind in p]
            # np.max: a NaN propagates as in one array over all records
            ratios[kind] = float(np.max([m for m, _ in parts])) if parts else 0.0
            beyond[kind] = sum(c for _, c in parts)
        return ratios, beyond

    def _fold(
        self,
        records: list[WindowRecord],
        tolerance: float = VIOLATION_TOLERANCE,
        ch: np.ndarray | None = None,
    ) -> dict[str, tuple[float, int]]:
        """Per bound kind, (largest change / threshold, changes beyond ``tolerance``) over the
        complete ``records`` (none: an empty dict); ``ch``: their changes (`changes_array`
        of those records) when the caller has them."""
        out: dict[str, tuple[float, int]] = {}
        if ch is None:
            recs = _closed(records)
            if not recs:
                return out
            # every record's changes in CHANGE_KEYS order, one (records, kinds, n) array
            ch = changes_array(recs, self.n)
        elif not len(ch):
            return out
        for kind, key, lim in self._limits:
            ratio = ch[:, CHANGE_KEYS.index(key), :] / lim
            out[kind] = (float(ratio.max()), int((ratio > 1.0 + tolerance).sum()))
        return out

    def hand_over(self, records: list[WindowRecord], sink: Any) -> None:
        """The recorder's sink: fold the records' changes, then write their rows."""
        recs = _closed(records)
        # the changes as one array once, for the fold and (every record closed: the
        # recorder hands over no other) the rows' _true columns
        ch = changes_array(recs, self.n) if recs else None
        for kind, (m, c) in self._fold(recs, VIOLATION_TOLERANCE, ch).items():
            m0, c0 = self._folded.get(kind, (m, 0))
            self._folded[kind] = (float(np.max([m0, m])), c0 + c)
        if hasattr(sink, "write_columns"):  # a ChunkWriter: no DataFrame for the CSV
            same = ch if len(recs) == len(records) else None
            sink.write_columns(records_columns(records, self.n, self.rec.limits, changes=same))
        else:
            sink.write(records_frame(records, self.n, self.rec.limits))

    def _hough_exec(self, job: Job, seg: Segment, rng: np.random.Generator) -> float:
        return self._hough_ms

    def _radio_exec(self, job: Job, seg: Segment, rng: np.random.Generator) -> float:
        """The window's radio round trip: uniform on [radio.min_ms, delta_t] (its maximum,
        what the analyses use), drawn from the link's own generator."""
        lo, span = self._radio_span  # (min_ms and delta_t − min_ms: `_hook_window`)
        dt = lo + span * self._uniform()  # type: ignore[misc]
        rec = self._open.get(job.index)
        if rec is not None:
            rec.radio_ms = dt
        return dt

    def _on_send(self, job: Job, seg: Segment) -> None:
        env, opened, send, offsets, n, loss = self._send_with  # (bound once: `__init__`)
        now = env._now
        i: int = seg.follower  # type: ignore[assignment]
        rec = opened[job.index]
        if loss and self._uniform() < loss:  # type: ignore[misc]
            # lost: the follower keeps its previous command; the leader, missing the reply,
            # keeps it in its estimate too
            rec.radio_losses += 1
        elif send is not None:  # (World.command's, one call: World.sender)
            send(i - 1, now)
        else:
            self.world.command(i, now)
        scan_t = rec.scan_t
        if scan_t == scan_t and 1 <= i <= n:  # (NaN before the scan)
            offsets[i - 1] = now - scan_t

    def _decide(self, job: Job) -> None:
        """The decision on the estimates now; it governs the next window (released at
        job.release + job.period) and sets the leader's target at once."""
        now = self.env._now
        ld = self.world.leader
        self.dec = self._estimates(now, job.release + job.period)  # advances the world
        v = ld.speed  # (_v_actual; max(a, b) is b only when b > a)
        if v > self._v_max:
            self._v_max = v
        ld.set_speed(self.dec.v_leader)  # (World.set_leader_speed now)
        v = ld.speed
        if v > self._v_max:
            self._v_max = v

    def _on_send_start(self, job: Job, seg: Segment) -> None:
        if seg.follower == 1:  # adjust.decide = "before-send": before the first send
            self._decide(job)

    def _on_done(self, job: Job) -> None:
        now = self.env._now
        self._open.pop(job.index).finish = now
        world = self.world
        if self._decide_at_end:
            self._decide(job)
        else:
            world.advance(now)
            v = world.leader.speed  # (_v_actual)
            if v > self._v_max:  # (max)
                self._v_max = v
        if self.lap_ms is None:
            d = world.leader.s - self._s0  # (`_lap_check`'s common case inline)
            if d < self._lap_cm:
                self._lap_prev = (now, d)
            else:
                self._lap_check(now)
        if (
            self._stop_s is not None
            and now >= self._stop_ms
            and world.leader.s - self._s0 >= self._stop_s
            and not self.stop.triggered
        ):
            self.stop.succeed()

    def _lap_check(self, now: float) -> None:
        """Record the leader's first lap completion (``lap_ms``): linear interpolation of
        its distance driven between the two window completions around it."""
        d = self.world.leader.s - self._s0
        if d < self._lap_cm:
            self._lap_prev = (now, d)
            return
        t0, d0 = self._lap_prev
        self.lap_ms = t0 + (now - t0) * (self._lap_cm - d0) / (d - d0) if d > d0 else now

    def summary_extra(
        self,
        res: Any,
        horizon_ms: float,
        stop_s: float | None,
        complete: list[WindowRecord] | None = None,
        changes: np.ndarray | None = None,
    ) -> dict[str, Any]:
        """summary.json's keys beyond the windows' (`summarize`): the lap, the policy and
        models, the violation ratios, the oracle's lap and the physical log; ``res``: the
        CPU's result; ``complete``: the kept records that are complete, if the caller has
        them, and ``changes`` their `changes_array` (`violation_ratios`)."""
        cfg, world = self._given, self.world  # (the scenario's world, before a settled start)
        extra: dict[str, Any] = {
            "laps": (world.leader.s - self._s0) / cfg.path.lap_length,
            "max_backlog": int(res.tasks[self.wname].max_backlog),
            "v_leader_desired": self.v_ld,
            "n": self.n,
            "policy": self.mode,
            "lap_time_s": None if self.lap_ms is None else self.lap_ms / 1000.0,
            "predictor": _name(self.predictor),
            "formation_model": formation_model(cfg),
            "localization_model": cfg.localization.model,
            "leader_accel_max": cfg.leader_accel_max,
            "leader_decel_max": cfg.leader_decel_max,
            "leader_start_speed": self.cfg.start_speed or cfg.leader_speed,
        }
        if self.infeasible_note is not None:
            extra["infeasible_note"] = self.infeasible_note
        if self.thr.localization == "predicted":
            extra["assumptions"] = {"predicted_heading_sd": self._heading_assumption()}
        if self.lap_ms is None:  # why there is no lap time
            extra["lap_time_note"] = (
                f"the leader did not complete its lap within the cap of "
                f"{run_duration.LAP_CAP_FACTOR:g} lap times at V_Ld ({horizon_ms / 1000.0:.6g} s)"
                if stop_s is not None
                else f"the run's duration ({horizon_ms / 1000.0:g} s) ended before the leader "
                f"completed its lap"
            )
        extra["max_violation_ratio"], extra["violations_beyond_5pct"] = self.violation_ratios(
            complete=complete, changes=changes
        )
        # the fastest lap that keeps every bound, offline (rtsim.control.oracle; cached)
        oracle = lap_oracle(cfg, self.w_sch)
        extra["lap_oracle_s"] = oracle
        extra["lap_over_oracle"] = (
            None if oracle is None or self.lap_ms is None else self.lap_ms / 1000.0 / oracle
        )
        world.followers.advance_all(world.t_ms, cfg.step_ms)
        extra.update(self.phys.summary(world.leader.s - self._s0, list(world.followers.odometer)))
        return extra

    # -- running ---------------------------------------------------------------------
    def watch(self, progress: Any) -> None:
        """Report progress (`rtsim.sim.progress.start_ticker`): the share of the
        duration; for a run to the end of the lap, the smaller of the shares of the lap
        driven and of the scenario's duration, ticking at every percent of a lap at V_Ld."""
        if self._stop_s is None:
            horizon = self.horizon_ms
            start_ticker(self.env, horizon / TICKS, lambda now: now / horizon, progress)
            return
        stop_s, stop_ms, s0 = self._stop_s, self._stop_ms, self._s0
        lap_ms = max(1000.0 * stop_s / max(self.v_ld, 1e-9), 1.0)

        def share(now: float) -> float:
            driven = (self.world.leader.s - s0) / stop_s if stop_s > 0 else 1.0
            return min(driven, now / stop_ms if stop_ms > 0 else 1.0)

        start_ticker(self.env, max(lap_ms, stop_ms) / TICKS, share, progress)

    def run(self) -> None:
        proc = self.cpu.start(self.horizon_ms)
        # The cyclic collector is off while the loop runs: the loop makes no reference
        # cycles (tests/coupling/test_no_cycles.py), so its passes only traversed the
        # records the run keeps, twice each (≈ 2 % of a Test 2 lap). Afterwards what the
        # run allocated joins the oldest generation with the objects alive before it
        # (frozen, then unfrozen), as a full collection would have left them, unless the
        # caller had frozen objects of its own. No effect on results.
        enabled, frozen = gc.isenabled(), gc.get_freeze_count() == 0
        gc.disable()
        try:
            if self._stop_s is None:
                self.env.run(until=self.horizon_ms)
            else:
                self.env.run(until=self.stop | proc)
        finally:
            if frozen:
                gc.freeze()
                gc.unfreeze()
            if enabled:
                gc.enable()
        last = self._last_scanned
        if last is not None and last.viol is None:  # close the last observation interval
            scan = self.world.scan(max(self.env.now, self.world.t_ms))
            fol, (xl, yl, _) = self.world.followers, scan.leader_pose
            # (with the fused scan, its changes kept as every other record's: a copy of the
            # scan's float rows, so the tables read every record's in one pass)
            rows = None if self._scan_T is None else self._scan_T.copy()
            self._close(scan, closest_each(fol.x, fol.y, xl, yl), None, rows)


class _Complete(list[WindowRecord]):
    """Records known to be complete (`_tables`' pick, which the violation ratios fold
    again): `_closed` reads only their changes, not `WindowRecord.complete` a second time
    (≈ 0.2 ms of a Test 2 lap)."""

    __slots__ = ()


def _closed(records: list[WindowRecord]) -> list[WindowRecord]:
    """The complete ``records`` whose changes are known (those the violation ratios fold)."""
    if type(records) is _Complete:
        if not any(map(is_, map(_CHANGES, records), repeat(None))):  # (a run's: the same)
            return records
        return [r for r in records if r.changes is not None]
    return [r for r in records if r.complete and r.changes is not None]


#: The relative excess of the filters' heading SD over the predicted-centre bound's assumed
#: one that still counts as held (summary.json ``assumptions``): the first scan's estimate
#: starts at P0 and adds one interval's drift (test1: 2.0001° against 2°).
HEADING_SLACK = 0.01


#: The keyword arguments `run_scenario` took under other names, and their names now.
RENAMED_ARGS: dict[str, str] = {"mode": "policy", "duration": "duration_s"}


def _refuse(unknown: Mapping[str, Any]) -> None:
    """A keyword argument `run_scenario` does not take (an old name among them) is a
    TypeError naming the one meant (`rtsim._suggest.did_you_mean`)."""
    for key in unknown:
        names = [p for p in inspect.signature(run_scenario).parameters if p != "unknown"]
        hint = did_you_mean(key, names, renamed=RENAMED_ARGS)
        raise TypeError(f"run_scenario() got an unexpected keyword argument '{key}'{hint}")


#: Rows of windows.csv the summary reads back at a time (a chunk's frame stays small next
#: to a run's table: the post-run peak does not grow with the run's length).
SUMMARY_READ_ROWS = 2_048


def run_scenario(
    scenario: Any,
    *,
    policy: str | None = None,
    seed: int = 0,
    overrides: Mapping[str, Any] | None = None,
    duration_s: float | None = None,
    record_jobs: bool = True,
    exec_model: ExecSpec = "wcet",
    text: str | None = None,
    record_trace: bool = False,
    window_sink: Any = None,
    job_sink: Any = None,
    trace_sink: Any = None,
    allow_code: bool | None = None,
    force: bool = False,
    windows: bool = True,
    progress: Any = None,
    scratch_dir: str | os.PathLike[str] | None = None,
    **unknown: Any,
) -> ScenarioResult:
    """Run one scenario: the leader's schedule and the robots' world in one simulation.

    Parameters
    ----------
    scenario : str, path, Scenario or ScenarioInputs
        A scenario file, a shipped one by name (``"test2"``), a loaded
        [`Scenario`][rtsim.config.scenario.Scenario], or
        [`ScenarioInputs`][rtsim.coupling.scenario_run.ScenarioInputs] prepared once.
    duration_s : float, optional
        Simulated seconds, exact. None: the scenario's ``duration``, else to the end of the
        lap (``until = "lap"``, `rtsim.coupling.duration`).
    seed : int, default 0
        One seed for the world's noise and the CPU's execution-time draws.
    record_jobs : bool, default True
        Keep the job table (``result.jobs``).
    exec_model : str, default "wcet"
        Execution times of the fixed segments: ``"wcet"`` or ``"uniform"`` in [bcet, wcet].
    text : str, optional
        The scenario file's text, for the manifest (read from the path when one is given).
    record_trace : bool, default False
        Keep the execution trace (``result.trace``, for trace export).
    overrides : mapping, optional
        Dotted keys of the scenario file and their values, as in a sweep
        (``{"leader.speed": 20, "sensing.r_H": 30}``; cm, cm/s as in the file); with a
        path or a shipped name only.
    window_sink, job_sink, trace_sink : optional
        `rtsim.io.columns.ChunkWriter` (or a callable) given the window rows, job
        records, trace rows in chunks during the run: memory stays flat on long runs, and
        the matching result table is None.
    policy : str, optional
        The adjustment policy, overriding the file's ``[adjust] policy`` (default ``plan``,
        the recommended model; ``adjust`` is the paper's): a registered name or
        ``"package.module:Name"``.
    allow_code : bool, optional
        The scenario file (or its task set) may name code, ``module:Name``
        (`rtsim.registry`); a ``policy`` of that form given here is always allowed.
    force : bool, default False
        Run above the work limits (2e6 windows, 2e8 world steps × followers, the
        transaction analysis of ``[adjust] lower_bound = "w_txn"``), as ``--force``.
    windows : bool, default True
        False leaves ``result.windows`` None (the summary is computed either way).
    progress : callable, optional
        ``progress(share, t_ms)``, called at every percent of the run with the share done
        (0..1) and the simulated ms; the results do not change.
    scratch_dir : path, optional
        A directory for the run's scratch files (``.rtsim-spool-*``: the samples whose
        exact percentiles summary.json reports), removed before returning: memory stays
        flat at any length and follower count. None keeps them in memory (8 bytes per
        sample); the results are the same.

    Returns
    -------
    ScenarioResult
        ``summary`` (summary.json), ``windows`` (one row per window), ``followers`` (one
        row per window and follower), ``jobs``, ``trace``, ``timing`` (wall s).

    Raises
    ------
    InputError
        A bad scenario, option or override, in one line per problem.
    """
    t0 = time.perf_counter()
    _refuse(unknown)
    if policy is not None:
        policy_class(policy, "policy")
    if not is_int(seed) or seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed!r}")
    check_seed(seed, "run_scenario: seed")
    inp = scenario_inputs(scenario, text, overrides, allow_code)
    horizon_ms, stop_s, stop_ms = _length(inp, duration_s, force)
    run = _Coupling(
        inp,
        policy,
        int(seed),
        exec_model,
        record_jobs,
        horizon_ms,
        stop_s,
        stop_ms,
        record_trace,
        job_sink,
        trace_sink,
        force,
    )
    if window_sink is not None:
        run.rec.sink = lambda recs: run.hand_over(recs, window_sink)
        if window_sink.empty is None:
            window_sink.empty = records_frame([], run.n, run.rec.limits)
    if progress is not None:
        run.watch(progress)
    scratch = None
    if scratch_dir is not None:
        scratch = Path(scratch_dir) / f".rtsim-spool-{secrets.token_hex(4)}"
        # (a write error names summary.json, the output the samples are for)
        run.phys.spill_to(f"{scratch}-physical", label=Path(scratch_dir) / "summary.json")
    try:
        t1, c1 = time.perf_counter(), time.process_time()
        run.run()
        if progress is not None:
            progress(1.0, float(run.env.now))
        t2, c2 = time.perf_counter(), time.process_time()
        df, table, complete, changes = _tables(run, window_sink, windows)
        res = run.cpu.result()
        summary = summarize(
            table,
            mode=run.mode,
            w_sch=run.w_sch,
            duration_s=run.env.now / 1000.0,
            seed=int(seed),
            scenario=inp.name,
            n=run.n,
            extra=run.summary_extra(res, horizon_ms, stop_s, complete, changes),
            scratch=None if scratch is None else f"{scratch}-fixes",
        )
    finally:
        run.phys.close()
        _drop(run)
    t3 = time.perf_counter()
    timing = {
        "setup_s": t1 - t0,
        "simulation_s": t2 - t1,
        "simulation_cpu_s": c2 - c1,
        "tables_s": t3 - t2,
    }
    frame: Any = df if window_sink is None else None  # (`_Records`: the frame when read)
    return ScenarioResult(frame, res.jobs, summary, timing, inp, res.trace)


def _drop(run: _Coupling) -> None:
    """The run's state and its world's dropped when the run returns, not left to a full
    collection: the CPU's hooks are the run's bound methods and the world keeps bound methods
    of itself (two cycles), and a sweep's points piled up (docs/performance.md, Memory)."""
    world = run.__dict__.get("world")
    run.__dict__.clear()
    if world is not None:
        world.__dict__.clear()


def _length(
    inp: ScenarioInputs, duration_s: float | None, force: bool
) -> tuple[float, float | None, float]:
    """The run's (horizon ms, stop arc length cm or None, earliest stop ms) for
    ``duration_s`` (`rtsim.coupling.duration.run_length`), within the work limits."""
    cfg = inp.world
    if duration_s is not None:
        if not is_real(duration_s) or not (0 < duration_s < math.inf):
            raise InputError(f"duration must be a positive number of seconds, got {duration_s!r}")
        check("option: --duration", duration_s, "run_scenario: duration_s")
    length = run_length(cfg, duration_s, inp.duration_s)
    win = inp.taskset.window
    check_coupled(
        length.horizon_ms,
        win.g() if win is not None else 0.0,
        cfg.step_ms,
        cfg.n,
        f"run_scenario: duration {length.horizon_ms / 1000.0:g} s",
        force=force,
    )
    return length.horizon_ms, length.stop_s, length.stop_ms


def _tables(
    run: _Coupling, window_sink: Any, windows: bool
) -> tuple[_Records | None, Any, list[WindowRecord] | None, np.ndarray | None]:
    """The windows' records for the result's frame (None: streamed or not asked for; the
    frame is built when first read, `_Frame`), the columns the summary reads (in memory,
    without the followers' state and bounds, or read back from the sink in chunks: memory
    stays flat at any length and follower count), the complete records kept (None:
    streamed) and their changes (`changes_array`, for the violation ratios; None: streamed
    or none). The violation flags are those the world's scans made of the same changes
    (`World.violations_of`): one array, not a pass over every record's flag lists
    (≈ 0.3 ms of a Test 2 lap; tests/coupling/test_summary_arrays.py)."""
    if window_sink is None:
        recs = _Complete([r for r in run.rec.records if r.complete])
        n, limits = run.n, run.rec.limits
        closed = _closed(recs)
        changes = changes_array(closed, n) if closed else None
        flags = None
        if changes is not None and len(closed) == len(recs):
            flags = run.world.violations_of(changes)
        table = records_columns(recs, n, limits, state=False, summary=True, violations=flags)
        frame = _Records(recs, n, limits) if windows else None
        return frame, table, recs, changes
    run.rec.flush()
    window_sink.close()
    return None, window_sink.iter_read(summary_columns(run.n), SUMMARY_READ_ROWS), None, None
