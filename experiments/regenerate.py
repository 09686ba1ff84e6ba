"""Regenerate every results table the documentation quotes, from the runs themselves.

    python experiments/regenerate.py --out DIR [--only NAME[,NAME...]] [--docs docs]
    python experiments/regenerate.py --quote     # only re-quote the tables from docs/results

Runs, each into ``DIR/<name>``:

* ``reproduction``: ``rtsim reproduce`` (Test 1 and Test 2; the paper's three modes, adjust on
  the paper's predictor, and plan beside them; seed 0, one lap);
* ``predictors``: ``experiments/predictors.py`` (adjust on each predictor, seed 0);
* ``policies``: ``experiments/policies.py`` (every policy, n = 2 and 4, seeds 0-4);
* ``followers``: ``experiments/followers.py`` (n = 1..10, r_H = 15-50 cm, seeds 0-4);
* ``clearance``: ``experiments/clearance.py`` (n = 6..10 with the clearance, seeds 13-37);
* ``thresholds``: ``experiments/thresholds.py`` (T_ε, T_ρ, T_β, the bearing offset);

then copies each one's summary table into the documentation, ``<docs>/results/<name>.csv``,
and its figures into ``<docs>/figures`` (the paper's figures, the policies'
Pareto plot, the followers' and the thresholds' figures), and rewrites every block of the
documentation's pages that quotes it with the table rendered from that CSV by the
experiment's own Markdown function::

    <!-- results: <name> -->
    ...the table...
    <!-- /results -->

``tests/project/test_results_current.py`` fails when a quoted block, or a table's Markdown,
no longer matches the last regenerated CSV. This is not the README's main command (which
writes only under its ``--out``): it rewrites files under ``docs/``. The whole set takes
about an hour of two cores; ``--only`` regenerates a part.
"""

from __future__ import annotations

import argparse
import importlib.util
import re
import shutil
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import pandas as pd

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

#: a quoted block in a documentation page
BLOCK = re.compile(r"(<!-- results: ([a-z_]+) -->\n)(.*?)(<!-- /results -->)", re.S)


