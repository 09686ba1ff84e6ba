"""report.html per run, opened in a real headless Chromium: it renders, every image loads,
the console stays clean, and the screenshot is not blank.

Skipped where no Chromium is installed, except when ``RTSIM_REQUIRE_BROWSER=1`` (set by
``.ci/run``, which installs Debian's chromium): then a missing browser is a failure.
"""

from __future__ import annotations

import io
import os
import re
from pathlib import Path

import numpy as np
import pytest
from chromium_cdp import find_chromium, load_page

from rtsim.cli import main


def _chromium() -> str:
    exe = find_chromium()
    if exe is None:
        if os.environ.get("RTSIM_REQUIRE_BROWSER") == "1":
            pytest.fail("RTSIM_REQUIRE_BROWSER=1 but no chromium found (apt-get install chromium)")
        pytest.skip("no chromium installed (set RTSIM_REQUIRE_BROWSER=1 to require it)")
    return exe


def _self_contained(report: Path, images: bool = True) -> None:
    text = report.read_text("utf-8")
    srcs = re.findall(r"src='([^']*)'", text)
    assert bool(srcs) == images
    assert all(s.startswith("data:image/png;base64,") for s in srcs)
    assert "http://" not in text and "https://" not in text
    for href in re.findall(r"href='([^']*)'", text):  # every data link resolves
        assert (report.parent / href).is_file(), href


def _check_in_browser(report: Path, n_images: int) -> None:
    page = load_page(report.resolve().as_uri(), _chromium())
    assert page.title.startswith("rtsim ")
    assert len(page.images) == n_images
    broken = [i["alt"] for i in page.images if not (i["complete"] and i["width"] > 0)]
    assert not broken, f"images that did not load: {broken}"
    assert page.console_errors == []
    import matplotlib.image as mpimg

    px = mpimg.imread(io.BytesIO(page.screenshot_png), format="png")[..., :3]
    assert px.shape[0] > 1000 and px.shape[1] >= 1000  # the full page, not a blank viewport
    ink = np.mean(np.any(px < 0.9, axis=-1))
    assert ink > 0.01, f"screenshot nearly blank ({ink:.1%} non-white pixels)"
    assert float(px.std()) > 0.05


def test_scenario_report_renders_in_chromium(tmp_path: Path) -> None:
    out = tmp_path / "run"
    assert main(["scenario", "test1", "--duration", "20", "--out", str(out)]) == 0
    report = out / "report.html"
    text = report.read_text("utf-8")
    for part in ("<h2>Summary</h2>", "<h2>Figures</h2>", "<h2>Assumptions</h2>",
                 "<h2>Data files</h2>", "<h2>Manifest</h2>", "thresholds.T_eps",
                 "windows.csv", "critical_share"):
        assert part in text, part
    _self_contained(report)
    pngs = sorted(out.glob("*.png"))
    from rtsim.plots.scenario import SCENARIO_FIGURES

    assert len(pngs) == len(SCENARIO_FIGURES)
    _check_in_browser(report, len(pngs))


@pytest.mark.slow
def test_validate_report_renders_in_chromium(tmp_path: Path) -> None:
    out = tmp_path / "val"
    assert main(["validate", "--quick", "--out", str(out), "--workers", "1", "--quiet"]) == 0
    report = out / "report.html"
    text = report.read_text("utf-8")
    assert "Findings (report.md)" in text and "validation.csv" in text
    assert "/points/" not in text  # the sweep's per-point records are not listed
    _self_contained(report)
    _check_in_browser(report, len(list(out.rglob("*.png"))))


@pytest.mark.slow
def test_reproduce_reports_render_in_chromium(tmp_path: Path) -> None:
    out = tmp_path / "paper"
    assert main(["reproduce", "--duration", "10", "--workers", "1", "--quiet",
                 "--out", str(out)]) == 0
    report = out / "report.html"
    text = report.read_text("utf-8")
    assert "<h2>Summary</h2>" in text and "fixed-wsch" in text and "min_msb_over_wsch" in text
    _self_contained(report)
    _check_in_browser(report, len(list(out.rglob("*.png"))))
    run = out / "test2" / "adjust" / "report.html"  # each run has its own page
    assert "Assumptions" in run.read_text("utf-8")
    _self_contained(run, images=False)  # a run directory of the reproduction has no PNG
