"""Physical outcomes of a coupled run, in centimetres (summary.json, docs/outputs.md).

The bounds of the paper are per-window conventions (a follower "violates" path diversion when
it drives more than T_ε·ρ_d in one window — a speed cap, not a departure from the path). What
a user of a robot group asks is physical: how far did the followers stray from the path, how
well did they keep their separation, how close did robots come, did any collide, how far did
they get. Sampled on the truth at every scan (every window, ~0.24 s here):

* ``cross_track_cm``: a follower's distance from its place on the trace — the leader's trace
  (the path it drove) shifted sideways by the follower's lateral offset, the curve its
  follow-the-leader law tracks (`rtsim.world.ftl.TraceFollower.project`); ``None``
  with l-ψ followers, which track a slot, not the trace;
* ``separation_error_cm``: |ρ − ρ_d|, ρ the follower's true distance to the leader;
* ``min_robot_distance_cm``: the closest any two robots' centres came (leader included);
* ``collisions``: scans at which some two robots' centres were closer than the sum of their
  radii (every robot has the follower radius r_F: the paper's barrels);
* ``clearance_violations``: scans at which some two robots' discs came closer than the
  formation's clearance (centres closer than 2·r_F + clearance; ``clearance_cm``);
* ``distance_cm``: the distance each robot drove over the run.

Per run: p95 and max over every follower's samples; per follower in ``per_follower``. The
samples go to a `rtsim.coupling.spill.ValueSpill` (a scratch file when the run
has a directory for one), and the percentiles are selected from it exactly in bounded memory
(`rtsim.coupling.spill.p95_max_columns`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from rtsim.coupling.spill import ValueSpill, p95_max_columns
from rtsim.world.contact import closest_each, contact_distance
from rtsim.world.ftl import _PY_SUBS, TraceFollower
from rtsim.world.jit import build, specialise
from rtsim.world.kernels import built_entry
from rtsim.world.scanstep import LOG_ROW, NEAR_ROW
from rtsim.world.tracelog import trace_samples

__all__ = ["PhysicalLog", "p95_max_rows", "trace_samples"]

Stats = dict[str, float] | None


def _p95_max(v: np.ndarray) -> Stats:
    """p95 and max of the values ``v`` (None: none)."""
    if not v.size:
        return None
    return {"p95": float(np.percentile(v, 95)), "max": float(v.max())}


def p95_max_rows(rows: Any) -> tuple[Stats, list[Stats]]:
    """p95 and max (`_p95_max`) of every row's values together and of each row's (one per
    follower, a list or an array each). Rows of one length go through one percentile call
    along the axis — each row's is its own, to the bit — and the flattened array, two calls
    whatever the number of rows; rows of unequal lengths, one call each."""
    arrs = [np.asarray(r, dtype=float) for r in rows]
    if len({a.size for a in arrs}) == 1 and arrs[0].size:
        stack = np.stack(arrs)
        p95, top = np.percentile(stack, 95, axis=1), stack.max(axis=1)
        per: list[Stats] = [
            {"p95": float(p), "max": float(m)} for p, m in zip(p95, top, strict=True)
        ]
        return _p95_max(stack.ravel()), per
    every = np.concatenate(arrs) if arrs else np.zeros(0)
    return _p95_max(every), [_p95_max(a) for a in arrs]


#: `trace_samples` as Python (``math.hypot``, the law's Python twins). (Compiled on its
#: own only where the world's scan does not make the samples, `PhysicalLog.fuse`: not
#: counted in the world's announcement of its compile.)
_PY_SAMPLES = specialise(trace_samples, _PY_SUBS)


class PhysicalLog:
    """Accumulates the physical outcomes at each scan (module docstring)."""

    def __init__(
        self,
        n: int,
        rho_d: list[float],
        radius: float,
        law: TraceFollower | None,
        guesses: list[float] | None = None,
        clearance: float = 0.0,
    ) -> None:
        self.n = n
        self.clearance = float(clearance)
        self.clearance_violations = 0
        self.rho_d = rho_d
        self.radius = float(radius)
        self._contact = contact_distance(self.radius, self.clearance)  # d_c
        self._collide = 2.0 * self.radius  # (two discs overlap: centres closer than this)
        self._law = None if law is None else law.clone()  # its own projection starts
        self._guess = guesses
        # per scan, each follower's separation error then (with a trace law) its cross-track
        self.samples = ValueSpill(n * (1 if law is None else 2))
        self.min_dist = math.inf
        self.collisions = 0
        self._trace: Any = None
        if self._law is not None:
            self._trace = self._trace_run(self._law, n)

    def _trace_run(self, law: TraceFollower, n: int) -> tuple[Any, ...]:
        """`trace_samples` and its arguments but the positions: compiled (one call per scan,
        on arrays; built at its first use, `_compiled`: where the world's scan makes the
        samples, `fuse`, never) when the law runs compiled, else its Python twin (on
        lists)."""
        guess = [0.0] * n if self._guess is None else [float(g) for g in self._guess]
        if not getattr(law, "compiled", False):
            return _PY_SAMPLES, law._G, law._sf, self.rho_d, guess, [0.0] * (2 * n), [0.0] * n
        args = (law._G, law._sf, np.asarray(self.rho_d, dtype=float), np.asarray(guess))
        return None, *args, np.zeros(2 * n), np.zeros(n)

    def _compiled(self) -> tuple[Any, ...]:
        """`_trace_run`'s compiled call and its arguments, the call built (or loaded)
        the first time."""
        trace = self._trace
        if trace[0] is None:
            _, G, sf, rho_d, guess, out, near = trace
            x = np.zeros(self.n)  # (the positions' type: float arrays of n)
            fn = built_entry(build(trace_samples), (G, sf, x, x, 0.0, 0.0, rho_d, guess, out, near))
            trace = self._trace = (fn, *trace[1:])
        return trace  # type: ignore[no-any-return]

    def add(self, leader: tuple[float, float, float], xs: Any, ys: Any) -> Sequence[float]:
        """One scan: the leader's pose and the followers' true positions (cm: lists of
        floats, or float arrays, such as the compiled world's rows `FollowerGroup.xy`, which
        the compiled samples read as they are). Returns each follower's centre distance to
        the nearest other robot, leader included (cm, `rtsim.world.contact.closest_to`: the
        planner's contact bound measures the same), a list."""
        trace = self._trace
        if trace is not None and trace[0] is not _PY_SAMPLES:
            return self.adder()(leader, xs, ys)
        xl, yl, _ = leader
        samples = self.samples
        if type(xs) is np.ndarray:
            xs, ys = xs.tolist(), ys.tolist()
        if trace is None:
            put = samples.buf.append
            hypot, rho_d = math.hypot, self.rho_d
            for k in range(self.n):
                put(abs(hypot(xs[k] - xl, ys[k] - yl) - rho_d[k]))
            near = list(closest_each(xs, ys, xl, yl))
        else:
            fn, G, sf, rho_d, guess, out, near_k = trace
            fn(G, sf, xs, ys, xl, yl, rho_d, guess, out, near_k)
            samples.buf += out
            near = list(near_k)
        samples.full()  # a chunk's worth goes to the file (once per scan)
        self.count(near)
        return near

    def count(self, near: Sequence[float]) -> None:
        """Count one scan's closest approaches ``near`` (`add`'s): the closest pair of the
        run, the collisions and the clearance violations."""
        # the smallest, as min(near) (every pair has a follower in it): the first item
        # unless a later one is less, NaN included; a loop, not min(), which parses keyword
        # arguments at every call (≈ 1.6x the instructions at n = 2)
        close = math.inf
        if near:
            close = near[0]
            for x in near:
                if x < close:
                    close = x
        if close < self.min_dist:
            self.min_dist = close
        # (a count goes up only when a scan breaks: branches, not a bool added every scan)
        if close < self._collide:
            self.collisions += 1
        if close < self._contact:
            self.clearance_violations += 1

    def adder(self) -> Callable[[tuple[float, float, float], Any, Any], Sequence[float]]:
        """`add` as one call for a caller that adds every scan (a coupled run): with the
        compiled samples, a function that has their arguments at hand (not looked up per
        scan); else `add`."""
        trace = self._trace
        if trace is None or trace[0] is _PY_SAMPLES:
            return self.add
        fn, G, sf, rho_d, guess, out, near_k = trace  # (fn built at the first call)
        row, near_list, count = out.tolist, near_k.tolist, self.count
        log = self  # (its samples: `spill_to` replaces them)

        def add(leader: tuple[float, float, float], xs: Any, ys: Any) -> Sequence[float]:
            nonlocal fn
            if fn is None:
                fn = log._compiled()[0]
            xl, yl, _ = leader
            if type(xs) is not np.ndarray:
                xs, ys = np.array(xs, dtype=float), np.array(ys, dtype=float)
            fn(G, sf, xs, ys, xl, yl, rho_d, guess, out, near_k)
            samples = log.samples
            samples.buf += row()
            samples.full()  # (a chunk's worth to the file)
            near: list[float] = near_list()
            count(near)
            return near

        return add

    def fuse(self, world: Any) -> Callable[[Sequence[list[float]]], Sequence[float]] | None:
        """`adder` made in ``world``'s scans (`rtsim.world.world.World.log_truth`: the
        samples and closest approaches in the scan's compiled call, from the truth it has at
        hand), for a caller that adds every scan from before the first: a function of the
        scan's float rows (`World.scan_rows`) that adds them as `add` would and returns the
        closest approaches; None where the world does not make them (the caller adds with
        `adder`). Call it before ``world``'s first scan."""
        trace, law = self._trace, self._law
        if trace is None or trace[0] is _PY_SAMPLES:
            return None
        sf = world.log_truth(law, trace[3], trace[4])
        if sf is None:
            return None
        law._sf = sf  # type: ignore[union-attr]  # (the scan's from now on)
        self._trace = (trace[0], trace[1], sf, *trace[3:])
        count = self.count
        log = self  # (its samples: `spill_to` replaces them)

        def put(rows: Sequence[list[float]]) -> Sequence[float]:
            samples = log.samples
            buf = samples.buf
            buf += rows[LOG_ROW]  # (the samples in follower order over two rows)
            buf += rows[LOG_ROW + 1]
            if len(buf) >= samples.limit:  # (`ValueSpill.full`: a chunk's worth to the file)
                samples.flush()
            near = rows[NEAR_ROW]
            count(near)
            return near

        return put

    def spill_to(self, path: Any, label: Any = None) -> None:
        """Keep the samples in the scratch file ``path`` from now on (before the first
        scan; removed by `close`): memory stays flat however long the run."""
        assert not self.samples.rows and not self.samples.buf, "spill_to after a scan"
        self.samples.close()
        self.samples = ValueSpill(self.samples.width, path, label)

    def close(self) -> None:
        """Remove the scratch file and its samples (samples kept in memory stay)."""
        if self.samples.path is not None:
            self.samples.close()

    def _stats(self, part: int) -> tuple[Stats, list[Stats]]:
        """`p95_max_rows` of the samples' separation errors (``part`` 0) or cross-track
        distances (1), selected from the chunks (`rtsim.coupling.spill.p95_max_columns`)."""
        step = self.samples.width // self.n
        return p95_max_columns(lambda: (c[:, part::step] for c in self.samples.chunks()), self.n)

    @property
    def sep(self) -> list[np.ndarray]:
        """Each follower's separation errors (cm), whole (tests; memory grows with them)."""
        return self.samples.columns()[0 :: self.samples.width // self.n]

    @property
    def cross(self) -> list[np.ndarray]:
        """Each follower's cross-track distances (cm), whole; empty without a trace law."""
        if self._law is None:
            return [np.zeros(0) for _ in range(self.n)]
        return self.samples.columns()[1::2]

    def summary(self, leader_cm: float, follower_cm: list[float]) -> dict[str, Any]:
        """The summary.json keys (module docstring); ``leader_cm``, ``follower_cm``: the
        distance each robot drove."""
        self.samples.flush()
        every_sep, sep = self._stats(0)
        if self._law is None:
            every_cross, cross = p95_max_rows([[] for _ in range(self.n)])
        else:
            every_cross, cross = self._stats(1)
        return {
            "cross_track_cm": every_cross,
            "separation_error_cm": every_sep,
            "min_robot_distance_cm": None if math.isinf(self.min_dist) else self.min_dist,
            "collisions": int(self.collisions),
            "clearance_cm": self.clearance,
            "clearance_violations": int(self.clearance_violations),
            "distance_cm": {
                "leader": float(leader_cm),
                "followers": [float(d) for d in follower_cm],
            },
            "per_follower": [
                {
                    "cross_track_cm": cross[k],
                    "separation_error_cm": sep[k],
                    "distance_cm": float(follower_cm[k]),
                }
                for k in range(self.n)
            ],
        }
