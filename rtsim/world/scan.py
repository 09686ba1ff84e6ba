"""One scan's outcome as the leader's localization saw it (docs/model/world.md).

[`Scan`][rtsim.world.scan.Scan] is what
[`rtsim.world.world.World.scan`][rtsim.world.world.World.scan] returns: per follower, the beams
returned, the position fixes, the Hough windows, lost and re-acquired tracks, and the truth's
change since the previous scan with the bound violations it caused.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rtsim.world.localization import LOST_CAUSES

__all__ = ["Scan"]

Array = NDArray[np.float64]
Pose = tuple[float, float, float]


_NEW = object.__new__
_SET = object.__setattr__


def _as_list(x: Any) -> list[Any]:
    return x if isinstance(x, list) else np.asarray(x).tolist()


class Scan:
    """What one scan at ``t_ms`` saw; arrays have one row per follower (index i − 1).

    points: beams returned by each follower (shadowing included); measured: position fixes in
    the leader frame (truth + noise, cm); truth: true positions in the leader frame; centre:
    Hough window centres; in_window / lost / reacquired: localization outcome; changes: the
    truth's change since the previous scan (``displacement`` in the leader frame, ``d_rho``,
    ``travel``, ``d_beta``; zeros at the first scan); violations: per bound kind
    (docs/model/world.md),
    whether that change exceeded its threshold.

    Read-only. The world builds a scan from plain lists; each array (and each mapping of
    arrays) is made on first access, so a caller that reads a few fields pays for those only.
    """

    __slots__ = ("t_ms", "leader_pose", "_raw", "_arrays")

    t_ms: float
    leader_pose: Pose
    _raw: dict[str, Any]
    _arrays: dict[str, Any]

    def __init__(
        self,
        t_ms: float,
        leader_pose: Pose,
        points: Any,
        measured: Any,
        truth: Any,
        centre: Any,
        in_window: Any,
        lost: Any,
        reacquired: Any,
        changes: Mapping[str, Any],
        violations: Mapping[str, Any],
        searched: Any = None,
        cause: Any = None,
        *,
        voted: Any = None,
        fix_error: Any = None,
        neighbour: Any = None,
        cells: int | None = None,
    ) -> None:
        object.__setattr__(self, "t_ms", t_ms)
        object.__setattr__(self, "leader_pose", leader_pose)
        if searched is None:  # every lost follower searched for (the default search)
            searched = lost
        if cause is None:
            cause = ["" if not v else "outside_window" for v in _as_list(lost)]
        object.__setattr__(
            self,
            "_raw",
            {
                "points": points,
                "measured": measured,
                "truth": truth,
                "centre": centre,
                "in_window": in_window,
                "lost": lost,
                "reacquired": reacquired,
                "changes": changes,
                "violations": violations,
                "searched": searched,
                "cause": cause,
                "voted": voted,
                "fix_error": fix_error,
                "neighbour": neighbour,
                "cells": cells,
            },
        )
        object.__setattr__(self, "_arrays", {})

    @classmethod
    def _of(cls, t_ms: float, leader_pose: Pose, raw: dict[str, Any]) -> Scan:
        """A scan from its fields as the constructor would keep them, ``raw`` (every
        key of `__init__`'s, ``searched`` and ``cause`` given, each field a list and each
        mapping's values lists): the world's per-scan path, without the constructor's
        keywords."""
        raw["_plain"] = True
        scan = _NEW(cls)
        # (the slots' own setters, half object.__setattr__'s cost; ``_arrays`` made when
        # first asked for, `_array`)
        _SET_T(scan, t_ms)
        _SET_POSE(scan, leader_pose)
        _SET_RAW(scan, raw)
        return scan

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"Scan is read-only: cannot set {name!r}")

    def _array(self, name: str, dtype: Any = None) -> Any:
        try:
            arrays = self._arrays
        except AttributeError:  # (a scan `_of` the world's: made on the first call)
            arrays = {}
            _SET(self, "_arrays", arrays)
        arr = arrays.get(name)
        if arr is None:
            raw = self._raw[name]
            if name in ("changes", "violations"):
                arr = {k: np.array(v) for k, v in raw.items()}
            elif isinstance(raw, np.ndarray):
                arr = raw
            else:
                arr = np.array(raw) if dtype is None else np.array(raw, dtype=dtype)
            arrays[name] = arr
        return arr

    def as_lists(self, name: str) -> Any:
        """A field as plain lists, without making numpy arrays (a fast path; do not mutate)."""
        fields = self._raw
        raw = fields[name]
        if name in ("changes", "violations"):
            if "_plain" in fields:  # (lists already: a copy of the mapping)
                return dict(raw)
            return {k: _as_list(v) for k, v in raw.items()}
        return _as_list(raw)

    def fields(self) -> Mapping[str, Any]:
        """Every field by name as plain lists (`as_lists`'s; ``changes`` and ``violations``
        mappings of lists, ``cells``, ``voted``, ``fix_error``, ``neighbour`` as kept, None
        included): the world's scans hand over the mapping they keep (do not mutate)."""
        raw = self._raw
        if "_plain" in raw:
            return raw
        return {k: v if v is None or k == "cells" else self.as_lists(k) for k, v in raw.items()}

    @property
    def points(self) -> NDArray[np.int64]:
        return self._array("points", np.int64)  # type: ignore[no-any-return]

    @property
    def measured(self) -> Array:
        return self._array("measured")  # type: ignore[no-any-return]

    @property
    def truth(self) -> Array:
        return self._array("truth")  # type: ignore[no-any-return]

    @property
    def centre(self) -> Array:
        return self._array("centre")  # type: ignore[no-any-return]

    @property
    def in_window(self) -> NDArray[np.bool_]:
        return self._array("in_window")  # type: ignore[no-any-return]

    @property
    def lost(self) -> NDArray[np.bool_]:
        return self._array("lost")  # type: ignore[no-any-return]

    @property
    def reacquired(self) -> NDArray[np.bool_]:
        return self._array("reacquired")  # type: ignore[no-any-return]

    @property
    def changes(self) -> Mapping[str, Array]:
        return self._array("changes")  # type: ignore[no-any-return]

    @property
    def violations(self) -> Mapping[str, NDArray[np.bool_]]:
        return self._array("violations")  # type: ignore[no-any-return]

    @property
    def n(self) -> int:
        return len(self._raw["points"])

    @property
    def total_points(self) -> int:
        """Scan points returned by all followers (Eq 1's min(361, k·n), counted)."""
        return int(sum(_as_list(self._raw["points"])))

    @property
    def hough(self) -> bool:
        """Whether the fixes came from a laser scan and Hough windows (``model = "hough"``)."""
        return self._raw["voted"] is not None

    @property
    def voted(self) -> tuple[int, ...]:
        """Per follower, the scan points that voted in its window (``hough``; else the beams
        it returned)."""
        v = self._raw["voted"]
        return tuple(_as_list(self._raw["points"] if v is None else v))

    @property
    def hough_points(self) -> int:
        """Eq 1's second term, counted: ``hough`` — the points that voted over every window;
        ``gaussian`` — the beams the followers returned (`total_points`)."""
        return int(sum(self.voted))

    @property
    def cells(self) -> int | None:
        """The cells every window's accumulator covered (``hough``), or None (Eq 1's
        π·r_H²·n)."""
        return self._raw["cells"]  # type: ignore[no-any-return]

    @property
    def fix_error(self) -> tuple[float, ...]:
        """Per follower, the accepted fix's distance from the truth (cm; inf: no fix)."""
        v = self._raw["fix_error"]
        return tuple(_as_list(v)) if v is not None else (math.inf,) * self.n

    @property
    def neighbour(self) -> tuple[bool, ...]:
        """Per follower, whether another follower's points made its fix (a confusion)."""
        v = self._raw["neighbour"]
        return tuple(_as_list(v)) if v is not None else (False,) * self.n

    @property
    def confusions(self) -> int:
        """Followers whose fix a neighbour made at this scan."""
        return int(sum(self.neighbour))

    @property
    def n_lost(self) -> int:
        """Followers lost at this scan (each re-acquisition is charged)."""
        return int(sum(_as_list(self._raw["lost"])))

    @property
    def searched(self) -> NDArray[np.bool_]:
        """Lost followers the leader searched for (a full-scan search each)."""
        return self._array("searched")  # type: ignore[no-any-return]

    @property
    def cause(self) -> tuple[str, ...]:
        """Why each follower's track was lost (`LOST_CAUSES`; "" when it was not)."""
        return tuple(self._raw["cause"])

    @property
    def n_searched(self) -> int:
        """Searches charged at this scan ([`hough_time`][rtsim.world.localization.hough_time])."""
        return int(sum(_as_list(self._raw["searched"])))

    @property
    def n_reacquired(self) -> int:
        """Lost followers found again by their search."""
        return int(sum(_as_list(self._raw["reacquired"])))

    def lost_by_cause(self) -> dict[str, int]:
        """Lost tracks per cause, every cause of `LOST_CAUSES` present (0 if none)."""
        out = dict.fromkeys(LOST_CAUSES, 0)
        for c in self._raw["cause"]:
            if c:
                out[c] += 1
        return out

    @property
    def lost_followers(self) -> tuple[int, ...]:
        """1-based numbers of the followers that need re-acquisition."""
        return tuple(k + 1 for k, v in enumerate(_as_list(self._raw["lost"])) if v)

    def __repr__(self) -> str:
        return f"Scan(t_ms={self.t_ms!r}, n={self.n}, points={_as_list(self._raw['points'])})"


#: `Scan`'s slots' setters (`Scan._of`)
_SET_T = Scan.__dict__["t_ms"].__set__
_SET_POSE = Scan.__dict__["leader_pose"].__set__
_SET_RAW = Scan.__dict__["_raw"].__set__
