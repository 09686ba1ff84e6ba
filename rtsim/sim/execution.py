"""Execution-time models: how long a segment of a job runs, decided when the segment starts.

A model is any callable ``model(job, segment, rng) -> float`` (ms). The virtual CPU calls it
once per segment, at the instant the segment starts (docs/model/lower-bound.md: e_hough is known
only once the
scan has counted its points), with the task's own random generator.

Models shipped here:

- [`WCET`][rtsim.sim.execution.WCET] — every segment runs its ``wcet`` (the default; the analysis'
assumption);
- [`Uniform`][rtsim.sim.execution.Uniform] — uniform in [bcet, wcet]: the segment's ``bcet``; else,
for a task with a
  ``bcet``, that bcet scaled by ``segment.wcet / task.wcet``; else no variation (bcet = wcet);
- [`Empirical`][rtsim.sim.execution.Empirical] — measured times from a CSV file, replayed in file
order (job k of a task
  gets the k-th value of its (task, segment) column, cyclically; stateless) or bootstrapped
  (drawn with replacement). CSV columns: ``task``, optional ``segment``, ``exec_time`` (ms).
  A missing or empty ``segment`` means the task's only segment (named after the task).
  Segments without measurements use the ``fallback`` model (WCET by default);
- any callable with the signature above, e.g. e_hough from the beams counted at the scan.

Randomness: all of it comes from one seed. Each task gets its own child generator,
``SeedSequence(entropy=<seed entropy>, spawn_key=(crc32(task name),))``
([`task_rngs`][rtsim.sim.execution.task_rngs]), so
a task's draws depend only on the seed and its name: adding, removing or re-prioritising another
task never reshuffles them, and the same seed gives the identical trace.
"""

from __future__ import annotations

import itertools
import math
import operator
import os
import zlib
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, Protocol

import numpy as np

from rtsim._numbers import is_int
from rtsim.errors import InputError
from rtsim.model.task import Segment
from rtsim.registry import Registry

if TYPE_CHECKING:
    from rtsim.sim.job import Job

__all__ = [
    "EXEC_MODELS",
    "ExecModel",
    "ExecSpec",
    "WCET",
    "Uniform",
    "Empirical",
    "resolve_exec_model",
    "base_seed_sequence",
    "task_rngs",
    "jitter_rngs",
    "UNIFORM_BLOCK",
    "uniforms",
]

#: How many uniforms `uniforms` takes from its generator at a time.
UNIFORM_BLOCK = 1024


class ExecModel(Protocol):
    """Execution time (ms) of ``segment`` of ``job``, drawn from ``rng`` if random."""

    def __call__(self, job: Job, segment: Segment, rng: np.random.Generator) -> float: ...


#: What ``simulate(exec_model=...)`` accepts: a name (``"wcet"``, ``"uniform"``) or a model.
ExecSpec = str | ExecModel | Callable[..., float]


@dataclass(frozen=True)
class WCET:
    """Every segment runs exactly its worst-case execution time."""

    name: str = "wcet"

    def __call__(self, job: Job, segment: Segment, rng: np.random.Generator) -> float:
        return segment.wcet


def segment_bcet(job: Job, segment: Segment) -> float:
    """The best case used by [`Uniform`][rtsim.sim.execution.Uniform] (see the module docstring)."""
    if segment.bcet is not None:
        return segment.bcet
    task = job.task
    if task.bcet is not None and task.wcet > 0:
        return task.bcet * segment.wcet / task.wcet
    return segment.wcet


@dataclass(frozen=True)
class Uniform:
    """Uniform in [bcet, wcet] per segment (one draw from the task's generator per segment)."""

    name: str = "uniform"

    def __call__(self, job: Job, segment: Segment, rng: np.random.Generator) -> float:
        lo = segment_bcet(job, segment)
        if lo >= segment.wcet:
            return segment.wcet
        return float(rng.uniform(lo, segment.wcet))


