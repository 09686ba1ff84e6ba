"""The command-aware rollout: the leader predicts the followers from the commands it will
send (docs/planning.md, "The rollout").

For a candidate target speed it plays itself (the world's `Leader`, its speed ramping) and
every follower (the command it holds, then at each send the command the law computes, on a
clone of the law's state, integrated as the world integrates, without actuation noise)
forward, and reads at the scans the changes the world checks, and each follower's closest
approach (`rtsim.world.contact`). A change c against threshold L over a window w gives the
bound MSB = L·w / c (ms; ∞ when c = 0). Used by the ``commands`` predictor
(`rtsim.control.adjust.adjust`) and by policies through `PolicyInput.rollout`
(`rtsim.control.policy`): ``ctx.rollout.rows(v)``, ``ctx.rollout.changes(v, windows)``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import MISSING, dataclass, field, fields
from typing import Any

import numpy as np

from rtsim.analysis.kinematics import Thresholds
from rtsim.control.adjust import ROLLOUT_GRID, ROLLOUT_TOL
from rtsim.control.compiled_rollout import RUNS as COMPILED_RUNS
from rtsim.control.compiled_rollout import (
    CompiledRollout,
    _Rest,
    as_changes,
    compiled_rollout,
    compiles,
)
from rtsim.control.predict import min_bound_rows
from rtsim.world.contact import closest_over, closest_to, lowest_contact
from rtsim.world.follower import FollowerGroup, FollowerParams, control_targets, lpsi_command
from rtsim.world.ftl import TraceFollower
from rtsim.world.leader import Leader
from rtsim.world.motionmodels import motion_model
from rtsim.world.path import LeaderPath

__all__ = [
    "Rollout",
    "RolloutState",
    "Changes",
    "decided_state",
    "rollout_state",
    "rollouts_run",
    "rows_state",
]

#: Per follower, the four predicted changes of one window: (displacement in the leader frame
#: cm, |Δρ| cm, distance driven cm, |Δβ| rad), in BOUND_KINDS order, then its closest
#: approach to any other robot over the window (cm, `rtsim.world.contact`).
Changes = tuple[float, float, float, float, float]

_TWO_PI = 2.0 * math.pi

#: rollouts the Python rollout has run in this process (`rollouts_run`)
_PYTHON_RUNS = [0]


def rollouts_run() -> int:
    """How many rollouts this process has run so far, compiled and Python (each one a leader
    target played over its windows; a memoised one is not run again): a benchmark reads it
    before and after a run for its rollouts per lap (one integer add per decision)."""
    return _PYTHON_RUNS[0] + COMPILED_RUNS[0]


@dataclass(frozen=True)
class RolloutState:
    """What the leader knows at its decision (ms, cm, cm/s, rad).

    path, law: its path and its follow-the-leader law (cloned per rollout, so the caller's
    is never changed), or None for l-ψ followers (then their slots ``rho_d``, ``beta_d`` and
    [`lpsi_command`][rtsim.world.follower.lpsi_command], as the world commands them); params: the
    followers' limits (max speed, acceleration, turn rate; the noise fields are ignored);
    step_ms: the integration step of a ramping wheel speed;
    t_now: the decision's time; leader_s, leader_speed: its arc length and actual speed;
    v_ld: its desired speed; accel_max, decel_max: its ramp limits; poses, speeds, held:
    per follower the estimate (x, y, heading), its expected speed and the command (v, ω) it
    holds; pending: per follower the sends still to come in the current window (ms); next_scan:
    the scan that opens the window the decision governs; send_offsets: per follower, its send
    after a window's scan; thresholds, rho_d: the bounds' thresholds; w_sch: the window
    length of windows after the first; group: the class that integrates the followers (the
    world's own, so that a compiled world rolls out compiled: the same numbers); contact_cm:
    d_c = 2·r_F + clearance, the centre distance the contact bound keeps.
    """

    path: LeaderPath
    law: TraceFollower | None
    params: FollowerParams
    step_ms: float
    t_now: float
    leader_s: float
    leader_speed: float
    v_ld: float
    accel_max: float
    decel_max: float
    poses: tuple[tuple[float, float, float], ...]
    speeds: tuple[float, ...]
    held: tuple[tuple[float, float], ...]
    pending: tuple[tuple[float, ...], ...]
    next_scan: float
    send_offsets: tuple[float, ...]
    thresholds: Thresholds
    rho_d: tuple[float, ...]
    w_sch: float
    group: type[FollowerGroup] = FollowerGroup
    beta_d: tuple[float, ...] = ()
    #: d_c = 2·r_F + clearance (cm), the contact bound's distance (`rtsim.world.contact`;
    #: 0: none known, a policy cannot keep it)
    contact_cm: float = 0.0
    #: per follower, the turn rate it is expected to have: the state of the motion model
    #: ``params.motion_model`` (`rtsim.world.motionmodels`), by which the followers and the
    #: leader move (empty: the held commands' turn rates, as the unicycle turns at once)
    turns: tuple[float, ...] = field(default=(), kw_only=True)


_STATE_FIELDS = [f.name for f in fields(RolloutState) if not f.kw_only]
_STATE_DEFAULTS = {f.name: f.default for f in fields(RolloutState) if f.default is not MISSING}
_STATE_REQUIRED = len([n for n in _STATE_FIELDS if n not in _STATE_DEFAULTS])


def _made(cls: type[Rollout], lazy: tuple[Any, ...], compiled: Any) -> Rollout:
    """A ``cls`` whose state is made when read (`Rollout.decided`, `Rollout.planned`):
    ``lazy`` the base and `rows_state`'s values, ``compiled`` its `CompiledRollout`."""
    ro: Rollout = object.__new__(cls)
    ro._lazy = lazy
    ro.base = lazy[0]
    ro._count = 0
    ro._memo = {}
    ro._raw_d = {}
    ro._compiled = compiled
    return ro


def rollout_state(*values: Any, turns: tuple[float, ...] = ()) -> RolloutState:
    """``RolloutState(*values, turns=turns)``, the same object built without the frozen
    dataclass's ``object.__setattr__`` per field (23 of them: ≈ 6 µs of every decision):
    the fields written into its ``__dict__`` at once, the defaults of those not given."""
    if not _STATE_REQUIRED <= len(values) <= len(_STATE_FIELDS):
        raise TypeError(f"rollout_state takes {len(_STATE_FIELDS)} fields, got {len(values)}")
    state = object.__new__(RolloutState)
    d = state.__dict__
    d.update(_STATE_DEFAULTS)
    d.update(zip(_STATE_FIELDS, values, strict=False))  # (the defaults stay for the rest)
    d["turns"] = turns
    return state


#: the fields of `RolloutState` a decision sets (`decided_state`); the others stay for a run
DECIDED = (
    "t_now",
    "leader_s",
    "leader_speed",
    "poses",
    "speeds",
    "held",
    "pending",
    "next_scan",
    "send_offsets",
    "turns",
)


def decided_state(base: RolloutState, *values: Any) -> RolloutState:
    """``dataclasses.replace(base, **dict(zip(DECIDED, values)))``: the state of a decision
    from a run's ``base`` (its path, law, limits, thresholds and slots), the same object
    built by copying ``base``'s fields at once (a run's decisions differ only in `DECIDED`)."""
    if len(values) != len(DECIDED):
        raise TypeError(f"decided_state takes the {len(DECIDED)} fields {DECIDED}")
    state = object.__new__(RolloutState)
    d = state.__dict__
    d.update(base.__dict__)
    d.update(zip(DECIDED, values))  # noqa: B905 (lengths checked above)
    return state


def rows_state(
    base: RolloutState,
    t_now: float,
    leader_s: float,
    leader_speed: float,
    rows: Any,
    pending: tuple[tuple[float, ...], ...],
    next_scan: float,
    send_offsets: tuple[float, ...],
    turned: bool,
) -> RolloutState:
    """`decided_state` of ``base`` at a decision that read ``rows``
    (`rtsim.world.world.World.estimate_rows`: per follower x, y, θ, v̂, ω̂, v_c, ω_c; or
    `planned`'s float array of them, read as its lists): the poses, speeds and held commands
    (v_c, ω_c) are theirs, and the turns their ω̂ when ``turned`` (the motion model keeps a
    turn rate: `RolloutState.turns`), else none."""
    if type(rows) is np.ndarray:  # (its floats, as the lists `estimate_rows` gives)
        rows = rows.tolist()
    return decided_state(
        base,
        t_now,
        leader_s,
        leader_speed,
        tuple([(r[0], r[1], r[2]) for r in rows]),
        tuple([r[3] for r in rows]),
        tuple([(r[5], r[6]) for r in rows]),
        pending,
        next_scan,
        send_offsets,
        tuple([r[4] for r in rows]) if turned else (),
    )


class Rollout:
    """Rollouts from one `RolloutState`, memoised per (target, windows).

    ``count``: the rollouts actually run (one per distinct (target, windows)). ``base``: a
    state whose fields other than `DECIDED` are ``state``'s (``state`` itself, or the run's
    base of `decided`, whose rollouts make ``state`` only when it is read): what the
    rollout reads of its state per decision.

    A compiled decision's rollouts (`search`, `plan`) stay as the kernel left them
    (`rtsim.control.compiled_rollout._Kept`): `changes` and `closest` read the key they
    ask for from them, and reading ``count`` or ``_raw`` puts them all in ``_raw``, the
    entries and count the decision would have put there.
    """

    #: (compared by value, as a dataclass: no hash)
    __hash__ = None  # type: ignore[assignment]

    #: the last compiled decision's rollouts not yet put in ``_raw`` (`_settle`), or None
    _kept: Any = None
    #: a rollout of `decided`: its base and the values its ``state`` is made of when read
    _lazy: Any = None

    def __init__(
        self,
        state: RolloutState,
        count: int = 0,
        _memo: dict[tuple[float, tuple[float, ...]], list[list[Changes]]] | None = None,
    ) -> None:
        self.state = state
        self.base = state
        self._count = count
        self._memo = {} if _memo is None else _memo
        self._raw_d: dict[tuple[float, tuple[float, ...]], Any] = {}
        # a law of the world's compiled backend plays whole rollouts in compiled calls
        self._compiled = compiled_rollout(state.law, state)

    def __getattr__(self, name: str) -> Any:
        """``state``, made when first read for a rollout of `decided` (attributes the
        instance has are found before this is asked)."""
        if name == "state":
            lazy = self.__dict__.get("_lazy")
            if lazy is not None:
                state = self.__dict__["state"] = rows_state(*lazy)
                return state
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def __eq__(self, other: object) -> bool:
        if other.__class__ is not self.__class__:
            return NotImplemented
        assert isinstance(other, Rollout)
        return (self.state, self.count, self._memo) == (other.state, other.count, other._memo)

    def __repr__(self) -> str:
        return f"{type(self).__qualname__}(state={self.state!r}, count={self.count!r})"

    @property
    def count(self) -> int:
        """The rollouts actually run (one per distinct (target, windows))."""
        if self._kept is not None:
            self._settle()
        return self._count

    @count.setter
    def count(self, value: int) -> None:
        if self._kept is not None:
            self._settle()
        self._count = value

    @property
    def _raw(self) -> dict[tuple[float, tuple[float, ...]], Any]:
        """The compiled search's rollouts kept for the memo, keyed (target, windows), as
        arrays (or `rtsim.control.compiled_rollout._Rest`) until `changes` asks for one."""
        if self._kept is not None:
            self._settle()
        return self._raw_d

    def _settle(self) -> None:
        """Put the last compiled decision's rollouts in ``_raw`` (and count them)."""
        kept, self._kept = self._kept, None
        self._count += kept.put(self._raw_d, self._memo)

    def _keep(self, kept: Any) -> None:
        """Keep a compiled decision's rollouts (`_Kept`) for the memo, after the last's."""
        if self._kept is not None:
            self._settle()
        self._kept = kept

    @classmethod
    def decided(cls, base: RolloutState) -> Callable[..., Rollout]:
        """``make(t_now, leader_s, leader_speed, rows, pending, next_scan, send_offsets,
        turned)``: the rollout of ``rows_state(base, ...)`` of these, for the decisions of a
        run (a coupled run's), its state made only when read (the compiled rollout packs
        the rows themselves: `CompiledRollout.direct`); ``Rollout(rows_state(base, ...))``
        when the law does not roll out compiled."""
        if not compiles(base.law):

            def plain(*values: Any) -> Rollout:
                return cls(rows_state(base, *values))

            return plain
        comp = CompiledRollout.direct(base.law, base)
        made = _made

        def make(
            t_now: float,
            leader_s: float,
            leader_speed: float,
            rows: Any,
            pending: tuple[tuple[float, ...], ...],
            next_scan: float,
            sends: tuple[float, ...],
            turned: bool,
        ) -> Rollout:
            # (the values written out, twice: no tuple of them unpacked)
            return made(
                cls,
                (base, t_now, leader_s, leader_speed, rows, pending, next_scan, sends, turned),
                comp(t_now, leader_s, leader_speed, rows, pending, next_scan, sends, turned),
            )

        return make

    @classmethod
    def planned(
        cls,
        base: RolloutState,
        turned: bool,
        keep: float,
        need: float,
        cap: float,
        v_floor: float,
        windows: int,
        contact: float,
    ) -> Callable[..., tuple[Rollout, Any, Any]] | None:
        """`decided`'s rollout and its `plan` (V_Ld and w_sch ``base``'s, the other numbers
        these) in one step, for the decisions of a run (``turned``: `decided`'s):
        ``step(carry, t_now, leader_s, leader_speed, pending, next_scan, sends)`` → (the
        rollout, `plan`'s answer, the estimates' rows it read: a float array, per follower
        x, y, θ, v̂, then more), ``carry(t_now, out)`` writing the estimates' rows into the pack's
        rows ``out`` (`rtsim.control.compiled_rollout.CompiledRollout.planner`); None when
        the law does not roll out compiled (the caller makes the rollout and plans)."""
        if not compiles(base.law):
            return None
        w = base.w_sch
        inner = CompiledRollout.planner(
            base.law, base, turned,
            False, keep, need, cap, v_floor, ROLLOUT_GRID, ROLLOUT_TOL, windows, w, contact,
        )  # fmt: skip
        made = _made

        def step(
            carry: Any,
            t_now: float,
            leader_s: float,
            leader_speed: float,
            pending: tuple[tuple[float, ...], ...],
            next_scan: float,
            sends: tuple[float, ...],
        ) -> tuple[Rollout, Any, Any]:
            comp, out, kept, rows = inner(
                carry, t_now, leader_s, leader_speed, pending, next_scan, sends
            )
            ro = made(  # (`decided`'s make, its state made when read)
                cls,
                (base, t_now, leader_s, leader_speed, rows, pending, next_scan, sends, turned),
                comp,
            )
            return ro, ro._planned(out, kept, keep, need, windows, w, contact), rows

        return step

    def changes(self, v: float, windows: Sequence[float]) -> list[list[Changes]]:
        """The predicted changes per window (lengths ``windows``, ms, the first opening at
        ``next_scan``) and per follower, with the leader's target ``v`` from now on."""
        key = (float(v), tuple(map(float, windows)))  # (map: no generator frame)
        out = self._memo.get(key)
        if out is None:
            kept = self._kept
            if kept is not None and not self._raw_d:  # the decision's, read directly
                raw = kept.first(key)
                if raw is not None:  # (`_settle` will not count it again: it is in the memo)
                    self._count += 1
            else:
                if kept is not None:
                    self._settle()
                raw = self._raw_d.pop(key, None) if self._raw_d else None
            if raw is None:
                out = self._memo[key] = self._run(key[0], key[1])
                self._count += 1
            else:  # a rollout of the compiled search, kept as its array until asked for
                out = self._memo[key] = as_changes(raw)
        return out

    def rows(self, v: float, w: float | None = None) -> list[tuple[float, float, float, float]]:
        """Every follower's four bounds (ms, BOUND_KINDS order) in the window of length ``w``
        (default w_sch) that the decision governs, with the leader's target ``v``."""
        w = self.base.w_sch if w is None else float(w)
        return self.bounds(self.changes(v, (w,))[0], w)

    def bounds(
        self, changes: Sequence[Changes], w: float
    ) -> list[tuple[float, float, float, float]]:
        """The bounds L·w / c of one window's ``changes`` (module docstring)."""
        thr = self.base.thresholds
        inf = math.inf
        r_h, t_rho, t_eps, t_beta = thr.r_H, thr.T_rho, thr.T_eps, thr.T_beta
        # the window follows the predicted motion: what is left is the residual's bound
        loc = thr.predicted_ms if thr.localization == "predicted" else None
        out = []
        # (each bound written out, lim · w / c: a generator per follower was ≈ 2x the time)
        rho_ds = self.base.rho_d
        if len(changes) != len(rho_ds):  # (zip's strict=, checked once: its keyword is slow)
            raise ValueError(f"{len(changes)} followers' changes for {len(rho_ds)} followers")
        for c, rho_d in zip(changes, rho_ds):  # noqa: B905
            c0, c1, c2, c3 = c[0], c[1], c[2], c[3]  # (c[4] is the contact's)
            l1, l2 = t_rho * rho_d, t_eps * rho_d
            out.append(
                (
                    (inf if c0 <= 0.0 else r_h * w / c0) if loc is None else loc,
                    inf if c1 <= 0.0 else l1 * w / c1,
                    inf if c2 <= 0.0 else l2 * w / c2,
                    inf if c3 <= 0.0 else t_beta * w / c3,
                )
            )
        return out

    def rows_closest(self, v: float) -> tuple[list[tuple[float, float, float, float]], list[float]]:
        """`rows` and `closest` at ``v`` in the window of length w_sch, from one read of the
        window's changes (the rollout's memo, or one rollout made now)."""
        w = self.base.w_sch
        changes = self.changes(v, (w,))[0]
        return self.bounds(changes, w), [c[4] for c in changes]

    def closest(self, v: float, w: float | None = None) -> list[float]:
        """Every follower's predicted closest approach to any other robot (cm) in the window
        of length ``w`` (default w_sch) that the decision governs, with the leader's target
        ``v``."""
        w = self.base.w_sch if w is None else float(w)
        key = (float(v), (w,))
        raw = None
        if key not in self._memo:
            kept = self._kept
            if kept is not None and not self._raw_d:  # the decision's rollouts, read as is
                r, how = kept.find(key)
                if r >= 0 and how != 2:  # (an array: its first window, whole or alone)
                    return kept.near(r)  # type: ignore[no-any-return]
                if r < 0:  # not the decision's: rolled out now (as `changes` would)
                    out = self._memo[key] = self._run(key[0], key[1])
                    self._count += 1
                    return [c[4] for c in out[0]]
            elif self._raw:
                raw = self._raw_d.get(key)
        if raw is not None and not isinstance(raw, _Rest):  # the search's array, read as is
            return raw[0, :, 4].tolist()  # type: ignore[no-any-return]
        return [c[4] for c in self.changes(v, (w,))[0]]

    @staticmethod
    def contact(windows: Sequence[Sequence[Changes]], w: float, d_c: float, m: float) -> float:
        """``m`` lowered to the smallest contact bound w·d / d_c of every follower in
        ``windows`` (each window's changes; ``d_c`` 0: ``m`` unchanged): the plan's fifth
        bound (`rtsim.world.contact.lowest_contact`, the compiled search's code)."""
        return lowest_contact(windows, w, d_c, m)  # type: ignore[no-any-return]

    def search(
        self, v_ld: float, keep: float, need: float, v_floor: float, windows: int, w: float
    ) -> tuple[float, str, float] | None:
        """`search_rollout` over keep · m(V), m(V) the smallest
        bound of every follower in ``windows`` windows of ``w`` ms (plan's; adjust with the
        ``commands`` predictor asks for one window of w_sch, its rows), in one
        compiled call; None when this rollout is not compiled (the caller searches in
        Python, with the same result; also when ``v_ld``, the top of the search, is not the
        state's). The rollouts it ran join the memo, as the Python search's do (a later
        `changes` of one of its speeds is that rollout)."""
        if self._compiled is None or v_ld != self.base.v_ld:
            return None
        out, kept = self._compiled.decide(
            True, keep, need, 0.0, v_floor, ROLLOUT_GRID, ROLLOUT_TOL, windows, w, 0.0
        )
        self._keep(kept)
        return out[1], "numeric" if out[2] == 1.0 else "best", out[3]

    def plan(
        self,
        v_ld: float,
        keep: float,
        need: float,
        cap: float,
        v_floor: float,
        windows: int,
        w: float,
        contact: float = 0.0,
    ) -> tuple[float, float, str, float, bool, list[Any], list[Any]] | None:
        """`PlanPolicy`'s decision (margin 1 − ``keep``, horizon
        ``windows`` windows of ``w`` ms, the contact bound at d_c = ``contact`` cm, 0: off)
        in one compiled call: (w, V_L, method, the found
        speed or NaN, feasible, the rows at V_Ld, the rows at V_L: the same list when the
        method is none, as the Python decision's); None when this rollout
        is not compiled, or ``v_ld`` or ``w`` are not the state's (its V_Ld and w_sch,
        which `rows` uses). Its rollouts join the memo, as the Python policy's do."""
        st = self.base
        if self._compiled is None or v_ld != st.v_ld or w != st.w_sch:
            return None
        out, kept = self._compiled.decide(
            False, keep, need, cap, v_floor, ROLLOUT_GRID, ROLLOUT_TOL, windows, w, contact
        )
        return self._planned(out, kept, keep, need, windows, w, contact)

    def _planned(
        self,
        out: list[float],
        kept: Any,
        keep: float,
        need: float,
        windows: int,
        w: float,
        contact: float,
    ) -> tuple[float, float, str, float, bool, list[Any], list[Any]]:
        """`plan`'s answer from the compiled decision's ``out`` and rollouts ``kept``
        (`rtsim.control.compiled_rollout.CompiledRollout.decide`'s), its rollouts kept for
        the memo."""
        if self._kept is not None:  # (`_keep`)
            self._settle()
        self._kept = kept
        w_out, v_l, method, found, feasible = out[:5]
        # the rows after the kernel's seven numbers, each follower's four bounds in turn
        # (zip of one iterator four times: its items four by four)
        half = (len(out) + 7) >> 1
        it = iter(out[7:half])
        before = list(zip(it, it, it, it))  # noqa: B905 (a multiple of four)
        if method == 0.0:  # V_Ld kept: its rows (the kernel copied them to rows[1])
            return w_out, v_l, "none", found, feasible == 1.0, before, before
        it = iter(out[half:])
        after = list(zip(it, it, it, it))  # noqa: B905
        if math.isnan(feasible):  # the search did not roll the chosen speed out: here
            after = self.rows(v_l)
            horizon = self.changes(v_l, (w,) * windows)
            worst = min(min_bound_rows(self.bounds(c, w))[0] for c in horizon)
            worst = self.contact(horizon, w, contact, worst)
            feasible = 1.0 if keep * worst >= need else 0.0
        return (
            w_out,
            v_l,
            ("none", "numeric", "best")[int(method)],
            found,
            feasible == 1.0,
            before,
            after,
        )

    def _run(self, v: float, windows: tuple[float, ...]) -> list[list[Changes]]:
        if self._compiled is not None:  # the world's compiled law: one kernel call
            return self._compiled.changes(v, windows)  # type: ignore[no-any-return]
        _PYTHON_RUNS[0] += 1
        st = self.state
        travel = motion_model(st.params.motion_model).leader
        ld = Leader(
            st.path,
            st.v_ld,
            st.leader_s,
            accel_max=st.accel_max,
            decel_max=st.decel_max,
            travel=travel,
        )
        ld.speed = st.leader_speed
        ld.target_speed = st.leader_speed
        ld.set_speed(min(max(v, 0.0), st.v_ld))
        n = len(st.poses)
        law = None if st.law is None else st.law.clone()
        targets: dict[float, tuple[Any, Any]] = {}  # l-ψ: control targets per curvature
        # the scans and the sends, in time order (a send before a scan at the same time)
        scans = [st.next_scan]
        for w in windows:
            scans.append(scans[-1] + w)
        events: list[tuple[float, int, int]] = []
        for k in range(n):
            for t in st.pending[k]:
                if st.t_now <= t < scans[-1]:
                    events.append((t, 0, k))
            for s0 in scans[:-1]:
                t = s0 + st.send_offsets[k]
                if t < scans[-1]:
                    events.append((t, 0, k))
        events += [(t, 1, j) for j, t in enumerate(scans)]
        events.sort()
        samples: list[list[tuple[float, float, float, float, float]]] = []
        group = st.group(
            [p[0] for p in st.poses],
            [p[1] for p in st.poses],
            [p[2] for p in st.poses],
            st.speeds,
            st.params,
            st.t_now,
        )
        group.cmd_v = [h[0] for h in st.held]
        group.cmd_w = [h[1] for h in st.held]
        group.w = list(st.turns or group.cmd_w)
        t_leader = st.t_now
        for t, kind, k in events:
            if t > t_leader:
                ld.advance((t - t_leader) / 1000.0)
                t_leader = t
            if kind == 0:
                group.advance(k, t, st.step_ms)
                if law is not None:
                    cmd = law.command(
                        k, ld.s, ld.pose, ld.speed, group.x[k], group.y[k], group.th[k]
                    )
                else:
                    kappa = ld.curvature
                    if kappa not in targets:
                        targets[kappa] = control_targets(
                            np.asarray(st.rho_d),
                            np.asarray(st.beta_d),
                            st.params.control_offset,
                            kappa,
                        )
                    l_d, psi_d = targets[kappa]
                    cmd = lpsi_command(
                        ld.pose,
                        ld.speed,
                        kappa * ld.speed,
                        group.x[k],
                        group.y[k],
                        group.th[k],
                        float(l_d[k]),
                        float(psi_d[k]),
                        st.params,
                    )
                v_c, w_c = group.saturate(*cmd)
                group.apply_drawn(k, v_c, w_c, 0.0, 0.0)
                continue
            group.advance_all(t, st.step_ms)
            xl, yl, hl = ld.pose
            c, s = math.cos(hl), math.sin(hl)
            row = []
            for i in range(n):
                dx, dy = group.x[i] - xl, group.y[i] - yl
                tx, ty = c * dx + s * dy, -s * dx + c * dy
                row.append(
                    (
                        tx,
                        ty,
                        math.hypot(tx, ty),
                        math.atan2(ty, tx) % _TWO_PI,
                        group.odometer[i],
                    )
                )
            samples.append(row)
        near = []  # each follower's closest approach at each scan (rtsim.world.contact)
        for a in samples:
            xs, ys = [p[0] for p in a], [p[1] for p in a]
            near.append([closest_to(xs, ys, i, 0.0, 0.0) for i in range(n)])
        out = []
        for j, (a, b) in enumerate(zip(samples, samples[1:], strict=False)):
            out.append(
                [
                    (
                        math.hypot(q[0] - p[0], q[1] - p[1]),
                        abs(q[2] - p[2]),
                        q[4] - p[4],
                        abs(math.remainder(q[3] - p[3], _TWO_PI)),
                        closest_over(near[j][i], near[j + 1][i]),
                    )
                    for i, (p, q) in enumerate(zip(a, b, strict=True))
                ]
            )
        return out
