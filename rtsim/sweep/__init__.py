"""Parameter sweeps: a TOML sweep file, deterministic per-point seeds, resumable results.

See `rtsim.sweep.spec` for the file format and `rtsim.sweep.engine` for the
output directory. Library use::

    from rtsim.sweep import run_sweep
    df = run_sweep("experiments/sweeps/smoke.toml", "out/smoke", workers=2)
"""

from rtsim.sweep.engine import Sweep, SweepIncomplete, SweepOutcome, run_sweep
from rtsim.sweep.grid import Point, point_seed, points
from rtsim.sweep.kinds import KINDS, KindSpec, PointInput, register_kind
from rtsim.sweep.spec import BaseFile, SweepSpec, load_sweep, parse_sweep

__all__ = [
    "BaseFile",
    "KINDS",
    "KindSpec",
    "Point",
    "PointInput",
    "Sweep",
    "SweepIncomplete",
    "SweepOutcome",
    "SweepSpec",
    "load_sweep",
    "parse_sweep",
    "point_seed",
    "points",
    "register_kind",
    "run_sweep",
]
