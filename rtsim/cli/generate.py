"""``rtsim generate``: random task-set TOML files (UUniFast / UUniFast-Discard periods).

    rtsim generate --tasks N --utilization U --periods loguniform:10..1000|10,20,40 \
                   --count K --seed S --out DIR

writes ``DIR/set_0000.toml`` … (readable by
[`rtsim.config.taskset.load_taskset`][rtsim.config.taskset.load_taskset]) and
``DIR/manifest.json``. Set i is drawn from the i-th child of ``SeedSequence(S)``, so set i
does not depend on ``--count``.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import numpy as np

from rtsim.cli.common import add_json, add_quiet
from rtsim.config.taskset import load_taskset
from rtsim.errors import InputError
from rtsim.io.atomic import dumps, write_text
from rtsim.io.manifest import write_manifest
from rtsim.io.outdir import stage
from rtsim.model.generate import PeriodSpec, parse_periods, random_taskset
from rtsim.model.taskset import TaskSet

__all__ = ["register", "run", "taskset_toml"]


def register(sub: Any) -> None:
    """Add the ``generate`` sub-command."""
    p = sub.add_parser(
        "generate",
        help="write random task-set files (UUniFast)",
        description=__doc__.splitlines()[0],
    )
    p.add_argument("--tasks", type=int, required=True, help="tasks per set")
    p.add_argument(
        "--utilization",
        type=float,
        required=True,
        help="total utilization (UUniFast-Discard above 1)",
    )
    p.add_argument(
        "--periods", default="loguniform:10..1000", help="loguniform:LO..HI or a list 10,20,40 (ms)"
    )
    p.add_argument(
        "--granularity",
        type=float,
        default=None,
        help="round log-uniform periods to a multiple of this (ms)",
    )
    p.add_argument(
        "--deadlines",
        default="implicit",
        help="implicit (default) or constrained:A..B, D uniform in [A·p, B·p]",
    )
    p.add_argument("--count", type=int, default=1, help="number of sets")
    p.add_argument("--seed", type=int, default=0, help="random seed")
    p.add_argument("--out", required=True, help="output directory")

    add_json(p, "print the files written as one JSON object")
    add_quiet(p, "no line saying what was written")
    p.set_defaults(func=run)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"cannot write {v!r} to TOML")
        return repr(v)
    s = str(v).replace("\\", "\\\\").replace('"', '\\"')
    return f'"{s}"'


def taskset_toml(ts: TaskSet, comment: str = "") -> str:
    """A plain (window-less) task set as TOML text in the file format of rtsim.config.taskset."""
    if ts.window is not None:
        raise InputError("taskset_toml: sets with a [window] are not supported")
    lines = [f"# {line}" for line in comment.splitlines()]
    lines.append(f"name = {_toml_value(ts.name)}")
    for t in ts.tasks:
        lines += [
            "",
            "[[tasks]]",
            f"name = {_toml_value(t.name)}",
            f"wcet = {_toml_value(t.wcet)}",
            f"period = {_toml_value(t.period)}",
            f"deadline = {_toml_value(t.deadline)}",
            f"priority = {_toml_value(t.priority)}",
        ]
        if t.offset:
            lines.append(f"offset = {_toml_value(t.offset)}")
        if t.bcet is not None:
            lines.append(f"bcet = {_toml_value(t.bcet)}")
        if t.overload != "finish-late":
            lines.append(f"overload = {_toml_value(t.overload)}")
    return "\n".join(lines) + "\n"


def _deadline_factor(text: str) -> tuple[float, float]:
    if text == "implicit":
        return (1.0, 1.0)
    if text.startswith("constrained:") and ".." in text:
        a, b = text.split(":", 1)[1].split("..", 1)
        try:
            fa, fb = float(a), float(b)
        except ValueError:
            fa = fb = math.nan
        if 0 < fa <= fb <= 1:
            return (fa, fb)
    raise InputError(
        f"--deadlines: expected implicit or constrained:A..B with 0 < A <= B <= 1, got {text!r}"
    )


def run(args: argparse.Namespace) -> int:
    """Write the sets and the manifest (a whole directory); print the directory."""
    if args.tasks < 1:
        raise InputError(f"--tasks must be at least 1, got {args.tasks}")
    if not (math.isfinite(args.utilization) and args.utilization > 0):
        raise InputError(f"--utilization must be positive, got {args.utilization:g}")
    if args.count < 1:
        raise InputError(f"--count must be at least 1, got {args.count}")
    if args.seed < 0:
        raise InputError(f"--seed must be non-negative, got {args.seed}")
    spec = parse_periods(args.periods)
    if args.granularity is not None:
        if not (args.granularity > 0):
            raise InputError(f"--granularity must be positive, got {args.granularity:g}")
        spec = PeriodSpec(spec.lo, spec.hi, spec.choices, args.granularity)
    factor = _deadline_factor(args.deadlines)

    with stage(args.out, command="generate") as staged:
        files = _write_sets(args, staged.path, spec, factor)
        staged.commit()
    if args.json:
        print(dumps({"out": str(args.out), "files": files}))
    elif not args.quiet:
        print(f"wrote {len(files)} task set(s) to {args.out}")
    return 0


def _readable(args: argparse.Namespace, path: Path) -> None:
    """Read the set just written as ``analyze`` and ``simulate`` will (their ranges, e.g. a
    period of 1 µs to 11.6 days): a set they would refuse is not written (the staging goes),
    the refusal is one line naming the options and the reader's first problem."""
    try:
        load_taskset(path)
    except InputError as exc:
        first = (getattr(exc, "lines", None) or [str(exc)])[0]
        why = first.split(": ", 1)[1] if first.startswith(str(path)) else first
        raise InputError(
            f"--periods {args.periods}, --utilization {args.utilization:g}: makes sets that "
            f"the task-set reader refuses ({path.name}: {why})"
        ) from None


def _write_sets(
    args: argparse.Namespace, out: Path, spec: Any, factor: tuple[float, float]
) -> list[str]:
    """Write the sets and the manifest into ``out`` (the staging directory)."""
    import sys

    children = np.random.SeedSequence(args.seed).spawn(args.count)
    files = []
    for i, child in enumerate(children):
        rng = np.random.default_rng(child)
        ts = random_taskset(
            args.tasks, args.utilization, rng, spec, name=f"set_{i:04d}", deadline_factor=factor
        )
        name = f"set_{i:04d}.toml"
        write_text(
            out / name,
            taskset_toml(
                ts,
                f"rtsim generate: UUniFast U={args.utilization:g}, periods {args.periods}, "
                f"seed {args.seed}, set {i}",
            ),
        )
        _readable(args, out / name)
        files.append(name)
    write_manifest(
        out,
        command="generate",
        seed=args.seed,
        inputs={
            "tasks": args.tasks,
            "utilization": args.utilization,
            "periods": args.periods,
            "granularity": args.granularity,
            "deadlines": args.deadlines,
            "count": args.count,
        },
        argv=["rtsim", *sys.argv[1:]],
        extra={"outputs": files},
    )
    return files
