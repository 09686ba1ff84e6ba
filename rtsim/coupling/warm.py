"""The compiled world's kernels made ready in a parent process before its workers start.

A process pool whose workers each build a world on the ``compiled`` backend would compile
the same kernels once per worker the first time (an empty numba cache: every worker pays
the full compile at the same moment). `warm_world` compiles them, or loads them from
the cache, in the calling process first: workers forked after it inherit them, spawned ones
load what it cached (`rtsim.world.jit`). ``rtsim reproduce`` and the sweep engine call
it just before they start their pools.
"""

from __future__ import annotations

from collections.abc import Iterable

from rtsim.config.scenario import Scenario
from rtsim.control import kernels

__all__ = ["warm_world"]


def warm_world(scenarios: Iterable[Scenario]) -> bool:
    """Compile (or load) the kernels when any of ``scenarios`` runs on the compiled backend
    (`rtsim.world.config.WorldConfig.resolved_backend`); returns whether it did. The
    world's and the rollout's kernels (`rtsim.control.kernels.warm_all`); the ``paper``
    predictor's compiles lazily where it is used."""
    if not any(sc.world.resolved_backend() == "compiled" for sc in scenarios):
        return False

    kernels.warm_all()
    return True
