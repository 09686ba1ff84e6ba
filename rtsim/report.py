"""``report.html``: one self-contained page per run directory.

`write_run_report` reads what a run already wrote — ``summary.json`` (or
``summary.csv``), ``manifest.json``, the PNG figures, the data files — and writes
``report.html`` beside them: the summary table, the figures (embedded as base64 PNG, so the
page is one file that can be mailed or archived), the assumptions table (the scenario's
``[assumptions]``, from the manifest), links to the data files (relative, so the page works
where the directory is) and the manifest itself. Used by ``rtsim scenario``, ``rtsim
validate`` and ``rtsim reproduce``. Plain HTML and CSS: no script, no external resource.
"""

from __future__ import annotations

import base64
import html
import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from rtsim.io.atomic import atomic_path
from rtsim.notebook import flatten

__all__ = ["write_run_report", "render_run_report", "REPORT_NAME"]

REPORT_NAME = "report.html"
_DATA_SUFFIXES = (".csv", ".parquet", ".json", ".md", ".txt")
_CSS = """
body{font:14px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;margin:2em auto;
max-width:1100px;padding:0 1em;color:#222}
h1{font-size:1.6em}h2{font-size:1.25em;border-bottom:1px solid #ddd;padding-bottom:.2em}
table{border-collapse:collapse;margin:.5em 0;max-width:100%}th{overflow-wrap:anywhere}
td,th{border:1px solid #ccc;padding:.25em .6em;
text-align:left;vertical-align:top}th{background:#f3f3f3}td.num{text-align:right;
font-variant-numeric:tabular-nums}figure{margin:1em 0}img{max-width:100%;height:auto;
border:1px solid #eee}figcaption{color:#555;font-size:.9em}pre{background:#f7f7f7;
padding:.8em;overflow:auto;font-size:12px}.muted{color:#666}
"""


def _esc(v: Any) -> str:
    return html.escape(str(v), quote=True)


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return "nan" if math.isnan(v) else f"{v:.6g}"
    if v is None:
        return "–"
    return str(v)


def _kv_table(rows: Mapping[str, Any], header: tuple[str, str] = ("key", "value")) -> str:
    body = "".join(
        f"<tr><th>{_esc(k)}</th><td class='{'num' if isinstance(v, int | float) else ''}'>"
        f"{_esc(_fmt(v))}</td></tr>"
        for k, v in rows.items()
    )
    return f"<table><tr><th>{_esc(header[0])}</th><th>{_esc(header[1])}</th></tr>{body}</table>"


#: Full names of the short summary columns (rtsim reproduce's summary.csv); a bound kind's
#: column (``viol5_separation``) takes the bound's name after its kind's title.
COLUMN_TITLES: dict[str, str] = {
    "viol5": "window-follower pairs with a bound broken by more than 5 %",
    "max_viol_ratio": "largest violation ratio (the world's bound over the predicted one)",
    "viol": "window-follower pairs with a bound broken",
    "missed": "deadline misses",
    "tracks_lost": "lost tracks",
    "seed": "seed",
    "duration_s": "simulated time (s)",
    "laps": "laps the leader drove",
    "w_sch": "lower bound w_sch (ms)",
    "windows": "processing windows",
    "critical_share": "share of critical windows",
    "min_msb_over_wsch": "smallest MSB over w_sch",
    "min_speed_ratio": "lowest leader speed over V_Ld",
    "methods": "how the windows were chosen",
    "predictor": "predictor",
    "formation_model": "follower model",
    "max_response": "longest window response (ms)",
    "wall_s": "wall-clock time (s)",
    "lap_time_s": "lap time (s)",
    "lap_oracle_s": "oracle lap: the fastest that keeps every bound (s)",
    "lap_over_oracle": "lap over the oracle lap",
    "collisions": "collisions (samples with two robots' discs overlapping)",
    "min_robot_distance_cm": "closest approach of two robots, centre to centre (cm)",
    "separation_binds": "critical windows where the separation bound binds",
    "critical_windows": "critical windows (a bound below w_sch)",
}


def column_title(name: str) -> str:
    """The full name of a summary column (``viol5_separation`` → "… by more than 5 %:
    separation bound"); a name without one is returned as it is."""
    if name in COLUMN_TITLES:
        return COLUMN_TITLES[name]
    for short in sorted(COLUMN_TITLES, key=len, reverse=True):
        if name.startswith(short + "_"):
            kind = name[len(short) + 1 :].replace("_", " ")
            return f"{COLUMN_TITLES[short]}: {kind} bound"
    return name


