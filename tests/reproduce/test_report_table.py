"""report.html's summary table of a reproduction: full column names, and narrow enough for the
page (one column per run, not one per quantity; issue 34)."""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd

from rtsim.report import column_title, render_run_report
from rtsim.reproduce import SUMMARY_COLUMNS


def test_every_summary_column_has_a_full_name() -> None:
    short = [c for c in SUMMARY_COLUMNS if c not in ("test", "mode")]
    assert all(column_title(c) != c or c in ("seed", "predictor") for c in short)
    assert column_title("viol5") == "window-follower pairs with a bound broken by more than 5 %"
    assert column_title("viol5_path_diversion").endswith(": path diversion bound")
    assert column_title("something_else") == "something_else"


def test_the_summary_table_is_one_column_per_run(tmp_path: Path) -> None:
    rows = [
        {c: (t if c == "test" else m if c == "mode" else 1.5) for c in SUMMARY_COLUMNS}
        for t in ("test1", "test2")
        for m in ("adjust", "fixed-wsch", "min-msb")
    ]
    pd.DataFrame(rows, columns=list(SUMMARY_COLUMNS)).to_csv(tmp_path / "summary.csv", index=False)
    html = render_run_report(tmp_path, title="rtsim reproduce")
    table = html[html.index("<h2>Summary</h2>") :]
    table = table[: table.index("</table>")]
    header = re.findall(r"<th>([^<]*)</th>", table[: table.index("</tr>")])
    assert header == [
        "",
        *(f"{t} / {m}" for t in ("test1", "test2") for m in ("adjust", "fixed-wsch", "min-msb")),
    ]
    assert "window-follower pairs with a bound broken by more than 5 % (viol5)" in table
    assert table.count("<tr>") == 1 + len(SUMMARY_COLUMNS) - 2
