"""The points of a sweep: the grid as a product or a zip, and each point's seed.

A point's seed is ``int.from_bytes(sha256(canonical_json({"seed": S, "params": P}))[:8])
& (2**63 - 1)``, where ``S`` is the sweep's seed and ``P`` the point's grid values (without
``seed``). It depends on nothing else: not on the point's index, the order of execution or
the worker, so adding values to a grid keeps the seeds of the points already there. A
``seed`` entry in the grid is used as the point's seed instead.
"""

from __future__ import annotations

import hashlib
import itertools
from dataclasses import dataclass
from typing import Any

from rtsim.sweep.kinds import PointInput
from rtsim.sweep.spec import SweepSpec, canonical_json

__all__ = ["Point", "point_seed", "points", "point_input"]

_INT63 = (1 << 63) - 1


@dataclass(frozen=True)
class Point:
    """One point: its index in point order, its grid values, its seed and its id."""

    index: int
    params: dict[str, Any]
    seed: int

    @property
    def key(self) -> str:
        """12 hex digits identifying the point's values and seed (part of its file name)."""
        text = canonical_json({"params": self.params, "seed": self.seed})
        return hashlib.sha256(text.encode("utf-8")).hexdigest()[:12]

    @property
    def filename(self) -> str:
        return f"{self.index:06d}-{self.key}.json"


def point_seed(sweep_seed: int, params: dict[str, Any]) -> int:
    """The derived seed of a point (see the module docstring), a non-negative int63."""
    text = canonical_json({"seed": sweep_seed, "params": params})
    digest = hashlib.sha256(text.encode("utf-8")).digest()
    return int.from_bytes(digest[:8], "big") & _INT63


def points(spec: SweepSpec) -> list[Point]:
    """All points in point order (product: the last grid entry varies fastest)."""
    names = [k for k, _ in spec.grid]
    values = [v for _, v in spec.grid]
    combos = itertools.product(*values) if spec.combine == "product" else zip(*values, strict=True)
    out = []
    for i, combo in enumerate(combos):
        params = dict(zip(names, combo, strict=True))
        seed = params["seed"] if "seed" in params else point_seed(spec.seed, params)
        out.append(Point(i, params, seed))
    return out


def point_input(spec: SweepSpec, point: Point) -> PointInput:
    """What the point's kind receives: merged options, base-file overrides, the seed.

    ``[sweep.set]`` entries are applied first, then the point's grid values.
    """
    options = dict(spec.options)
    overrides = []
    params = {k: v for k, v in point.params.items() if k != "seed"}
    for name, value in [*spec.fixed, *params.items()]:
        target = spec.targets[name]
        if target[0] == "option":
            options[name] = value
        elif target[0] == "path":
            overrides.append((tuple(target[1:]), value))
    if spec.kind == "call":
        params = {**dict(spec.fixed), **params}
    return PointInput(
        index=point.index,
        kind=spec.kind,
        params=params,
        options=options,
        seed=point.seed,
        base=spec.base,
        overrides=tuple(overrides),
        function=spec.function,
        allow_code=spec.allow_code,
    )
