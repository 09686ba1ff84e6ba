"""The controller's command-aware rollout in compiled calls (the world's ``compiled``
backend): `CompiledRollout` packs a `rtsim.control.rollout.RolloutState` into arrays
once and hands it to the kernels of `rtsim.control.kernels` — a rollout whole in one
call, and the ``plan`` policy's decision or the ``commands`` speed search in one call per
decision (its rollouts handed back for the rollout's memo, as the Python policy leaves them
there). The same expressions in the same order as the Python rollout, so the same numbers
bit for bit (`rtsim.world.compiled` says which operations may be compiled).
"""

from __future__ import annotations

import functools
import itertools
import math
import operator
from collections.abc import Callable
from typing import Any

import numpy as np

from rtsim.control import kernels as K
from rtsim.world.compiled import CompiledTraceFollower
from rtsim.world.kernels import entry, kernels
from rtsim.world.motionmodels import motion_model

__all__ = ["CompiledRollout", "as_changes", "compiled_rollout", "compiles"]


def as_changes(arr: Any) -> list[list[Any]]:
    """A [window, follower, change] array as the rollout's lists of tuples (the four changes
    and the closest approach, `rtsim.control.rollout.Changes`); a search's rollout that
    stopped early (`_Rest`) is rolled out whole first."""
    if isinstance(arr, _Rest):
        arr = arr()
    return [[tuple(c) for c in win] for win in arr.tolist()]


def compiled_rollout(law: Any, state: Any) -> CompiledRollout | None:
    """The compiled rollout of ``state`` (a `RolloutState` whose law is ``law``) when the
    law is the compiled backend's and the compiled hypot is this interpreter's; else None
    (the caller plays the rollout in Python)."""
    return CompiledRollout(law, state) if compiles(law) else None


def compiles(law: Any) -> bool:
    """Whether a rollout on ``law`` runs compiled (`compiled_rollout`): the law is the
    compiled backend's and the compiled hypot is this interpreter's."""
    return isinstance(law, CompiledTraceFollower) and kernels().exact_hypot


#: how many of RolloutScalars' fields change from one decision to the next (they come first)
_CHANGING = K.RolloutScalars._fields.index("accel")

#: the items of iterables in turn
_chain = itertools.chain.from_iterable

#: the follower pack's columns (`rtsim.control.kernels.FollowerColumns`)
_COLUMNS = len(K.FollowerColumns._fields)

#: a `World.estimate_rows` row's pack columns before the send and ρ_d, for a motion model
#: without a turn rate of its own (x, y, θ, v̂, then ω = the held command's ω_c, v_c, ω_c)
_UNICYCLE = operator.itemgetter(0, 1, 2, 3, 6, 5, 6)

#: rollouts of one search kept for the memo: v_floor, 7 scanned speeds and the bisection (5 at
#: ROLLOUT_TOL = 0.005; room for any tolerance down to 2^-50)
_SEARCH_RUNS = 64


#: the rollouts every `CompiledRollout` has run in this process (each kernel call's; a list,
#: not a class attribute: writing a class's attribute empties the type's method cache)
RUNS = [0]

#: the compiled functions behind the rollout kernels' dispatchers, by dispatcher (`call`)
_ENTRIES: dict[Any, Any] = {}


def call(fn: Any, *args: Any) -> Any:
    """``fn(*args)`` for a rollout kernel ``fn``, through its compiled function once it has
    one for these arguments' types (`rtsim.world.kernels.entry`: the pack's nested tuple of
    arrays is not typed again at every call); every call of a kernel here passes the same
    types."""
    f = _ENTRIES.get(fn)
    if f is None:
        f = entry(fn, args)
        if f is not fn:
            _ENTRIES[fn] = f
    return f(*args)


#: the window lengths of whole rollouts as arrays, by their tuple (the kernels read them only;
#: a run asks for few: w_sch and the horizon)
_LENGTHS: dict[tuple[float, ...], Any] = {}


def _lengths(windows: tuple[float, ...]) -> Any:
    """``windows`` (a tuple of floats) as a float array, kept for the next ask (writeable,
    as the kernel's build is typed; no kernel writes it)."""
    arr = _LENGTHS.get(windows)
    if arr is None:
        if len(_LENGTHS) >= 256:  # (bounded: a long run's windows vary)
            _LENGTHS.clear()
        arr = _LENGTHS[windows] = np.array(windows, dtype=float)
    return arr