@dataclass(frozen=True)
class Empirical:
    """Measured execution times, replayed in order or bootstrapped (see module docstring)."""

    samples: Mapping[tuple[str, str], tuple[float, ...]]
    mode: Literal["replay", "bootstrap"] = "replay"
    fallback: Callable[..., float] = field(default_factory=WCET)
    name: str = "empirical"

    def __post_init__(self) -> None:
        if self.mode not in ("replay", "bootstrap"):
            raise InputError(
                f"empirical exec model: mode must be replay or bootstrap, got {self.mode!r}"
            )
        for key, values in self.samples.items():
            if not values:
                raise InputError(f"empirical exec model: no samples for {key}")

    @classmethod
    def from_csv(
        cls,
        path: str | os.PathLike[str],
        mode: Literal["replay", "bootstrap"] = "replay",
        fallback: Callable[..., float] | None = None,
    ) -> Empirical:
        """Read ``task[, segment], exec_time`` rows (ms) from a CSV file."""
        import pandas as pd

        try:
            df = pd.read_csv(path)
        except (OSError, ValueError) as exc:
            raise InputError(f"{path}: cannot read execution times: {exc}") from None
        for col in ("task", "exec_time"):
            if col not in df.columns:
                raise InputError(
                    f"{path}: missing column '{col}' (need task, [segment,] exec_time)"
                )
        segs: Iterable[Any] = df["segment"] if "segment" in df.columns else [None] * len(df)
        samples: dict[tuple[str, str], list[float]] = {}
        for row, (task, seg, value) in enumerate(
            zip(df["task"], segs, df["exec_time"], strict=True)
        ):
            try:
                v = float(value)
            except (TypeError, ValueError):
                v = math.nan
            if not math.isfinite(v) or v < 0:
                raise InputError(
                    f"{path}: row {row + 2}: exec_time must be a non-negative number, got {value!r}"
                )
            seg_name = (
                str(task)
                if seg is None or (isinstance(seg, float) and math.isnan(seg)) or seg == ""
                else str(seg)
            )
            samples.setdefault((str(task), seg_name), []).append(v)
        return cls(
            {k: tuple(v) for k, v in samples.items()},
            mode,
            WCET() if fallback is None else fallback,
        )

    def __call__(self, job: Job, segment: Segment, rng: np.random.Generator) -> float:
        values = self.samples.get((job.name, segment.name))
        if values is None:
            return self.fallback(job, segment, rng)
        if self.mode == "replay":
            return values[job.index % len(values)]
        return values[int(rng.integers(len(values)))]


def _exec_model(obj: Any, spec: str, where: str) -> Callable[..., float]:
    """A loaded model: a class is instantiated; the result must be callable."""
    model = obj() if isinstance(obj, type) else obj
    if not callable(model):
        raise InputError(
            f"{where} is not an execution-time model (a callable model(job, segment, rng) -> ms)"
        )
    return model  # type: ignore[no-any-return]


#: The execution-time models by name (entry-point group ``rtsim.exec_models``; an entry point
#: names a model, or a class whose instances are models).
EXEC_MODELS: Registry[Callable[..., float]] = Registry(
    "execution-time model", "rtsim.exec_models", _exec_model
)
EXEC_MODELS.register("wcet", WCET())
EXEC_MODELS.register("uniform", Uniform())


def resolve_exec_model(spec: ExecSpec, *, allow_code: bool | None = None) -> Callable[..., float]:
    """A model from a name (``wcet``, ``uniform``, an entry point, ``package.module:Name``) or
    a callable (returned as is)."""
    if isinstance(spec, str):
        return EXEC_MODELS.resolve(spec, "exec model", allow_code=allow_code)
    if not callable(spec):
        raise InputError(f"exec model must be a name or a callable, got {spec!r}")
    return spec


def base_seed_sequence(
    seed: int | np.random.SeedSequence | np.random.Generator | None,
) -> np.random.SeedSequence:
    """The root SeedSequence of a run (a Generator contributes one 128-bit draw)."""
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if isinstance(seed, np.random.Generator):
        hi, lo = (int(x) for x in seed.integers(0, 2**63, size=2))
        return np.random.SeedSequence((hi << 64) | lo)
    if seed is None:
        seed = 0
    if not is_int(seed) or seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed!r}")
    return np.random.SeedSequence(int(seed))


def jitter_rngs(
    seed: int | np.random.SeedSequence | np.random.Generator | None, names: Iterable[str]
) -> dict[str, np.random.Generator]:
    """One release-delay generator per task: spawn key (…, crc32(name), 1), a stream apart
    from the task's execution-time generator, so jitter never reshuffles execution times."""
    base = base_seed_sequence(seed)
    out: dict[str, np.random.Generator] = {}
    for name in names:
        key = tuple(base.spawn_key) + (zlib.crc32(name.encode("utf-8")), 1)
        child = np.random.SeedSequence(entropy=base.entropy, spawn_key=key)
        out[name] = np.random.Generator(np.random.PCG64(child))
    return out


def uniforms(rng: np.random.Generator, block: int = UNIFORM_BLOCK) -> Iterator[float]:
    """``rng``'s uniforms on [0, 1) as floats, one per ``next``: the numbers one
    ``rng.random()`` call per draw gives, in the same order (a Generator's ``random(N)`` is
    its N single draws concatenated), taken ``block`` at a time, so that a draw costs a
    ``next`` instead of a numpy call; ``rng`` itself runs ahead by up to a block. (An
    iterator of C parts, each block's ``rng.random(block).tolist()`` chained: a ``next``
    resumes no Python frame, as a generator's would.)"""
    blocks = map(operator.methodcaller("random", block), itertools.repeat(rng))
    return itertools.chain.from_iterable(map(np.ndarray.tolist, blocks))


def task_rngs(
    seed: int | np.random.SeedSequence | np.random.Generator | None, names: Iterable[str]
) -> dict[str, np.random.Generator]:
    """One child generator per task, keyed by a stable hash of its name (see module doc)."""
    base = base_seed_sequence(seed)
    out: dict[str, np.random.Generator] = {}
    for name in names:
        key = tuple(base.spawn_key) + (zlib.crc32(name.encode("utf-8")),)
        child = np.random.SeedSequence(entropy=base.entropy, spawn_key=key)
        out[name] = np.random.Generator(np.random.PCG64(child))
    return out
