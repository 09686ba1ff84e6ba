"""The documentation's results are the last regenerated tables (experiments/regenerate.py):
every quoted block equals its table rendered from the regenerated CSV in docs/results."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
RESULTS = DOCS / "results"


def _regenerate():  # type: ignore[no-untyped-def]
    spec = importlib.util.spec_from_file_location(
        "regenerate", ROOT / "experiments" / "regenerate.py"
    )
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # (its dataclass looks its module up)
    spec.loader.exec_module(mod)
    return mod


REG = _regenerate()
PAGES = [p for p in sorted(DOCS.rglob("*.md")) if RESULTS not in p.parents] + [ROOT / "README.md"]
CSVS = sorted(RESULTS.glob("*.csv"))


def test_every_regenerated_table_is_known() -> None:
    assert CSVS
    for csv in CSVS:
        assert csv.stem in REG.TABLES, f"{csv}: not a table of experiments/regenerate.py"


def test_every_quoted_block_is_the_last_regenerated_table() -> None:
    seen = 0
    for page in PAGES:
        for m in REG.BLOCK.finditer(page.read_text("utf-8")):
            name = m.group(2)
            csv = RESULTS / f"{name}.csv"
            assert csv.is_file(), f"{page.name} quotes {name}, never regenerated"
            assert m.group(3) == REG.table_markdown(name, RESULTS), (
                f"{page.relative_to(ROOT)} quotes a stale {name} table: run "
                f"python experiments/regenerate.py --only {name} (or its quote step)"
            )
            seen += 1
    assert seen >= 1


def test_a_changed_number_is_caught(tmp_path: Path) -> None:
    """The check can fail: one number changed in a quoted copy no longer matches."""
    name = CSVS[0].stem
    table = REG.table_markdown(name, RESULTS)
    line = next(
        ln for ln in table.splitlines() if ln.startswith("| ") and any(c.isdigit() for c in ln)
    )
    digit = next(c for c in line if c.isdigit())
    bad = table.replace(line, line.replace(digit, str((int(digit) + 1) % 10), 1))
    page = tmp_path / "page.md"
    page.write_text(f"<!-- results: {name} -->\n{bad}<!-- /results -->\n", "utf-8")
    m = REG.BLOCK.search(page.read_text("utf-8"))
    assert m is not None and m.group(3) != table