class _Rest(tuple):  # type: ignore[type-arg]
    """A search's rollout that stopped after its first window (its speed failed there, and
    the decision needed no more), kept for the rollout's memo as the tuple (the
    `CompiledRollout`, the speed, the window lengths, the pack of the decision with the law's
    search starts copied then): called, it rolls the whole horizon out on that pack, the
    numbers the search would have had. (A tuple: made in C, a decision keeps several.)"""

    __slots__ = ()

    def __call__(self) -> Any:
        ro, v, windows, pack = self
        if not pack:  # (the kernel stops a rollout early only in a search: `decide` keeps it)
            raise RuntimeError("a rollout stopped early outside a search: its pack was not kept")
        return ro._whole(v, windows, pack)


def _static(law: CompiledTraceFollower, state: Any) -> Any:
    """The law's cache for rollouts of ``state``'s params, thresholds, ramp limits and step:
    (those five, the float pack with the scalars that stay from one decision to the next,
    in RolloutScalars' order after the five that change, the no-sends-pending array per
    follower count, the kernels, the size of a decision's float buffer per follower count
    and horizon); made once per law (a clone of the law shares it) and kept while the five are
    the same objects."""
    p, thr = state.params, state.thresholds
    static = (p, thr, state.accel_max, state.decel_max, state.step_ms)
    cached: Any = getattr(law, "_rollout_static", None)
    if cached is not None and cached[0] == static:  # (the same objects: no field compared)
        return cached
    scalars = K.RolloutScalars(
        leader_s=0.0,  # the five that change: set per decision (`CompiledRollout._made`)
        leader_speed=0.0,
        v_ld=0.0,
        t_now=0.0,
        next_scan=0.0,
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
    # (compiled once per process and motion model: before the first rollout)
    ker = K.rollout_kernels(motion_model(p.motion_model))
    # (the sizes of the decision's float buffer, by follower count and horizon: each
    # decision's buffers are its own, `_Kept` reads them when asked; the five that change
    # are written over a copy per decision)
    cached = (static, np.array(scalars, dtype=float), {}, ker, None, {})
    setattr(law, "_rollout_static", cached)  # noqa: B010 (a cache the law carries)
    return cached


def _new_rollout(
    ker: Any,
    bufs: Any,
    scalars: Any,
    leader_s: float,
    leader_speed: float,
    t_now: float,
    next_scan: float,
    fol: Any,
    pend: Any,
    law: Any,
) -> CompiledRollout:
    """A `CompiledRollout` on the kernels ``ker`` and buffers ``bufs`` (`_static`'s) whose
    pack is RolloutScalars ``scalars`` (the run's, copied) with a decision's four that
    change, the followers' rows ``fol``, the pending sends ``pend`` and the law's geometry
    and search starts (`CompiledRollout._packed`'s pack, for `direct` and `planner`)."""
    fs = scalars.copy()
    fs[0] = leader_s
    fs[1] = leader_speed
    fs[3] = t_now
    fs[4] = next_scan
    ro: CompiledRollout = object.__new__(CompiledRollout)
    ro._ker = ker
    ro._bufs = bufs
    ro._pack = (fs, fol, pend, law._G, law._sr, law._sf)
    ro.n = len(fol)
    return ro


class CompiledRollout:
    """`Rollout`'s arithmetic for one state in compiled calls:
    the state packed into arrays once (`RolloutScalars`, a row per
    follower, the pending sends NaN-padded), the law's search starts read at each call (the
    live law's, as the Python rollout clones it then).

    The rollouts every instance has run in this process (each kernel call's) are counted in
    `RUNS` (read through `rtsim.control.rollout.rollouts_run`)."""

    def __init__(self, law: CompiledTraceFollower, state: Any) -> None:
        self._made(law, _static(law, state), state)

    @staticmethod
    def direct(law: Any, base: Any) -> Callable[..., CompiledRollout]:
        """``CompiledRollout(law, s)`` for the states ``s`` of a run's decisions without
        ``s``: the law's cache looked up once; ``make(t_now, leader_s, leader_speed, rows,
        pending, next_scan, send_offsets, turned)`` packs the state that
        `rtsim.control.rollout.rows_state` makes of ``base`` and these (the same arrays),
        from ``rows`` themselves, for a rollout that makes its state only when read."""
        cached = _static(law, base)
        made, fromiter = _new_rollout, np.fromiter
        rho = base.rho_d
        ker, bufs, no_pend = cached[3], cached[5], cached[2]
        # RolloutScalars with the run's V_Ld: a decision writes the other four that change
        scalars = cached[1].copy()
        scalars[2] = base.v_ld

        def make(
            t_now: float,
            leader_s: float,
            leader_speed: float,
            rows: Any,
            pending: Any,
            next_scan: float,
            sends: Any,
            turned: bool,
        ) -> CompiledRollout:
            # (`_packed` written out, one call a decision: the followers' pack columns in
            # FollowerColumns' order, row after row, of `World.estimate_rows`' rows — x, y,
            # θ, v̂, ω̂, v_c, ω_c — the sends and the slots; ω the rows' ω̂ when ``turned``,
            # the motion model keeps a turn rate, else the held command's)
            flat: list[float] = []
            if turned:
                for r, send, rho_d in zip(rows, sends, rho):  # noqa: B905
                    flat += r
                    flat += (send, rho_d)
            else:  # (the unicycle: ω is the held command's)
                for r, send, rho_d in zip(rows, sends, rho):  # noqa: B905
                    flat += _UNICYCLE(r)
                    flat += (send, rho_d)
            n = len(rows)
            pend = no_pend.get(n) if not any(pending) else None
            if pend is None:
                pend = _pending_pack(cached, n, pending)
            fol = fromiter(flat, float, n * _COLUMNS).reshape(n, _COLUMNS)
            return made(
                ker, bufs, scalars, leader_s, leader_speed, t_now, next_scan, fol, pend, law
            )

        return make

    @staticmethod
    def planner(
        law: Any, base: Any, turned: bool, *decision: Any
    ) -> Callable[..., tuple[CompiledRollout, list[float], _Kept, Any]]:
        """`direct`'s state and `decide` on it (``decision``: `decide`'s arguments) in one
        step, for the decisions of a run (``turned``: `direct`'s): ``step(carry, t_now,
        leader_s, leader_speed, pending, next_scan, sends)`` → (the `CompiledRollout`,
        `decide`'s two answers, the follower pack's rows: its array, which no call changes
        afterwards, not lists of its floats a record would keep). ``carry(t_now, out)``
        writes the estimates' rows (x, y, θ, v̂, ω̂, v_c, ω_c:
        `rtsim.world.world.World.estimate_rows`) into the first seven columns of the pack's
        rows ``out`` in place: the pack is made with no list of the rows between (its send
        and ρ_d columns copied from a template per ``sends``, ω the held command's for the
        unicycle)."""
        cached = _static(law, base)
        made = _new_rollout
        ker, bufs, no_pend = cached[3], cached[5], cached[2]
        scalars = cached[1].copy()  # (RolloutScalars with the run's V_Ld, as `direct`'s)
        scalars[2] = base.v_ld
        n = len(base.rho_d)
        rho = base.rho_d
        # the pack's rows with their send and ρ_d columns, by send offsets (a run's windows
        # repeat a few: Test 2 at n = 2, 31 in 516 decisions)
        fixed: dict[tuple[float, ...], Any] = {}
        unturned = range(0) if turned else range(n)
        search_only, keep, need, cap, v_floor, grid, tol, windows, w, contact = decision
        # (as the compiled entry is typed: `decide`'s first call's conversions)
        search_only, keep, need, cap = bool(search_only), float(keep), float(need), float(cap)
        v_floor, grid, tol, contact = float(v_floor), int(grid), float(tol), float(contact)
        windows, w, no_f1 = int(windows), float(w), K.NO_F1
        size = bufs.get((n, windows))
        if size is None:
            size = bufs[n, windows] = K.decision_buffers(n, windows, _SEARCH_RUNS)[0].size
        empty, int64, m2, head = np.empty, np.int64, 2 * _SEARCH_RUNS, K.decision_head(n)
        entry_of: list[Any] = [None]  # (the compiled entry, found at the first call: `call`)

        def step(
            carry: Any,
            t_now: float,
            leader_s: float,
            leader_speed: float,
            pending: Any,
            next_scan: float,
            sends: tuple[float, ...],
        ) -> tuple[CompiledRollout, list[float], _Kept, Any]:
            fol = fixed.get(sends)
            if fol is None:
                if len(fixed) >= 256:  # (bounded: a long run's offsets vary)
                    fixed.clear()
                fol = fixed[sends] = np.empty((n, _COLUMNS))
                fol[:, 7], fol[:, 8] = sends, rho
            fol = fol.copy()
            carry(t_now, fol)
            for k in unturned:  # (the unicycle: ω is the held command's)
                fol[k, 4] = fol[k, 6]
            pend = no_pend.get(n) if not any(pending) else None
            if pend is None:
                pend = _pending_pack(cached, n, pending)
            ro = made(ker, bufs, scalars, leader_s, leader_speed, t_now, next_scan, fol, pend, law)
            pack = ro._pack
            fb, ib = empty(size), empty(m2, int64)
            f = entry_of[0]
            if f is None:  # (the first call: `call` finds the entry for these types)
                f = functools.partial(call, ker.roll_or_decide)
            runs = f(
                False, 0.0, search_only, keep, need, cap, v_floor, grid, tol, w, contact,
                no_f1, pack, fb, ib,
            )  # fmt: skip
            if entry_of[0] is None:
                entry_of[0] = _ENTRIES.get(ker.roll_or_decide, f)
            got, kept = ro._decided(runs, fb, ib, w, windows, head)
            return ro, got, kept, fol

        return step

    def _made(self, law: CompiledTraceFollower, cached: Any, state: Any) -> None:
        """Pack ``state`` (the law's cache ``cached``, `_static`)."""
        rho = state.rho_d
        # per follower, in FollowerColumns' order (x, y, θ, v, ω, held v, held ω, send, ρ_d)
        turns = state.turns
        flat: list[float] = []
        if turns:
            for pose, v, w, h, send, rho_d in zip(  # noqa: B905
                state.poses, state.speeds, turns, state.held, state.send_offsets, rho
            ):
                flat += (*pose, v, w, *h, send, rho_d)
        else:  # (the unicycle: ω is the held command's)
            for pose, v, h, send, rho_d in zip(  # noqa: B905
                state.poses, state.speeds, state.held, state.send_offsets, rho
            ):
                flat += (*pose, v, h[1], *h, send, rho_d)
        five = (state.leader_s, state.leader_speed, state.v_ld, state.t_now, state.next_scan)
        self._packed(law, cached, five, flat, len(state.poses), state.pending)

    def _packed(
        self,
        law: CompiledTraceFollower,
        cached: Any,
        five: Any,
        flat: list[float],
        n: int,
        pending: Any,
    ) -> None:
        """The pack of RolloutScalars' first ``five``, the ``n`` followers' columns ``flat``
        (row by row) and the ``pending`` sends (the law's cache ``cached``, `_static`)."""
        self._ker, self._bufs = cached[3], cached[5]
        fs = cached[1].copy()
        # RolloutScalars' first five (item by item: a slice from a tuple converts it first;
        # one fromiter of all 21 is 2.5x the copy)
        fs[0], fs[1], fs[2], fs[3], fs[4] = five
        # (a flat list of floats read by fromiter: no shape or type to discover)
        fol = np.fromiter(flat, float, n * _COLUMNS).reshape(n, _COLUMNS)
        pend = _pending_pack(cached, n, pending)
        # (the law's search starts: its arrays, changed only in place, read at each call)
        self._pack = (fs, fol, pend, law._G, law._sr, law._sf)
        self.n = n

    def pack(self) -> tuple[Any, ...]:
        """The kernels' ``P``: the state's arrays, the path's, the law's geometry and its
        search starts as they are now."""
        return self._pack

    def changes(self, v: float, windows: tuple[float, ...]) -> list[list[Any]]:
        """`Rollout.changes` uncached: per window, per follower the four changes."""
        return as_changes(self._whole(v, windows, self.pack()))

    def _whole(self, v: float, windows: tuple[float, ...], pack: tuple[Any, ...]) -> Any:
        """One rollout whole on ``pack`` (`pack`'s arrays): its changes array."""
        out = np.empty((len(windows), self.n, 5))
        RUNS[0] += 1
        call(  # (`_rollout_changes` through the one entry: the decision's buffers unused)
            self._ker.roll_or_decide, True, float(v), False, 1.0, -math.inf, 0.0, 0.0, 0,
            0.0, 0.0, 0.0, _lengths(windows), pack, out.reshape(-1), K.NO_I1,
        )  # fmt: skip
        return out

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
        contact: float,
    ) -> tuple[list[float], _Kept]:
        """`PlanPolicy`'s decision, or with ``search_only``
        `rtsim.control.adjust.search_rollout` over keep · (the smallest bound of
        ``windows`` windows of ``w`` ms; the contact bound at d_c = ``contact`` cm, 0: off),
        in one call (`rtsim.control.kernels._plan_decide`, on fresh arrays of
        changes): ([w, V_L, method code, found, feasible, the checked window, the rollouts
        run beyond the count, then the rows at V_Ld and at V_L, follower then kind, each
        follower's four in turn], the rollouts it ran for the rollout's memo as the kernel
        left them, `_Kept`)."""
        n = self.n
        windows = int(windows)
        w = float(w)
        # the decision's own two buffers (`rtsim.control.kernels._roll_or_decide`: the out
        # values, the rows and the rollouts' speeds and changes in one float array, their
        # codes and cuts in one integer array; `_Kept` reads them when the memo asks)
        size = self._bufs.get((n, windows))  # (the law's, per follower count and horizon)
        if size is None:
            size = self._bufs[n, windows] = K.decision_buffers(n, windows, _SEARCH_RUNS)[0].size
        fb = np.empty(size)
        ib = np.empty(2 * _SEARCH_RUNS, np.int64)
        f = _ENTRIES.get(self._ker.roll_or_decide)
        if f is None:  # (the first call: `call` finds the entry for these types)
            f = functools.partial(call, self._ker.roll_or_decide)
            search_only, keep, need, cap = bool(search_only), float(keep), float(need), float(cap)
            v_floor, grid, tol, contact = float(v_floor), int(grid), float(tol), float(contact)
        # (the compiled entry converts its scalars as it is typed: no float() here)
        runs = f(
            False, 0.0, search_only, keep, need, cap, v_floor, grid, tol, w, contact, K.NO_F1,
            self._pack, fb, ib,
        )  # fmt: skip
        return self._decided(runs, fb, ib, w, windows)

    def _decided(
        self, runs: int, fb: Any, ib: Any, w: float, windows: int, head: int = -1
    ) -> tuple[Any, Any]:
        """`decide`'s answer from the kernel's ``runs`` and its buffers ``fb``, ``ib`` (a
        decision of ``windows`` windows of ``w`` ms on this pack; ``head``: `decision_head`
        of its follower count when the caller has it)."""
        if head < 0:
            head = K.decision_head(self.n)
        got = fb[:head].tolist()
        RUNS[0] += runs + int(got[6])
        frozen: tuple[Any, ...] = ()
        if got[2] != 0.0:  # a search (only one stops a rollout after its first window):
            # the law's search starts as they are at the decision, for those rolled out
            # whole when asked (`_Rest`)
            p = self._pack
            frozen = (p[0], p[1], p[2], p[3], p[4].copy(), p[5].copy())
        m = runs if runs < _SEARCH_RUNS else _SEARCH_RUNS  # (those it kept)
        return got, _Kept((self, fb, ib, m, w, windows, got[5], frozen, head))