def _experiment(name: str) -> ModuleType:
    """experiments/<name>.py as a module (the scripts are not a package)."""
    spec = importlib.util.spec_from_file_location(f"rtsim_experiment_{name}", HERE / f"{name}.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


@dataclass(frozen=True)
class Table:
    """One regenerated table: how to run it (``run(out_dir)``), which CSV of its output is
    the table, and how that CSV renders as Markdown (``markdown(frame)``)."""

    name: str
    run: Callable[[Path], int]
    csv: str
    markdown: Callable[[pd.DataFrame], str]
    #: figures of its output copied to <docs>/figures: (file in the output, name in docs)
    figures: tuple[tuple[str, str], ...] = ()


def _reproduce(out: Path) -> int:
    from rtsim.reproduce import ReproduceOptions, run

    docs = out.parent / "reproduction-docs-figures"
    rc = run(ReproduceOptions(out=out, quiet=True, workers=2, docs=docs))
    for png in sorted(docs.glob("*.png")) if rc == 0 else ():
        shutil.copyfile(png, out / png.name)
    return rc


def _script(name: str) -> Callable[[Path], int]:
    def run(out: Path) -> int:
        return int(_experiment(name).main(["--out", str(out)]))

    return run


def _script_markdown(name: str) -> Callable[[pd.DataFrame], str]:
    def md(df: pd.DataFrame) -> str:
        return str(_experiment(name).markdown(df)).rstrip("\n") + "\n"

    return md


def _predictors(out: Path) -> int:
    out.mkdir(parents=True, exist_ok=True)
    return int(_experiment("predictors").main(["--out", str(out / "predictors.csv")]))


def _docs_figures() -> tuple[str, ...]:
    from rtsim.reproduce import DOCS_FIGURES

    return DOCS_FIGURES


def _reproduce_markdown(df: pd.DataFrame) -> str:
    from rtsim.reproduce import summary_markdown

    return summary_markdown(df)


TABLES: dict[str, Table] = {
    t.name: t
    for t in (
        Table(
            "reproduction",
            _reproduce,
            "summary.csv",
            _reproduce_markdown,
            tuple((stem + ".png", stem + ".png") for stem in _docs_figures()),
        ),
        Table("predictors", _predictors, "predictors.csv", _script_markdown("predictors")),
        Table(
            "policies",
            _script("policies"),
            "policies_summary.csv",
            _script_markdown("policies"),
            (("pareto.png", "policies_pareto.png"),),
        ),
        Table(
            "followers",
            _script("followers"),
            "followers_summary.csv",
            _script_markdown("followers"),
            (("followers.png", "followers.png"),),
        ),
        Table(
            "clearance",
            _script("clearance"),
            "clearance_summary.csv",
            _script_markdown("clearance"),
        ),
        Table(
            "thresholds",
            _script("thresholds"),
            "thresholds_summary.csv",
            _script_markdown("thresholds"),
            (("thresholds.png", "thresholds.png"),),
        ),
    )
}


def read_table(path: Path) -> pd.DataFrame:
    """A regenerated CSV as the experiment wrote it (empty strings stay strings)."""
    return pd.read_csv(path, keep_default_na=False, na_values=["nan", "NaN", ""])


def table_markdown(name: str, results: Path) -> str:
    """The Markdown of table ``name`` rendered from ``<results>/<name>.csv``."""
    return TABLES[name].markdown(read_table(results / f"{name}.csv"))


def quote(docs: Path) -> list[Path]:
    """Rewrite every quoted block under ``docs`` and in the README beside it from
    ``docs/results/<name>.csv`` (rendered by :func:`table_markdown`); returns the pages
    changed."""
    from rtsim.io.atomic import write_text

    results = docs / "results"
    changed = []
    readme = docs.parent / "README.md"
    for page in sorted(docs.rglob("*.md")) + ([readme] if readme.is_file() else []):
        if results in page.parents:
            continue
        text = page.read_text("utf-8")

        def sub(m: re.Match[str]) -> str:
            name = m.group(2)
            known = name in TABLES and (results / f"{name}.csv").is_file()
            body = table_markdown(name, results) if known else m.group(3)
            return m.group(1) + body + m.group(4)

        new = BLOCK.sub(sub, text)
        if new != text:
            write_text(page, new)
            changed.append(page)
    return changed


def regenerate(name: str, out: Path, docs: Path) -> dict[str, Any]:
    """Run table ``name`` into ``out/name`` and copy its CSV into docs/results, its figures
    into docs/figures."""
    t0 = time.perf_counter()
    table = TABLES[name]
    rc = table.run(out / name)
    if rc != 0:
        raise SystemExit(f"regenerate: {name} exited with {rc}")
    results = docs / "results"
    results.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(out / name / table.csv, results / f"{name}.csv")
    for src, dst in table.figures:
        (docs / "figures").mkdir(parents=True, exist_ok=True)
        shutil.copyfile(out / name / src, docs / "figures" / dst)
    return {"name": name, "seconds": time.perf_counter() - t0}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", metavar="DIR", help="where the runs write (required unless --quote)")
    p.add_argument(
        "--only",
        metavar="NAME[,NAME...]",
        default=",".join(TABLES),
        help=f"tables to regenerate (default all: {', '.join(TABLES)})",
    )
    p.add_argument("--docs", metavar="DIR", default=str(ROOT / "docs"), help="docs directory")
    p.add_argument(
        "--quote",
        action="store_true",
        help="run nothing: only rewrite the quoted blocks from the CSVs in <docs>/results",
    )
    args = p.parse_args(argv)
    if args.quote:
        for page in quote(Path(args.docs)):
            print(f"updated {page}", file=sys.stderr)
        return 0
    if args.out is None:
        print("regenerate: --out DIR is required (or --quote)", file=sys.stderr)
        return 2
    names = [n for n in args.only.split(",") if n]
    unknown = [n for n in names if n not in TABLES]
    if unknown:
        print(f"regenerate: --only: unknown table {unknown[0]!r}", file=sys.stderr)
        return 2
    out, docs = Path(args.out), Path(args.docs)
    for name in names:
        done = regenerate(name, out, docs)
        print(f"{name}: {done['seconds']:.0f} s", file=sys.stderr)
    for page in quote(docs):
        print(f"updated {page}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
