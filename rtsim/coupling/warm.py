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

import numpy as np

from rtsim.config.scenario import Scenario
from rtsim.control import kernels
from rtsim.coupling.physical import trace_samples
from rtsim.world.formation import follower_model
from rtsim.world.jit import build
from rtsim.world.kernels import built_entry
from rtsim.world.kernels import kernels as world_kernels
from rtsim.world.locmodels import HoughModel, localization_model

__all__ = ["warm_world"]


def warm_world(scenarios: Iterable[Scenario]) -> bool:
    """Compile (or load) the kernels when any of ``scenarios`` runs on the compiled backend
    (`rtsim.world.config.WorldConfig.resolved_backend`); returns whether it did. The
    world's and the rollout's kernels (`rtsim.control.kernels.warm_all`) and the truth
    log's (when a world follows the trace and its scan does not make the log's samples:
    `_scan_logs`); the ``paper`` predictor's compiles lazily where it is used."""
    compiled = [sc for sc in scenarios if sc.world.resolved_backend() == "compiled"]
    if not compiled:
        return False
    kernels.warm_all()
    on_trace = [sc for sc in compiled if follower_model(sc.world.formation.model).on_trace]
    if any(not _scan_logs(sc) for sc in on_trace):
        _warm_truth_log()
    return True


def _scan_logs(sc: Scenario) -> bool:
    """Whether a world of ``sc`` (compiled, on the trace) makes its truth log's samples in
    its scan's compiled call (`rtsim.world.world.World.log_truth`: the fused scan, with the
    ``hough`` model, where the kernels' hypot is this interpreter's), so that its run never
    calls `trace_samples`' own entry."""
    model = localization_model(sc.world.localization.model)
    return model is HoughModel and bool(world_kernels().exact_hypot)


def _warm_truth_log() -> None:
    """Compile the truth log's kernel (`rtsim.coupling.physical.trace_samples`: a world
    on the follow-the-leader law's trace) or load it, for the types of its every call
    (`rtsim.coupling.physical.PhysicalLog`), without running it."""
    G = (np.zeros(1), np.zeros(6), 1e3, np.zeros(3))  # (the types of path.geometry_arrays)
    f = np.zeros(1)
    built_entry(build(trace_samples), (G, f, f, f, 0.0, 0.0, f, f, np.zeros(2), f))