def _pending_pack(cached: Any, n: int, pending: Any) -> Any:
    """The pack's pending sends of ``n`` followers: ``pending`` NaN-padded to as many per
    follower, or when none is pending the law's one array for ``n`` (``cached``: `_static`'s)."""
    if not any(pending):  # no sends pending: one array per n, kept
        pend = cached[2].get(n)
        if pend is None:
            pend = cached[2][n] = np.full((n, 1), math.nan)
        return pend
    counts = list(map(len, pending))
    m = max(counts)
    if min(counts) == m:  # (as many for each: read flat, as the followers)
        return np.fromiter(_chain(pending), float, n * m).reshape(n, m)
    pend = np.full((n, m), math.nan)
    for k, times in enumerate(pending):
        pend[k, : len(times)] = times
    return pend


class _Kept(tuple):  # type: ignore[type-arg]
    """A decision's rollouts for the rollout's memo, as the kernel left them: (the
    `CompiledRollout`, the decision's float and integer buffers — their speeds and changes
    [rollout, window, follower, change], their codes: 0 the horizon, 1 the horizon and its
    first window, 2 one window of the checked length, and whether each stopped after its
    first window; `rtsim.control.kernels.decision_views` —, how many, w, the horizon's
    windows, the checked window's length, the pack with the law's search starts copied at
    the decision — () when no rollout stopped early —, where the speeds start in the float
    buffer: `rtsim.control.kernels.decision_head`). The rollout's memo asks for them when
    it needs them (`put`, `first`), not at every decision. (A tuple: made in C.)"""

    __slots__ = ()

    def changes(self) -> Any:
        """The rollouts' changes [rollout, window, follower, change] (a view)."""
        return K.decision_views(self[1], self[2], self[0].n)[2]

    def near(self, r: int) -> list[float]:
        """Rollout ``r``'s closest approaches in its first window, per follower: ``changes()
        [r, 0, :, 4]`` read without the views (`rtsim.control.kernels.decision_at`)."""
        fb, n = self[1], self[0].n
        at = K.decision_at(self[8], n, self[2].shape[0] >> 1, self[5], r) + 4
        return fb[at : at + 5 * n : 5].tolist()  # type: ignore[no-any-return]

    def put(self, raw: dict[tuple[float, tuple[float, ...]], Any], memo: Any) -> int:
        """Put the rollouts in ``raw``, keyed (speed, window lengths), their changes
        [window, follower, change] as arrays, one stopped after its first window as `_Rest`
        (the first of equal keys, none whose key ``memo`` has); returns how many keys it
        added."""
        ro, fb, ib, runs, w, windows, checked, frozen, _ = self
        speeds, lens, changes, cut = K.decision_views(fb, ib, ro.n)[:4]
        before = len(raw)
        horizon = (w,) * windows
        put = raw.setdefault  # (the first of equal keys, as ever)
        sp, ln, ct = speeds[:runs].tolist(), lens[:runs].tolist(), cut[:runs].tolist()
        for r in range(runs):
            v = sp[r]
            code = ln[r]
            key: tuple[float, tuple[float, ...]]
            if code == 2:
                key = (v, (checked,))
                if not memo or key not in memo:
                    put(key, changes[r, :1])
                continue
            key = (v, horizon)
            if not memo or key not in memo:
                # (stopped after its first window: whole only if asked)
                put(key, _Rest((ro, v, horizon, frozen)) if ct[r] else changes[r])
            if code == 1:
                key = (v, (w,))
                if not memo or key not in memo:
                    put(key, changes[r, :1])
        return len(raw) - before

    def find(self, key: tuple[float, tuple[float, ...]]) -> tuple[int, int]:
        """Which entry `put` leaves under ``key`` (speed, window lengths) in an empty ``raw``
        and ``memo``: (the rollout, 0 its changes whole, 1 its first window's, 2 its `_Rest`),
        or (−1, 0) when no rollout of the decision has that key."""
        v, lengths = key
        fb, ib, runs, w, windows, checked = self[1], self[2], self[3], self[4], self[5], self[6]
        # (the speeds after the out values and rows, as a list: its search in C; the codes
        # first in ib, the cuts after them)
        at, cut = self[8], ib.shape[0] >> 1
        speeds = fb[at : at + runs].tolist()
        if v not in speeds:  # (== as `!=` below: a NaN is no speed's)
            return -1, 0
        for r in range(speeds.index(v), runs):
            if speeds[r] != v:
                continue
            code = ib.item(r)
            if code == 2:
                if lengths == (checked,):
                    return r, 1
                continue
            if len(lengths) == windows and lengths == (w,) * windows:  # (its first key)
                return r, 2 if ib.item(cut + r) else 0
            if code == 1 and lengths == (w,):
                return r, 1
        return -1, 0

    def first(self, key: tuple[float, tuple[float, ...]]) -> Any:
        """What `put` leaves under ``key`` (speed, window lengths) in an empty ``raw`` and
        ``memo``: its changes array or its `_Rest`; None when no rollout of the decision
        has that key (`find`)."""
        r, how = self.find(key)
        if r < 0:
            return None
        if how == 0:
            return self.changes()[r]
        if how == 1:
            return self.changes()[r, :1]
        horizon = (self[4],) * self[5]  # (the rollout's own speed and windows, as `put`'s)
        return _Rest((self[0], self[1].item(self[8] + r), horizon, self[7]))
