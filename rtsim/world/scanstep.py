"""The leader's scan in one compiled call: the ``compiled`` backend's `World.scan` with the
``hough`` localization model (docs/performance.md).

The per-follower arithmetic of a scan is written here once, as kernel sources
(`rtsim.world.jit`) that the Python reference (`rtsim.world.world.World._changes`,
`World._to_leader`) runs as Python (`PY`: their twins with ``math.hypot`` and
``math.remainder``) and that `scan_step` compiles:

- `to_leader_xy`: a point in the leader's frame;
- `truth_change`: a follower's range and bearing, and the truth's change since the previous
  scan (displacement, Δρ, odometer travel, Δβ);
- `bound_violations`: whether that change exceeds each bound kind's threshold;
- `fix_error`: a fix's distance from the truth.

`scan_step` composes them with the laser (`rtsim.world.rangefinder.scan_points`), the
predicted window centres (`rtsim.world.estimates.carry_row`), the Hough windows
(`rtsim.world.hough.locate_all`) and each window's outcome (`rtsim.world.hough.peak_fix`):
one call per scan fills the columns `FusedScan` hands to `World` as lists and, asked for
(`World.scan_estimate`), runs the estimate on the fixes too (`rtsim.world.estimates.est_scan`).
The rare window without a fix is searched for in Python afterwards (the model's own
``_search``), as the reference does, and the estimate then made by a second call.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rtsim.model.window import LASER_POINTS
from rtsim.world.estimates import carry_row, est_scan, new_estimates
from rtsim.world.exactmath import HYPOT_SUBS, cpython_hypot, cpython_remainder
from rtsim.world.hough import _dummy, locate_all, peak_fix
from rtsim.world.jit import build, kernel, specialise
from rtsim.world.kernels import built_entry
from rtsim.world.motion import GTH, GV
from rtsim.world.normals import standard_normals
from rtsim.world.rangefinder import BEAM_COS, BEAM_SIN, scan_points
from rtsim.world.tracelog import trace_samples

__all__ = [
    "FLOAT_ROWS",
    "FLAG_ROWS",
    "LOG_ROW",
    "NEAR_ROW",
    "TRUTH_ROW",
    "PY",
    "FusedFields",
    "FusedScan",
    "bound_violations",
    "fix_error",
    "scan_step",
    "to_leader_xy",
    "truth_change",
    "warm",
]

TWO_PI = 2 * math.pi

Array = NDArray[np.float64]

#: `scan_step`'s float columns (one row of ``T`` each, one entry per follower): the scan's,
#: then the followers' truth in the world's frame (x, y, heading, speed: copies of the
#: state's rows), then the truth log's (`rtsim.world.tracelog.trace_samples`, when the
#: world makes them, `FusedScan.log_truth`): its samples, 2 a follower in follower order
#: over the two rows ``log`` and ``log_2`` read as one, and each follower's closest approach
FLOAT_ROWS = (
    "tx", "ty", "cx", "cy", "mx", "my", "error",
    "rho", "beta", "displacement", "d_rho", "travel", "d_beta",
    "x", "y", "th", "v", "log", "log_2", "near",
)  # fmt: skip
#: ``T``'s rows
FLOAT_COUNT = len(FLOAT_ROWS)
#: where the truth's rows begin (x, y, th, v), the log's samples' and the closest approaches'
TRUTH_ROW, LOG_ROW, NEAR_ROW = (FLOAT_ROWS.index(r) for r in ("x", "log", "near"))
#: its flag columns (``B``): in the window, lost, lost to a neighbour's points, no fix in
#: the window (searched for in Python), then the four bound kinds' violations
FLAG_ROWS = (
    "in_window", "lost", "neighbour", "unfixed",
    "localization", "separation", "path_diversion", "bearing",
)  # fmt: skip


@kernel
def to_leader_xy(
    xl: float, yl: float, c: float, s: float, a: float, b: float
) -> tuple[float, float]:
    """Point (``a``, ``b``) in the frame of the leader at (``xl``, ``yl``) whose heading has
    cosine ``c`` and sine ``s``."""
    dx, dy = a - xl, b - yl
    return c * dx + s * dy, -s * dx + c * dy


@kernel
def truth_change(
    tx: float, ty: float, odo: float, px: float, py: float, p_rho: float, p_beta: float,
    p_odo: float, first: bool,
) -> tuple[float, float, float, float, float, float]:  # fmt: skip
    """A follower at (``tx``, ``ty``) in the leader's frame with odometer ``odo``, which was at
    (``px``, ``py``), range ``p_rho``, bearing ``p_beta`` and odometer ``p_odo`` at the previous
    scan: its range ρ, bearing β ∈ [0, 2π), and the change since (displacement in the
    leader's frame, |Δρ|, travel, |Δβ| wrapped to [0, π]; zeros at the ``first`` scan)."""
    rho = cpython_hypot(tx, ty)
    beta = math.atan2(ty, tx) % TWO_PI
    if first:
        return rho, beta, 0.0, 0.0, 0.0, 0.0
    disp = cpython_hypot(tx - px, ty - py)
    d_rho = abs(rho - p_rho)
    travel = odo - p_odo
    d_beta = abs(cpython_remainder(beta - p_beta, TWO_PI))
    return rho, beta, disp, d_rho, travel, d_beta


@kernel
def bound_violations(
    disp: float, d_rho: float, travel: float, d_beta: float, r_H: float, sep: float,
    trav: float, T_beta: float,
) -> tuple[bool, bool, bool, bool]:  # fmt: skip
    """Whether the truth's change (`truth_change`) violates the localization (``r_H``),
    separation (``sep``), path-diversion (``trav``) and bearing (``T_beta``) bounds."""
    return disp > r_H, d_rho > sep, travel > trav, d_beta > T_beta


@kernel
def fix_error(mx: float, my: float, tx: float, ty: float) -> float:
    """A fix's distance from the truth (cm)."""
    return cpython_hypot(mx - tx, my - ty)


@kernel
def math_remainder(x: float, y: float) -> float:
    """``math.remainder`` (the plain-Python twin's `cpython_remainder`)."""
    return math.remainder(x, y)


_PY_SUBS = (*HYPOT_SUBS, (cpython_remainder, math_remainder))
#: the Python twins the reference runs (the interpreter's hypot and remainder)
PY = {
    fn.__name__: specialise(fn, _PY_SUBS)
    for fn in (to_leader_xy, truth_change, bound_violations, fix_error)
}


@kernel
def buffer_views(FB: Any, IB: Any) -> tuple[Any, ...]:
    """`scan_step`'s buffers as views of one float array ``FB`` and one integer array ``IB``
    (`FusedScan`: numba unboxes two arrays at a call, not nineteen), ``IB`` beginning with
    the lengths: the followers n, the ring's steps, the accumulator's word and its into,
    the trace's arc lengths and segments, then whether the scan makes the truth log's
    samples (1) or not (0). From ``FB``: the normals z, the beams' cos and sin, px, py
    (`LASER_POINTS` each), ``P`` (5, n), the separation and travel limits (n each), ``T``
    (`FLOAT_ROWS`, n), ``F`` (n, 3), the ring's x and y steps, then the truth log's: its
    projections' arc lengths, ρ_d and first guesses (n each) and the law's geometry ``G``
    (`rtsim.world.path.geometry_arrays`: the arc lengths, the segments, the lap, three a
    follower); from ``IB``: the beams' owner, the counts (n), the accumulator's word, tally
    (n), state (1) and into, ``N`` (2, n). The truth log's ``trace`` = (``G``, arc lengths,
    ρ_d, guesses, samples: ``T``'s rows `LOG_ROW` and the next as one) and its flag last."""
    n, nr, nw, ni, ns, ng = IB[0], IB[1], IB[2], IB[3], IB[4], IB[5]
    L = LASER_POINTS
    z, cos_b, sin_b = FB[:L], FB[L : 2 * L], FB[2 * L : 3 * L]
    px, py = FB[3 * L : 4 * L], FB[4 * L : 5 * L]
    o = 5 * L
    P = FB[o : o + 5 * n].reshape((5, n))
    o += 5 * n
    sep, trav = FB[o : o + n], FB[o + n : o + 2 * n]
    o += 2 * n
    T = FB[o : o + FLOAT_COUNT * n].reshape((FLOAT_COUNT, n))
    log = FB[o + LOG_ROW * n : o + (LOG_ROW + 2) * n]  # (T's rows LOG_ROW and the next)
    o += FLOAT_COUNT * n
    F = FB[o : o + 3 * n].reshape((n, 3))
    o += 3 * n
    rx, ry = FB[o : o + nr], FB[o + nr : o + 2 * nr]
    o += 2 * nr
    sf, rho_d, guess = FB[o : o + n], FB[o + n : o + 2 * n], FB[o + 2 * n : o + 3 * n]
    o += 3 * n
    s0, seg = FB[o : o + ns], FB[o + ns : o + ns + ng]
    o += ns + ng
    trace = ((s0, seg, FB[o], FB[o + 1 : o + 1 + 3 * n]), sf, rho_d, guess, log)
    j = 7
    owner, counts = IB[j : j + L], IB[j + L : j + L + n]
    j += L + n
    word, tally, state = IB[j : j + nw], IB[j + nw : j + nw + n], IB[j + nw + n : j + nw + n + 1]
    j += nw + n + 1
    into = IB[j : j + ni]
    j += ni
    N = IB[j : j + 2 * n].reshape((2, n))
    return (
        z, cos_b, sin_b, px, py, P, sep, trav, T, F, rx, ry, owner, counts, word, tally,
        state, into, N, trace, IB[6],
    )  # fmt: skip


def buffer_sizes(n: int, nr: int, nw: int, ni: int, ns: int = 0, ng: int = 0) -> tuple[int, int]:
    """The lengths of `buffer_views`' ``FB`` and ``IB`` for n followers, a ring of ``nr``
    steps, a word of ``nw``, an into of ``ni`` and a trace of ``ns`` arc lengths and ``ng``
    segments' numbers."""
    floats = 5 * LASER_POINTS + (16 + FLOAT_COUNT) * n + 2 * nr + ns + ng + 1
    return floats, 7 + LASER_POINTS + 4 * n + nw + 1 + ni


@kernel
def scan_step(
    W: Any, xl: float, yl: float, hl: float, E: Any, t: float, a: float, predicted: bool,
    first: bool, mode: int, var: float, track: bool, FB: Any, IB: Any, B: Any, windows: Any,
    G: Any, laser: Any, hough: Any, ekf: Any,
) -> float:  # fmt: skip
    """One scan (module docstring) of the followers whose truth is ``W`` (rows x, y,
    odometer, heading, speed: the state's, `rtsim.world.motion.GROUP_ROWS`) seen by the
    leader at (``xl``, ``yl``, ``hl``), on the buffers of ``FB`` and ``IB``
    (`buffer_views`): ``laser`` = (r_F, max range, range σ, T_β) with the standard normals
    z (drawn into it first from the PCG64 whose state is ``G``, `rtsim.world.normals`,
    unless ``G`` is empty), into the beams' px, py, owner, counts;
    the window centres carried from the estimates ``E`` to ``t`` ms (acceleration limit
    ``a``) when ``predicted``, else ``T``'s rows cx, cy as given; ``hough`` = (r_H, cell,
    cells, min_points) with the accumulator's work into ``windows``; the previous scan's
    ``P`` (rows x, y, ρ, β, odometer; written with this scan's; ignored at the ``first``)
    and the separation and travel limits per follower. Fills ``T`` (`FLOAT_ROWS`: the truth's
    rows copied from ``W``; the truth log's samples when ``IB`` asks, `buffer_views`), ``B``
    (`FLAG_ROWS`), ``N`` (beams returned, points that voted) and ``F`` (per follower mx,
    my, 1 in its window else 0: `est_scan`'s fixes). ``mode`` 0: the scan alone, returns
    −1; 1: then, when every window has its fix, `World.estimate` with them (`est_scan` on
    ``E`` at ``t`` with ``ekf`` = (a, σ_v², σ_ω², q_p², q_θ², r), the heading variance's max
    so far ``var``, ``track``), returning its result (else −1: the caller searches and asks
    for mode 2); 2: `est_scan` with ``F`` as given, alone. The arguments from ``FB`` on are
    the same at every call of a world (`FusedScan`: one tuple)."""
    ea, sv2, sw2, qp2, qh2, r = ekf
    (
        z, cos_b, sin_b, px, py, P, sep, trav, T, F, rx, ry, owner, counts, word, tally,
        state, into, N, trace, logged,
    ) = buffer_views(FB, IB)  # fmt: skip
    if mode == 2:
        return est_scan(E, F, t, ea, sv2, sw2, qp2, qh2, r, xl, yl, hl, var, track)
    n = W.shape[1]
    c, s = math.cos(hl), math.sin(hl)
    for k in range(n):
        T[0, k], T[1, k] = to_leader_xy(xl, yl, c, s, W[0, k], W[1, k])
        if predicted:
            x, y, _, _, _ = carry_row(E, k, t, a)
            T[2, k], T[3, k] = to_leader_xy(xl, yl, c, s, x, y)
    r_F, max_range, range_sd, T_beta = laser
    if G.shape[0] != 0:
        standard_normals(G, z, z.shape[0])
    scan_points(T[0], T[1], r_F, max_range, range_sd, z, cos_b, sin_b, px, py, owner, counts)
    r_H, cell, cells, min_pts = hough
    work = (rx, ry, word, tally, state, into)
    locate_all(px, py, owner, T[2], T[3], r_H, r_F, cell, cells, work, windows)
    for k in range(n):
        tx, ty = T[0, k], T[1, k]
        rec = windows[k]
        N[0, k] = counts[k]
        N[1, k] = rec["voters"]
        found, neighbour = peak_fix(rec["votes"], rec["owner"], k, min_pts)
        if found:
            mx, my = rec["fix_x"], rec["fix_y"]
            T[6, k] = fix_error(mx, my, tx, ty)
            F[k, 2] = 1.0
        else:  # (the centre, until the search in Python)
            mx, my = T[2, k], T[3, k]
            T[6, k] = math.inf
            F[k, 2] = 0.0
        T[4, k], T[5, k] = mx, my
        F[k, 0], F[k, 1] = mx, my
        B[0, k], B[1, k], B[2, k], B[3, k] = found, neighbour or not found, neighbour, not found
        odo = W[2, k]
        rho, beta, disp, d_rho, travel, d_beta = truth_change(
            tx, ty, odo, P[0, k], P[1, k], P[2, k], P[3, k], P[4, k], first
        )
        T[7, k], T[8, k], T[9, k], T[10, k], T[11, k], T[12, k] = (
            rho, beta, disp, d_rho, travel, d_beta,
        )  # fmt: skip
        B[4, k], B[5, k], B[6, k], B[7, k] = bound_violations(
            disp, d_rho, travel, d_beta, r_H, sep[k], trav[k], T_beta
        )
        P[0, k], P[1, k], P[2, k], P[3, k], P[4, k] = tx, ty, rho, beta, odo
        i = TRUTH_ROW
        T[i, k], T[i + 1, k], T[i + 2, k], T[i + 3, k] = W[0, k], W[1, k], W[GTH, k], W[GV, k]
    if logged:  # (the truth log's samples: `FusedScan.log_truth`)
        geom, sf, rho_d, guess, log = trace
        trace_samples(geom, sf, W[0], W[1], xl, yl, rho_d, guess, log, T[NEAR_ROW])
    if mode == 1:
        for k in range(n):
            if B[3, k]:
                return -1.0
        return est_scan(E, F, t, ea, sv2, sw2, qp2, qh2, r, xl, yl, hl, var, track)
    return -1.0


def _arguments(
    n: int, E: Any, windows: Any, ring: int, word: int, into: int, ns: int = 0, ng: int = 0
) -> Any:
    """Arguments of `scan_step`'s types at every call for ``n`` followers (zeros, but for
    ``E``, ``windows`` and the lengths at the head of ``IB``, the trace's ``ns`` and ``ng``
    included, `buffer_views`): the ones that change per call, then the fixed ones (``FB``,
    ``IB``, ``B``, ``windows``, ``G``, laser, hough, ekf)."""
    x = 0.0
    nf, ni = buffer_sizes(n, ring, word, into, ns, ng)
    IB = np.zeros(ni, dtype=np.int64)
    IB[:6] = n, ring, word, into, ns, ng
    B = np.zeros((len(FLAG_ROWS), n), dtype=np.bool_)
    each = (np.zeros((GV + 1, n)), x, x, x, E, x, x, True, True, 0, x, True)
    G = np.zeros(0, dtype=np.uint64)
    fixed = (np.zeros(nf), IB, B, windows, G, (x,) * 4, (x, x, 0, 0), (x,) * 6)
    return each, fixed


def warm() -> None:
    """Compile `scan_step` (the unicycle's) or load it from the cache, without running it:
    for a pool's parent (`rtsim.control.kernels.warm_all`)."""
    dummy = _dummy(every=True)  # (the accumulator's work and records)
    work = dummy[9]
    each, fixed = _arguments(
        1, new_estimates(1), dummy[10], work[0].size, work[2].size, work[5].size
    )
    built_entry(build(scan_step), (*each, *fixed))


class FusedFields(dict[str, Any]):
    """A fused scan's fields for its `rtsim.world.scan.Scan` (``_raw``): the columns
    `scan_step` gives as lists, with ``T`` its float columns (`FLOAT_ROWS`, lists) from which
    the pairs a reader seldom asks for — ``truth``, ``centre``, ``measured`` — are zipped on
    their first read."""

    __slots__ = ("T",)
    T: list[list[float]]

    #: a pair field's rows of ``T`` (`FLOAT_ROWS`)
    PAIRS = {"truth": (0, 1), "centre": (2, 3), "measured": (4, 5)}

    def __missing__(self, name: str) -> list[tuple[float, float]]:
        i, j = self.PAIRS[name]
        T = self.T
        value = list(zip(T[i], T[j], strict=True))
        self[name] = value
        return value


class FusedScan:
    """A world's buffers for `scan_step` and its compiled entry (``motion``: the motion
    model whose parts carry the estimates). ``model``: the world's `HoughModel`, whose
    rangefinder's and accumulator's buffers become views of the kernel's (`buffer_views`);
    ``limits``: the separation and travel limits per follower, lists; ``T_beta``; ``pcg``:
    the world's PCG64 state (`rtsim.world.normals`), from which the kernel draws each
    scan's normals into `z` (None: the caller passes them); ``geometry``: the world's
    follow-the-leader law's (`rtsim.world.path.geometry_arrays`; None: none), copied in for
    the truth log's samples (`log_truth`)."""

    def __init__(
        self,
        model: Any,
        n: int,
        motion: Any,
        E: NDArray[np.float64],
        limits: tuple[list[float], list[float]],
        T_beta: float,
        pcg: NDArray[np.uint64] | None = None,
        geometry: tuple[Any, ...] | None = None,
    ) -> None:
        config = model.config
        rf, acc = model.rangefinder, model.accumulator
        r_H = config.thresholds.r_H
        nr, nw, ni = acc.ring_x.size, acc.word.size, acc.into.size
        self.windows = acc.out
        s0, seg, lap, fol = geometry or (np.zeros(0), np.zeros(0), 0.0, np.zeros(3 * n))
        each, fixed = _arguments(n, E, self.windows, nr, nw, ni, s0.size, seg.size)
        FB, IB = fixed[0], fixed[1]
        ring = (acc.ring_x, acc.ring_y)
        (
            self.z, cos_b, sin_b, rf.px, rf.py, self.P, sep, trav, self.T, self.F,
            acc.ring_x, acc.ring_y, rf.owner, rf.counts, acc.word, acc.tally, acc.state,
            acc.into, self.N, trace, _,
        ) = buffer_views(FB, IB)  # fmt: skip
        G, self._sf, self._rho_d, self._guess, _ = trace
        G[0][:], G[1][:], G[3][:] = s0, seg, fol
        FB[FB.size - 3 * n - 1] = lap  # (G's lap: between its segments and its last array)
        self._geometry = geometry
        cos_b[:], sin_b[:] = BEAM_COS, BEAM_SIN
        acc.ring_x[:], acc.ring_y[:] = ring
        acc.work = (acc.ring_x, acc.ring_y, acc.word, acc.tally, acc.state, acc.into)
        sep[:], trav[:] = limits
        self.B: NDArray[np.bool_] = fixed[2]
        self.G: NDArray[np.uint64] = fixed[4] if pcg is None else pcg
        self.laser = (rf.r_F, rf.max_range, rf.range_sd, float(T_beta))
        self.hough = (float(r_H), acc.cell, acc.cells(r_H), int(config.sensing.min_points))
        self.first = True
        self._step = built_entry(build(scan_step, motion.subs), (*each, *fixed))
        self._FB, self._IB = FB, IB
        self.ekf = fixed[-1]

    def log_truth(self, geometry: Any, sf: Any, rho_d: Any, guess: Any) -> Any:
        """Make the truth log's samples in every scan from now on (`scan_step`; ``T``'s
        rows `LOG_ROW` on, `FLOAT_ROWS`) for a log whose law has ``geometry`` (the one this
        scan was made with, the same object, else nothing is made: returns None) and the
        projections' arc lengths ``sf`` (copied in), with ρ_d and the first guesses per
        follower: returns the scan's arc lengths (a view: the log's state from now on)."""
        if geometry is not self._geometry:
            return None
        self._sf[:], self._rho_d[:], self._guess[:] = sf, rho_d, guess
        self._IB[6] = 1
        return self._sf

    @property
    def ekf(self) -> tuple[float, ...]:
        """`scan_step`'s EKF constants (`CompiledEstimates.ekf_args`), set by the world."""
        return self._fixed[-1]  # type: ignore[no-any-return]

    @ekf.setter
    def ekf(self, value: tuple[float, ...]) -> None:
        #: `scan_step`'s arguments that are the same at every call, with ``value``
        self._fixed: tuple[Any, ...] = (
            self._FB, self._IB, self.B, self.windows, self.G, self.laser, self.hough, value,
        )  # fmt: skip

    def run(
        self,
        W: NDArray[np.float64],
        lp: tuple[float, float, float],
        z: NDArray[np.float64] | None,
        E: NDArray[np.float64],
        t: float,
        a: float,
        predicted: bool,
        mode: int = 0,
        var: float = 0.0,
        track: bool = False,
    ) -> float:
        """`scan_step` on these buffers (the previous scan's state kept between calls) in
        ``mode`` (0: the scan; 1: the scan and, every window fixed, the estimate; 2: the
        estimate alone) with the heading variance's max ``var``, ``track``: the estimate's
        result, or −1 when none was made. ``z``: the scan's normals, copied into `z` (None:
        the kernel draws them there from ``pcg``)."""
        xl, yl, hl = lp
        if z is not None:
            self.z[:] = z
        out: float = self._step(
            W, xl, yl, hl, E, t, a, predicted, self.first, mode, var, track, *self._fixed
        )  # fmt: skip
        if mode != 2:
            self.first = False
        return out
