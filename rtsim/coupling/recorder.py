"""Per-window records of a coupled run, turned into the ``windows.csv`` table once.

The schema is pinned in ``docs/outputs.md`` (other modules plot and validate against
it): one row per processing window, window-level columns first, then per follower i (1-based)
the truth at the scan (``f{i}_x`` … ``f{i}_v``), the leader's estimate that the decision used
(the same names with ``_est``), every bound as the decision's belief and as the truth
(``f{i}_msb_{bound}_pred``, ``f{i}_msb_{bound}_true``, `true_bounds`), and the
violations observed on the truth between this window's scan and the next (``f{i}_viol_*``)
with ``f{i}_lost``, and last the contact columns (`CONTACT_FIELDS`). No empty cells: an
unbounded value is ``inf``; booleans are ``True``/``False``.

During the run the coupling fills one [`WindowRecord`][rtsim.coupling.recorder.WindowRecord] per
window (plain Python and small
numpy arrays); [`WindowRecorder.frame`][rtsim.coupling.recorder.WindowRecorder.frame] builds the
DataFrame in one pass with a fixed
column order and dtypes. With a ``sink``, every `CHUNK_WINDOWS` windows the complete
records at the front are handed to it and dropped (a record is complete once the next scan
has closed its violation interval, and never changes after), so a long run keeps about two
chunks of records in memory; `records_frame` turns a chunk into its rows of the table.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from itertools import chain, compress, repeat
from operator import attrgetter, is_, itemgetter
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from rtsim.analysis.kinematics import BOUND_KINDS, relative_state, relative_states_of
from rtsim.sim.records import EPS
from rtsim.world.localization import LOST_CAUSES
from rtsim.world.scanstep import FLOAT_ROWS

_chain = chain.from_iterable

__all__ = [
    "BOUND_FIELDS",
    "CHANGE_KEYS",
    "CONTACT_FIELDS",
    "CHUNK_WINDOWS",
    "WINDOW_COLUMNS",
    "FOLLOWER_FIELDS",
    "LOCALIZATION_COLUMNS",
    "ScanChanges",
    "ScanRows",
    "StateRows",
    "VIOLATION_FIELDS",
    "WindowRecord",
    "WindowRecorder",
    "changes_array",
    "contact_columns",
    "records_columns",
    "records_frame",
    "SENSING_FIELDS",
    "sensing_columns",
    "true_bounds",
    "window_columns",
]

#: Window records per chunk handed to a [`WindowRecorder`][rtsim.coupling.recorder.WindowRecorder]'s
#: sink.
CHUNK_WINDOWS = 1024

#: Window-level columns, in order (docs/outputs.md).
WINDOW_COLUMNS: tuple[str, ...] = (
    "window",
    "t",
    "w",
    "deadline",
    "w_sch",
    "msb_min",
    "binding",
    "margin",
    "slack",
    "v_leader_desired",
    "v_leader",
    "v_leader_target",
    "v_leader_max",
    "method",
    "feasible",
    "critical",
    "missed",
    "response",
    "finish",
    "points",
    "hough_ms",
    "tracks_lost",
    "segment",
    "curvature",
    "leader_x",
    "leader_y",
    "leader_heading",
)
#: Lost tracks by cause (``tracks_lost`` is their sum), the searches charged and the
#: followers they re-acquired: the last columns of windows.csv.
LOCALIZATION_COLUMNS: tuple[str, ...] = (
    *(f"tracks_lost_{c}" for c in LOST_CAUSES),
    "searches",
    "reacquisitions",
    "confusions",
    "radio_ms",
    "radio_losses",
)
#: Per-follower sensing columns, after `LOCALIZATION_COLUMNS`: the scan points that
#: voted in its window (``hough``; the beams it returned with ``gaussian``), the accepted
#: fix's distance from the truth (cm, inf: no fix), whether a neighbour's points made it.
SENSING_FIELDS: tuple[str, ...] = ("points", "fix_error_cm", "neighbour")
#: Per-follower contact columns, the last of windows.csv (`rtsim.world.contact`): the
#: closest approach to any other robot (leader included, centres, cm) that the window's
#: decision predicted (``_pred``) and that the truth showed at the window's scan and the
#: next (``_true``), and whether the truth came closer than 2·r_F + clearance.
CONTACT_FIELDS: tuple[str, ...] = ("contact_cm_pred", "contact_cm_true", "viol_contact")
#: Per-follower state columns (truth; the estimate adds ``_est``), in order.
FOLLOWER_FIELDS: tuple[str, ...] = ("x", "y", "heading", "rho", "beta", "theta", "v")
#: Per-follower bound columns, in order: the decision's prediction, then the truth.
BOUND_FIELDS: tuple[str, ...] = (
    *(f"msb_{k}_pred" for k in BOUND_KINDS),
    *(f"msb_{k}_true" for k in BOUND_KINDS),
)
#: The observed change (``Scan.changes`` key) that each bound kind limits, in
#: `BOUND_KINDS` order (docs/model/world.md): relative
# displacement (r_H),
#: |Δρ| (T_ρ·ρ_d), distance travelled (T_ε·ρ_d), |Δβ| (T_β).
CHANGE_KEYS: tuple[str, ...] = ("displacement", "d_rho", "travel", "d_beta")
#: Per-follower violation columns, in order (``lost`` last).
VIOLATION_FIELDS: tuple[str, ...] = (*(f"viol_{k}" for k in BOUND_KINDS), "lost")


def window_columns(n: int) -> list[str]:
    """Every column of windows.csv for ``n`` followers, in order."""
    return list(_window_columns(n))


@functools.lru_cache(maxsize=16)
def _window_columns(n: int) -> tuple[str, ...]:
    """`window_columns` of ``n``, made once per process (`records_columns` at every call)."""
    cols = list(WINDOW_COLUMNS)
    cols += [f"f{i}_{f}" for i in range(1, n + 1) for f in FOLLOWER_FIELDS]
    cols += [f"f{i}_{f}_est" for i in range(1, n + 1) for f in FOLLOWER_FIELDS]
    cols += [f"f{i}_{f}" for i in range(1, n + 1) for f in BOUND_FIELDS]
    cols += [f"f{i}_{f}" for i in range(1, n + 1) for f in VIOLATION_FIELDS]
    cols.append("assumption_broken")  # the scan counted more than Eq 1's min(361, k·n)
    cols += list(LOCALIZATION_COLUMNS)
    cols += sensing_columns(n)
    cols += contact_columns(n)
    return tuple(cols)


def contact_columns(n: int) -> list[str]:
    """The per-follower contact columns of windows.csv (`CONTACT_FIELDS`), in order."""
    return [f"f{i}_{f}" for i in range(1, n + 1) for f in CONTACT_FIELDS]


def sensing_columns(n: int) -> list[str]:
    """The per-follower sensing columns of windows.csv (`SENSING_FIELDS`), in order."""
    return [f"f{i}_{f}" for i in range(1, n + 1) for f in SENSING_FIELDS]


def true_bounds(
    w: NDArray[np.float64], change: NDArray[np.float64], limit: NDArray[np.float64] | float
) -> NDArray[np.float64]:
    """The bound the truth showed over a window (ms): ``limit·w / change``, ``inf`` where
    nothing changed.

    ``change`` is what the world observed between the window's scan and the next
    (docs/model/world.md),
    ``limit`` the bound's threshold (r_H, T_ρ·ρ_d, T_ε·ρ_d or T_β). It is the bound of
    Eqs 19–21 (and the bearing bound) with the rate replaced by the window's average rate
    change / w, so ``true < w`` exactly when ``change > limit``, i.e. when the window broke
    the bound (the ``viol`` columns).
    """
    w = np.asarray(w, dtype=float)
    change = np.asarray(change, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(change > 0.0, (np.asarray(limit, dtype=float) * w) / change, np.inf)
    return out


class StateRows(Sequence[tuple[float, ...]]):
    """n rows of 7 floats in `FOLLOWER_FIELDS` order, (x, y, θ, ρ, β, θ_L − θ_F, V_F) per
    follower, from the leader's pose and each follower's pose and speed; the relative
    state (`relative_state`) is computed when the rows are first read (the windows table,
    or a policy's `FollowerEstimate`), not per window: a sweep point's tables never read
    them. Iterates and indexes as the tuple of rows it stands for.

    ``poses``: (x, y, θ) per follower, and ``speeds`` their V_F (iterables the caller no
    longer changes, read once); or ``poses`` a float array whose rows ``speeds`` (an int)
    to ``speeds`` + 3 are the followers' x, y, θ and V_F (a copy of the scan's kernel rows,
    `rtsim.world.scanstep.FLOAT_ROWS`, or the decision's pack transposed: one object a
    record instead of the rows' lists); or
    with ``speeds`` None, ``poses`` a row per follower whose first four values are x, y, θ
    and V_F (the estimates' rows as the decision read them, kept as they are)."""

    __slots__ = ("_lp", "_poses", "_speeds", "_rows")

    def __init__(self, lp: tuple[float, float, float], poses: Any, speeds: Any) -> None:
        self._lp, self._poses, self._speeds = lp, poses, speeds
        self._rows: tuple[tuple[float, ...], ...] | None = None

    def rows(self) -> tuple[tuple[float, ...], ...]:
        """The rows as a tuple (made once)."""
        out = self._rows
        if out is None:
            lp = self._lp
            poses, speeds = self._poses, self._speeds
            if type(speeds) is int:  # (the array's rows: their floats, as lists)
                x, y, th, speeds = poses[speeds : speeds + 4].tolist()
                poses = zip(x, y, th, strict=True)
            elif speeds is None:  # (rows of x, y, θ, V_F, ...)
                poses, speeds = list(map(_POSE_OF, poses)), list(map(_SPEED_OF, poses))
            out = self._rows = tuple(
                [
                    (*pose, *relative_state(lp, pose), v)
                    for pose, v in zip(poses, speeds, strict=True)
                ]
            )
            self._poses = self._speeds = ()
        return out

    def __iter__(self) -> Iterator[tuple[float, ...]]:
        return iter(self.rows())

    def __len__(self) -> int:
        return len(self.rows())

    def __getitem__(self, k: Any) -> Any:
        return self.rows()[k]

    def __eq__(self, other: object) -> bool:
        if isinstance(other, StateRows):
            other = other.rows()
        return self.rows() == other

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"StateRows({self.rows()!r})"


class ScanRows(Mapping[str, Any]):
    """A record's per-follower values by key, read from a copy of the fused scan's rows
    (``rows``: `KEYS`' rows from `AT` on, each key's row an array of one value per
    follower): one object a record instead of a dict of lists, and the table reads every
    record's rows in one pass (`changes_array`)."""

    __slots__ = ("rows",)
    #: the keys, in order, and where their rows begin
    KEYS: tuple[str, ...] = ()
    AT = 0

    def __init__(self, rows: NDArray[Any]) -> None:
        self.rows = rows

    def __getitem__(self, key: str) -> NDArray[Any]:
        try:
            return self.rows[self.AT + self.KEYS.index(key)]
        except ValueError:
            raise KeyError(key) from None

    def __iter__(self) -> Iterator[str]:
        return iter(self.KEYS)

    def __len__(self) -> int:
        return len(self.KEYS)


class ScanChanges(ScanRows):
    """A record's observed changes (`CHANGE_KEYS` → each follower's, as ``Scan.changes``)
    in a copy of the fused scan's float rows (`rtsim.world.scanstep.FLOAT_ROWS`)."""

    __slots__ = ()
    KEYS = CHANGE_KEYS
    AT = FLOAT_ROWS.index(CHANGE_KEYS[0])


assert FLOAT_ROWS[ScanChanges.AT :][: len(CHANGE_KEYS)] == CHANGE_KEYS


@dataclass(slots=True)
class WindowRecord:
    """One window, filled in stages: at its release (the decision that governs it), at its
    scan (truth, points, lost tracks), when the Hough time is known, at its completion
    (``finish``), and at the next scan (``viol``).

    ``truth`` and ``est`` are n rows of 7 floats in `FOLLOWER_FIELDS` order (tuples,
    an (n, 7) array or `StateRows`); ``pred`` n rows of the decision's four bounds (ms,
    BOUND_KINDS order) at ``v_leader_max``, the highest speed the leader had between this
    window's scan and the next; ``viol`` maps each of `BOUND_KINDS` to an (n,) bool array
    (``World.scan(...).violations``), ``changes`` the observed changes (``Scan.changes``;
    a coupled run with the fused scan keeps them as `ScanChanges` over a copy of the
    scan's rows, one object instead of a dict of lists), ``lost`` is (n,) bool.
    ``segment`` and ``curvature`` are the leader's segment kind and curvature, or (a
    coupled run's, until the table reads them) its path and its arc length then
    (`segments`); ``fix_error`` and ``neighbour`` None: no fix and no neighbour for any
    follower. ``decision``: the decision that governs the window, kept
    by a coupled run until the next scan has read it.
    """

    window: int
    t: float
    w: float
    w_sch: float
    msb_min: float
    binding: str
    v_leader_desired: float
    v_leader: float
    v_leader_target: float
    method: str
    feasible: bool
    segment: str
    curvature: float
    est: Any
    points: int = 0
    hough_ms: float = math.nan
    tracks_lost: int = 0
    leader: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    truth: Any = None
    lost: Sequence[bool] | None = None
    viol: Mapping[str, Sequence[bool]] | None = None  # (the scan's lists, as they are)
    changes: Mapping[str, Sequence[float]] | None = None
    v_leader_max: float = math.nan
    pred: Any = None
    finish: float = math.nan
    scan_t: float = math.nan
    assumption_broken: bool = False
    lost_by_cause: tuple[int, ...] = (0,) * len(LOST_CAUSES)
    searches: int = 0
    reacquisitions: int = 0
    voted: Sequence[int] = ()
    fix_error: Sequence[float] | None = ()
    neighbour: Sequence[bool] | None = ()
    radio_ms: float = math.nan  # (set at the release: delta_t, or the drawn round trip)
    radio_losses: int = 0
    # contact (CONTACT_FIELDS), per follower: the truth's closest approach at this window's
    # scan, then (at the next scan) over both; the decision's prediction; the breaks
    near: Sequence[float] = ()
    near_true: Sequence[float] = ()
    near_pred: Sequence[float] = ()
    viol_contact: Sequence[bool] = ()
    decision: Any = None

    @property
    def complete(self) -> bool:
        """Finished, scanned, and its violation interval closed by a later observation."""
        return (
            not math.isnan(self.finish)
            and self.truth is not None
            and self.viol is not None
            and self.pred is not None
        )


@dataclass
class WindowRecorder:
    """Collects [`WindowRecord`][rtsim.coupling.recorder.WindowRecord] s of ``n`` followers; `frame`
    builds the table.

    ``limits``: each bound kind's threshold per follower (n values, BOUND_KINDS order: r_H,
    T_ρ·ρ_d,i, T_ε·ρ_d,i, T_β), for the ``_true`` columns (`true_bounds`).
    ``sink``: a callable given lists of complete records, oldest first, during the run
    (module docstring); `records` then holds only those not handed over yet.
    """

    n: int
    limits: tuple[tuple[float, ...], ...]
    records: list[WindowRecord] = field(default_factory=list)
    sink: Any = None
    chunk: int = field(default_factory=lambda: CHUNK_WINDOWS)

    def add(self, rec: WindowRecord) -> WindowRecord:
        """Keep ``rec`` (the last record); at every `chunk`-th window, `settle`."""
        self.records.append(rec)
        if rec.window % self.chunk == 0:
            self.settle()
        return rec

    def settle(self) -> None:
        """With a sink and two chunks of records kept, hand the complete ones at the front
        to the sink (`add` calls it at every `chunk`-th window; a caller that appends to
        `records` itself calls it then)."""
        if self.sink is not None and len(self.records) >= 2 * self.chunk:
            self._flush_settled()

    def _flush_settled(self) -> None:
        recs = self.records
        i = 0
        while i < len(recs) and recs[i].complete:
            i += 1
        if i:
            done = recs[:i]
            del recs[:i]
            self.sink(done)

    def flush(self) -> None:
        """Hand every complete record left to the sink (the end of the run); an incomplete
        one is dropped, as in `frame`."""
        done = [r for r in self.records if r.complete]
        self.records.clear()
        if done and self.sink is not None:
            self.sink(done)

    def frame(self) -> pd.DataFrame:
        """windows.csv as a DataFrame: complete records only (a window still running at the
        end, or one whose violation interval never closed, is dropped)."""
        return records_frame([r for r in self.records if r.complete], self.n, self.limits)


def records_frame(
    recs: list[WindowRecord], n: int, limits: tuple[tuple[float, ...], ...]
) -> pd.DataFrame:
    """The rows of windows.csv for complete records ``recs`` of ``n`` followers (``limits``
    as [`WindowRecorder`][rtsim.coupling.recorder.WindowRecorder]'s)."""
    data = records_columns(recs, n, limits)
    return pd.DataFrame(data, columns=list(data))


def _flat(rows: Any, dtype: Any, count: int) -> NDArray[Any]:
    """The numbers of ``rows`` (an iterable of sequences of sequences: one per record) in
    one flat array of ``count`` values, as ``np.array(list(rows), dtype).ravel()`` gives them
    (the same conversion per value) without discovering a nested list's shape (≈ 2× faster
    at 500 records)."""
    return np.fromiter(_chain(_chain(rows)), dtype, count)


def _rows(rows: Any, dtype: Any, m: int, width: int) -> NDArray[Any]:
    """``m`` rows of ``width`` numbers (an iterable of sequences: one per record) as an
    (m, width) array of ``dtype``, as ``np.array(list(rows), dtype)`` gives them."""
    return np.fromiter(_chain(rows), dtype, m * width).reshape(m, width)


def _same_rows(vals: list[Any], dtype: Any, width: int, equal: bool = False) -> NDArray[Any]:
    """`_rows` of ``vals`` (sequences of ``width`` numbers, one per record); when every one is
    the same object (a run's records without a lost track share their zero counts), or with
    ``equal`` an equal one (flags: equal values are equal bools; C-level compares), its
    numbers converted once and repeated, without a pass over the values."""
    m = len(vals)
    if m and (vals.count(vals[0]) == m if equal else all(map(is_, vals, repeat(vals[0])))):
        row = np.fromiter(vals[0], dtype, width)
        return np.broadcast_to(row, (m, width)).copy()
    return _rows(vals, dtype, m, width)


def _filled(recs: list[WindowRecord], name: str, empty: Any, dtype: Any, n: int) -> NDArray[Any]:
    """Every record's field ``name`` (``n`` values each) as an (m, n) array of ``dtype``,
    ``n`` times ``empty`` for a record whose field is empty or None (``r.name or (empty,) *
    n``: a record made without a scan's sensing or contact); no Python per record when
    every record has its values, or none has; flags (``dtype`` bool) every record holds
    equal (a run's neighbours' and contacts' flags, mostly none set) converted once and
    repeated (`_same_rows`)."""
    vals = list(map(attrgetter(name), recs))
    m = len(vals)
    if all(vals):
        return _same_rows(vals, dtype, n, equal=dtype is bool)
    if not any(vals):
        return np.full((m, n), empty, dtype=dtype)
    none = (empty,) * n
    return _rows([v or none for v in vals], dtype, m, n)


def _column(recs: list[WindowRecord], name: str, dtype: Any) -> NDArray[Any]:
    """One scalar field of every record, as an array of ``dtype``."""
    return np.fromiter(map(attrgetter(name), recs), dtype, len(recs))


def _each(recs: list[WindowRecord], name: str, keys: tuple[str, ...] = ()) -> Any:
    """Every record's field ``name`` (with ``keys``, the tuple of its values at those keys,
    in that order), an iterator for `_rows` and `_flat` that runs no Python per record."""
    out = map(attrgetter(name), recs)
    return out if not keys else map(itemgetter(*keys), out)


def changes_array(recs: list[WindowRecord], n: int) -> NDArray[np.float64]:
    """The observed changes of complete records ``recs`` of ``n`` followers, one (records,
    `CHANGE_KEYS`, n) array (`WindowRecord.changes`)."""
    return _keyed(list(map(_CHANGES, recs)), ScanChanges, np.float64, n)


def _keyed(maps: list[Any], kind: type[ScanRows], dtype: Any, n: int) -> NDArray[Any]:
    """Each of ``maps`` (a mapping of ``kind.KEYS`` to ``n`` values) as one (len(maps),
    keys, n) array of ``dtype``: copies of the scan's rows (``kind``) in one pass, any other
    mapping read by its keys."""
    nb, m = len(kind.KEYS), len(maps)
    values = itemgetter(*kind.KEYS)
    types = list(map(type, maps))
    k = types.count(kind)
    if not k:
        return _flat(map(values, maps), dtype, m * nb * n).reshape(m, nb, n)
    # (a run closed after its loop holds its last record's as the scan's lists)
    fused = None if k == m else list(map(is_, types, repeat(kind)))
    rows = list(map(_ROWS_OF, maps if fused is None else compress(maps, fused)))
    lo = kind.AT
    every = _joined(rows).reshape(k, -1, n)[:, lo : lo + nb]
    if fused is None:
        return every.astype(dtype)
    out = np.empty((m, nb, n), dtype=dtype)
    kept = np.fromiter(fused, np.bool_, m)
    out[kept] = every
    for i in np.flatnonzero(~kept).tolist():
        out[i] = values(maps[i])
    return out


def _joined(rows: list[NDArray[Any]]) -> NDArray[Any]:
    """The arrays ``rows`` (at least one) end to end, flat, as ``np.concatenate`` of them
    raveled gives them: their bytes joined when they are C-contiguous arrays of one dtype
    (≈ 4x concatenate's speed on 500 small arrays; a read-only view of the bytes), else
    concatenated."""
    dt = rows[0].dtype
    if len(set(map(_DTYPE, rows))) == 1:
        try:
            return np.frombuffer(b"".join(rows), dt)  # type: ignore[arg-type]
        except TypeError:  # (an array that is not C-contiguous)
            pass
    return np.concatenate([r.ravel() for r in rows])


def records_columns(
    recs: list[WindowRecord],
    n: int,
    limits: tuple[tuple[float, ...], ...],
    *,
    state: bool = True,
    changes: NDArray[np.float64] | None = None,
    summary: bool = False,
    violations: NDArray[np.bool_] | None = None,
) -> dict[str, Any]:
    """The columns of windows.csv (name -> array or list, in order) for complete records
    ``recs``: what `records_frame` holds, without the DataFrame (a writer's
    `write_columns` formats them directly). ``state`` False leaves out the followers'
    state and estimate (``f{i}_x`` … ``f{i}_v_est``), bound (``_pred``, ``_true``) and
    contact distance columns, which summary.json does not read (`_follower_state`);
    ``summary`` True (with ``state`` False) also the window-level and sensing columns it
    does not read (the points, round trips and neighbours' flags among them; the others of
    `rtsim.coupling.summary.summary_columns` are the same either way).
    ``changes``: `changes_array` of ``recs`` when the caller has made it (else made here);
    ``violations``: their flags as an (m, `BOUND_KINDS`, n) bool array when the caller has
    them (`rtsim.world.world.World.violations_of` of their changes; else read from ``viol``)."""
    cols = _window_columns(n)
    m = len(recs)
    data: dict[str, object] = {}
    t = _column(recs, "t", float)
    w = _column(recs, "w", float)
    w_sch = _column(recs, "w_sch", float)
    msb = _column(recs, "msb_min", float)
    finish = _column(recs, "finish", float)
    data["w"] = w
    data["w_sch"] = w_sch
    data["msb_min"] = msb
    data["binding"] = list(_each(recs, "binding"))
    for name in ("v_leader_desired", "v_leader"):
        data[name] = _column(recs, name, float)
    data["method"] = list(_each(recs, "method"))
    data["feasible"] = _column(recs, "feasible", bool)
    data["critical"] = msb < w_sch
    data["missed"] = finish > t + w + EPS
    data["response"] = finish - t
    data["tracks_lost"] = _column(recs, "tracks_lost", np.int64)
    if not (summary and not state):
        _window_rest(recs, t, w, w_sch, msb, finish, data)
    if state:
        _follower_state(recs, n, limits, w, data, changes)
    nb = len(BOUND_KINDS)
    if violations is None:
        violations = _flat(_each(recs, "viol", BOUND_KINDS), np.bool_, m * nb * n)
    viol = violations.reshape(m, nb, n).transpose(0, 2, 1)
    lost = None if summary and not state else _rows(_each(recs, "lost"), np.bool_, m, n)
    for i in range(n):
        for j, kind in enumerate(BOUND_KINDS):
            data[f"f{i + 1}_viol_{kind}"] = viol[:, i, j]
        if lost is not None:
            data[f"f{i + 1}_lost"] = lost[:, i]
    data["assumption_broken"] = _column(recs, "assumption_broken", bool)
    nc = len(LOST_CAUSES)
    causes = _same_rows(list(_each(recs, "lost_by_cause")), np.int64, nc)
    for j, col in enumerate(LOCALIZATION_COLUMNS[:nc]):
        data[col] = causes[:, j]
    data["searches"] = _column(recs, "searches", np.int64)
    data["reacquisitions"] = _column(recs, "reacquisitions", np.int64)
    # (a record made without a scan's sensing, by hand, has none: 0 points, no fix; the
    # summary's columns leave out the points, the round trips and the neighbours' flags,
    # which it does not read: each a pass over cold records, ≈ 0.2 ms of a Test 2 lap)
    least = summary and not state
    err = _filled(recs, "fix_error", math.inf, float, n)
    nb_ = _filled(recs, "neighbour", False, bool, n)
    data["confusions"] = nb_.sum(axis=1).astype(np.int64)
    if not least:
        data["radio_ms"] = _column(recs, "radio_ms", float)
    data["radio_losses"] = _column(recs, "radio_losses", np.int64)
    voted = None if least else _filled(recs, "voted", 0, np.int64, n)
    for i in range(n):
        if voted is not None:
            data[f"f{i + 1}_points"] = voted[:, i]
            data[f"f{i + 1}_neighbour"] = nb_[:, i]
        data[f"f{i + 1}_fix_error_cm"] = err[:, i]
    # (a record made by hand has no contact: inf, no break)
    broke = _filled(recs, "viol_contact", False, bool, n)
    for i in range(n):
        data[f"f{i + 1}_viol_contact"] = broke[:, i]
    return {c: data[c] for c in cols if c in data}


def _window_rest(
    recs: list[WindowRecord],
    t: NDArray[np.float64],
    w: NDArray[np.float64],
    w_sch: NDArray[np.float64],
    msb: NDArray[np.float64],
    finish: NDArray[np.float64],
    data: dict[str, object],
) -> None:
    """Add to ``data`` the window-level columns of ``recs`` that summary.json does not read
    (`records_columns`; ``t`` … ``finish`` its columns)."""
    data["window"] = _column(recs, "window", np.int64)
    data["t"] = t
    data["deadline"] = t + w
    with np.errstate(invalid="ignore"):
        data["margin"] = msb - w_sch
    data["slack"] = np.maximum(0.0, w - w_sch)
    for name in ("v_leader_target", "v_leader_max"):
        data[name] = _column(recs, name, float)
    data["finish"] = finish
    data["points"] = _column(recs, "points", np.int64)
    data["hough_ms"] = _column(recs, "hough_ms", float)
    kinds, kappas = segments(recs)
    data["segment"] = kinds
    data["curvature"] = np.array(kappas, dtype=float)
    leader = _rows(_each(recs, "leader"), float, len(recs), 3)
    data["leader_x"], data["leader_y"], data["leader_heading"] = leader.T


def segments(recs: list[WindowRecord]) -> tuple[list[str], list[float]]:
    """Each record's segment kind and curvature: its own, or those of the path it holds at
    its arc length (``path.segment_at(curvature)``: a coupled run leaves the lookup to the
    table, which a sweep point that reads only the summary never makes)."""
    kinds: list[str] = []
    kappas: list[float] = []
    for r in recs:
        kind = r.segment
        if type(kind) is str:
            kinds.append(kind)
            kappas.append(r.curvature)
        else:
            k, kappa = kind.segment_at(r.curvature)  # type: ignore[attr-defined]
            kinds.append(k)
            kappas.append(kappa)
    return kinds, kappas


_POSE_OF = itemgetter(0, 1, 2)
_SPEED_OF = itemgetter(3)
_CHANGES = attrgetter("changes")
_ROWS_OF = attrgetter("rows")
_DTYPE = attrgetter("dtype")
_LP = attrgetter("_lp")
_ROWS = attrgetter("_rows")
_SHAPE = attrgetter("shape")
_POSES = attrgetter("_poses")
_SPEEDS = attrgetter("_speeds")


def _states(rows: Any, m: int, n: int) -> NDArray[np.float64]:
    """``m`` records' state rows (`StateRows`, or n rows of 7 floats each), one (m, n, 7)
    array: `StateRows` not read yet from their poses and speeds read once into arrays
    (`relative_states_of`), without making their rows; the values `_flat` of their rows
    gives."""
    objs = list(rows)
    k = len(FOLLOWER_FIELDS)
    cols = _columns(objs, m, n)
    if cols is None:
        cols = _wide(objs, m, n)
    if cols is not None:
        return cols
    for o in objs:
        if type(o) is not StateRows or o._rows is not None:
            break
        if o._speeds is None or type(o._speeds) is int:  # (the other forms: `_wide`,
            break  # `_columns`; mixed, or of other shapes, read one by one below)
        p = o._poses
        if type(p) is not list:  # (kept for a later `rows`: poses may be an iterator)
            p = o._poses = list(p)
        if len(p) != n or len(o._speeds) != n:
            break
    else:
        if m:
            mn = m * n
            pose = np.fromiter(_chain(_chain(map(_POSES, objs))), float, 3 * mn).reshape(mn, 3)
            speeds = np.fromiter(_chain(map(_SPEEDS, objs)), float, mn)
            return _state_table(objs, pose, speeds, m, n)
    return _flat(objs, float, m * n * k).reshape(m, n, k)


def _state_table(
    objs: list[Any], pose: NDArray[np.float64], speeds: NDArray[np.float64], m: int, n: int
) -> NDArray[np.float64]:
    """`_states`' (m, n, 7) array of ``m`` `StateRows` ``objs`` from their poses (an (m·n,
    3) array, records' followers in order) and speeds (m·n), and their leaders' poses."""
    lead = np.fromiter(_chain(map(_LP, objs)), float, 3 * m).reshape(m, 3)
    lead = np.repeat(lead, n, axis=0)
    k = len(FOLLOWER_FIELDS)
    out = np.empty((m * n, k))
    out[:, :3] = pose
    xl, yl, hl = lead.T
    out[:, 3:6] = np.transpose(relative_states_of(xl, yl, hl, *pose.T))
    out[:, 6] = speeds
    return out.reshape(m, n, k)


def _columns(objs: list[Any], m: int, n: int) -> NDArray[np.float64] | None:
    """`_states` of ``m`` `StateRows` not read yet in their array form (arrays of one shape,
    ``n`` followers, the same row), read in one pass; None for any other."""
    if not _unread(objs):
        return None
    speeds = list(map(_SPEEDS, objs))
    if set(map(type, speeds)) != {int} or len(set(speeds)) != 1:
        return None
    at = speeds[0]
    arrays = list(map(_POSES, objs))
    if set(map(type, arrays)) != {np.ndarray}:
        return None
    shape = arrays[0].shape
    if len(shape) != 2 or shape[1] != n or set(map(_SHAPE, arrays)) != {shape}:
        return None
    cols = np.concatenate(arrays).reshape(m, -1, n)[:, at : at + 4]  # (m, 4, n): x, y, θ, v
    cols = cols.transpose(0, 2, 1).reshape(m * n, 4)  # (the records' followers in order)
    return _state_table(objs, cols[:, :3], cols[:, 3], m, n)


def _wide(objs: list[Any], m: int, n: int) -> NDArray[np.float64] | None:
    """`_states` of ``m`` `StateRows` not read yet whose poses are lists of ``n`` rows of x,
    y, θ, V_F and more (``speeds`` None), read in one pass; None for any other."""
    if not _unread(objs) or set(map(type, map(_SPEEDS, objs))) != {type(None)}:
        return None
    rows = list(map(_POSES, objs))
    if set(map(type, rows)) != {list} or set(map(len, rows)) != {n}:
        return None
    width = len(rows[0][0]) if n else 4
    if width < 4 or set(map(len, _chain(rows))) != {width}:
        return None
    a = np.fromiter(_chain(_chain(rows)), float, m * n * width).reshape(m * n, width)
    return _state_table(objs, a[:, :3], a[:, 3], m, n)


def _unread(objs: list[Any]) -> bool:
    """Every one of ``objs`` (at least one) a `StateRows` whose rows are not made yet."""
    return bool(objs) and set(map(type, objs)) == {StateRows} and not any(map(_ROWS, objs))


def _follower_state(
    recs: list[WindowRecord],
    n: int,
    limits: tuple[tuple[float, ...], ...],
    w: NDArray[np.float64],
    data: dict[str, object],
    ch: NDArray[np.float64] | None = None,
) -> None:
    """Add to ``data`` the followers' state and estimate columns, their bounds (``_pred``,
    and ``_true`` from the changes over the windows' lengths ``w``, `true_bounds`) and the
    contact distances (``contact_cm_pred``, ``contact_cm_true``) of ``recs`` (``ch``: their
    `changes_array`, or None to make it)."""
    m = len(recs)
    nb = len(BOUND_KINDS)
    truth = _states(_each(recs, "truth"), m, n)
    est = _states(_each(recs, "est"), m, n)
    pred = _flat(_each(recs, "pred"), float, m * n * nb).reshape(m, n, nb)
    changes = (changes_array(recs, n) if ch is None else ch).transpose(0, 2, 1)
    for i in range(n):
        for j, f in enumerate(FOLLOWER_FIELDS):
            data[f"f{i + 1}_{f}"] = truth[:, i, j]
            data[f"f{i + 1}_{f}_est"] = est[:, i, j]
        for j, kind in enumerate(BOUND_KINDS):
            data[f"f{i + 1}_msb_{kind}_pred"] = pred[:, i, j]
            data[f"f{i + 1}_msb_{kind}_true"] = true_bounds(w, changes[:, i, j], limits[j][i])
    near_p = _filled(recs, "near_pred", math.inf, float, n)
    near_t = _filled(recs, "near_true", math.inf, float, n)
    for i in range(n):
        data[f"f{i + 1}_contact_cm_pred"] = near_p[:, i]
        data[f"f{i + 1}_contact_cm_true"] = near_t[:, i]