def _frame_table(columns: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    head = "".join(f"<th>{_esc(c)}</th>" for c in columns)
    body = "".join(
        "<tr>"
        + "".join(
            f"<td class='{'num' if isinstance(v, int | float) else ''}'>{_esc(_fmt(v))}</td>"
            for v in r
        )
        + "</tr>"
        for r in rows
    )
    return f"<table><tr>{head}</tr>{body}</table>"


def _flatten(obj: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    return flatten(obj, prefix)


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text("utf-8"))
    except (OSError, ValueError):
        return None


def _summary_section(run_dir: Path) -> str:
    summary = _read_json(run_dir / "summary.json")
    if isinstance(summary, dict):
        flat = {k: v for k, v in _flatten(summary).items() if not isinstance(v, list)}
        return "<h2>Summary</h2>" + _kv_table(flat)
    csv = run_dir / "summary.csv"
    if csv.exists():
        import pandas as pd

        df = pd.read_csv(csv)
        return "<h2>Summary</h2>" + _summary_columns(df)
    return "<h2>Summary</h2><p class='muted'>No summary.json or summary.csv.</p>"


def _summary_columns(df: Any) -> str:
    """A summary table turned on its side so that it fits the page: one row per column of
    ``df`` under its full name (`column_title`, the short name beside it), one column
    per run (headed by its test and mode, or its row number)."""
    label = [c for c in ("test", "mode") if c in df.columns]
    heads = [
        " / ".join(str(r[c]) for c in label) if label else f"run {i + 1}"
        for i, (_, r) in enumerate(df.iterrows())
    ]
    values = df.astype(object).where(df.notna(), None)
    rows = [
        [f"{column_title(str(c))} ({c})" if column_title(str(c)) != str(c) else str(c)]
        + list(values[c])
        for c in df.columns
        if c not in label
    ]
    return _frame_table(["", *heads], rows)


def _assumptions(manifest: Any) -> dict[str, str]:
    """Every ``assumptions`` table found in the manifest's inputs (key -> reason)."""
    found: dict[str, str] = {}

    def walk(node: Any, where: str) -> None:
        if isinstance(node, dict):
            for k, v in node.items():
                if k == "assumptions" and isinstance(v, dict):
                    for ak, av in v.items():
                        found[f"{where}{ak}"] = str(av)
                else:
                    walk(v, f"{where}{k}: " if isinstance(v, dict) and where else where)
        elif isinstance(node, list):
            for e in node:
                walk(e, where)

    if isinstance(manifest, dict):
        walk(manifest.get("inputs", {}), "")
    return found


_MIME = {".png": "image/png", ".svg": "image/svg+xml"}


def _png(path: Path) -> str:
    """``path`` (a PNG or an SVG figure) as a data URL."""
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return f"data:{_MIME[path.suffix]};base64,{data}"


def render_run_report(
    run_dir: str | os.PathLike[str], *, title: str | None = None, extra_html: str = ""
) -> str:
    """The HTML text of ``run_dir``'s report (module docstring)."""
    d = Path(run_dir)
    manifest = _read_json(d / "manifest.json")
    if title is None:
        cmd = manifest.get("command", "run") if isinstance(manifest, dict) else "run"
        title = f"rtsim {cmd}: {d.name}"
    parts = [f"<h1>{_esc(title)}</h1>"]
    if isinstance(manifest, dict):
        parts.append(
            f"<p class='muted'>rtsim {_esc(manifest.get('rtsim_version', '?'))}, "
            f"seed {_esc(manifest.get('seed'))}, created "
            f"{_esc(manifest.get('created_utc', '?'))}; "
            f"<code>{_esc(' '.join(map(str, manifest.get('argv') or [])))}</code></p>"
        )
    parts.append(_summary_section(d))
    if extra_html:
        parts.append(extra_html)
    pngs = sorted(p for p in d.rglob("*") if p.is_file() and p.suffix in _MIME)
    if pngs:
        parts.append("<h2>Figures</h2>")
        for p in pngs:
            rel = p.relative_to(d).as_posix()
            parts.append(
                f"<figure><img src='{_png(p)}' alt='{_esc(rel)}'>"
                f"<figcaption>{_esc(rel)}</figcaption></figure>"
            )
    assumptions = _assumptions(manifest)
    if assumptions:
        parts.append(
            "<h2>Assumptions</h2><p class='muted'>Values the paper does not give, "
            "each with its reason (the scenario's <code>[assumptions]</code>).</p>"
            + _kv_table(assumptions, ("key", "reason"))
        )
    data = sorted(
        p
        for p in d.rglob("*")
        if p.is_file()
        and p.suffix in _DATA_SUFFIXES
        and p.name != REPORT_NAME
        and "/points/" not in f"/{p.relative_to(d)}"
    )
    if data:
        items = "".join(
            f"<li><a href='{_esc(p.relative_to(d).as_posix())}'>"
            f"{_esc(p.relative_to(d).as_posix())}</a> "
            f"<span class='muted'>({p.stat().st_size:,} bytes)</span></li>"
            for p in data
        )
        parts.append(f"<h2>Data files</h2><ul>{items}</ul>")
    if isinstance(manifest, dict):
        shown = json.dumps(manifest, indent=2, ensure_ascii=False, default=str)
        parts.append(
            "<h2>Manifest</h2><details><summary>manifest.json</summary>"
            f"<pre>{_esc(shown)}</pre></details>"
        )
    body = "\n".join(parts)
    return (
        f"<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
        f"<meta name='viewport' content='width=device-width, initial-scale=1'>"
        f"<title>{_esc(title)}</title><style>{_CSS}</style></head>"
        f"<body>\n{body}\n</body></html>\n"
    )


def write_run_report(
    run_dir: str | os.PathLike[str], *, title: str | None = None, extra_html: str = ""
) -> Path:
    """Write ``run_dir/report.html`` atomically and return its path."""
    target = Path(run_dir) / REPORT_NAME
    text = render_run_report(run_dir, title=title, extra_html=extra_html)
    # a path that is not UTF-8 (surrogates) shows its bytes as \xNN escapes
    text = text.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")
    with atomic_path(target) as tmp:
        Path(tmp).write_text(text, "utf-8")
    return target
