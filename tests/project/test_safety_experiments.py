"""experiments/thresholds.py and experiments/clearance.py, --quick (issue 33)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[2]


def _module(name: str):  # type: ignore[no-untyped-def]
    spec = importlib.util.spec_from_file_location(
        f"exp_{name}", ROOT / "experiments" / f"{name}.py"
    )
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def test_thresholds_quick(tmp_path: Path) -> None:
    """A row per run, the summary the runs' sums, the shipped value marked, the figure."""
    mod = _module("thresholds")
    assert mod.main(["--quick", "--out", str(tmp_path)]) == 0
    runs = pd.read_csv(tmp_path / "thresholds.csv")
    summ = pd.read_csv(tmp_path / "thresholds_summary.csv")
    assert len(runs) == 4 and set(runs["policy"]) == {"plan", "adjust"}
    assert set(runs.loc[runs["policy"] == "adjust", "predictor"]) == {"paper"}
    for r in summ.itertuples(index=False):
        sel = runs[(runs["value"] == r.value) & (runs["policy"] == r.policy)]
        assert r.viol5 == sel["viol5"].sum() and r.missed == sel["missed"].sum()
    assert summ.loc[summ["value"] == 0.025, "shipped"].all()
    assert not summ.loc[summ["value"] == 0.03, "shipped"].any()
    assert (tmp_path / "thresholds.png").stat().st_size > 0


def test_clearance_quick(tmp_path: Path) -> None:
    """Six followers run without contact; nine are refused before the run, in one line."""
    mod = _module("clearance")
    assert mod.main(["--quick", "--out", str(tmp_path)]) == 0
    summ = pd.read_csv(tmp_path / "clearance_summary.csv", keep_default_na=False)
    six = summ[summ["n"] == 6].iloc[0]
    assert six.runs == 1 and six.collisions == 0 and float(six.closest_min_cm) >= 60.0
    assert six.contact_breaks == 0
    nine = summ[summ["n"] == 9].iloc[0]
    assert nine.runs == 0 and "9 followers do not fit" in nine.refused
    assert "refused before the run" in (tmp_path / "clearance.md").read_text()


def test_regenerate_quotes_a_table(tmp_path: Path) -> None:
    """--quote rewrites a page's block from docs/results' CSV and leaves the rest alone."""
    reg = _module("regenerate")
    docs = tmp_path / "docs"
    (docs / "results").mkdir(parents=True)
    src = ROOT / "docs" / "results" / "clearance.csv"
    (docs / "results" / "clearance.csv").write_bytes(src.read_bytes())
    page = docs / "page.md"
    page.write_text("before\n<!-- results: clearance -->\nold\n<!-- /results -->\nafter\n")
    assert reg.main(["--quote", "--docs", str(docs)]) == 0
    text = page.read_text()
    assert text.startswith("before\n<!-- results: clearance -->\n| test | n |")
    assert text.endswith("<!-- /results -->\nafter\n")
    assert reg.table_markdown("clearance", docs / "results") in text
