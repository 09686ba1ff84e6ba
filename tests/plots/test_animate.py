"""rtsim animate: a scenario run rendered to GIF (60 simulated seconds, as CI requires), HTML,
and the errors; the beam geometry against a hand computation."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rtsim.animate import hit_beams, window_view
from rtsim.cli import main


@pytest.fixture(scope="module")
def run60(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("anim") / "t2"
    assert main(["scenario", "test2", "--duration", "60", "--no-figures", "--out", str(out)]) == 0
    return out


def test_beams_hitting_a_disc_match_the_hand_count() -> None:
    # a 25 cm disc 150 cm ahead: half-width asin(25/150) = 9.594°, beams at -9.5°..9.5° = 39
    # (SPEC: 38-39 beams hit a 25 cm disc at 150 cm; Eq 2's 2·atan(25/150)/0.5° = 37.85)
    angles = hit_beams(np.array([0.0, 0.0, 0.0]), np.array([150.0, 0.0]), 25.0)
    assert len(angles) == 39
    assert math.degrees(angles.min()) == pytest.approx(-9.5)
    turned = hit_beams(
        np.array([10.0, 5.0, 1.0]),
        np.array([10.0, 5.0]) + 150 * np.array([math.cos(1.3), math.sin(1.3)]),
        25.0,
    )
    assert len(turned) in (38, 39, 40)
    assert len(hit_beams(np.zeros(3), np.array([10.0, 0.0]), 25.0)) == 0  # leader inside


@pytest.mark.slow
def test_sixty_simulated_seconds_render_to_gif(run60: Path, tmp_path: Path) -> None:
    from PIL import Image

    windows = pd.read_csv(run60 / "windows.csv")
    assert windows["t"].max() / 1000 > 59
    out = tmp_path / "run.gif"
    assert main(["animate", str(run60), "--out", str(out), "--every", "3", "-q"]) == 0
    with Image.open(out) as im:
        assert im.n_frames == math.ceil(len(windows) / 3)
        assert im.size == (640, 576)
        im.seek(0)
        first = np.asarray(im.convert("RGB"), dtype=float)
        im.seek(im.n_frames // 2)
        middle = np.asarray(im.convert("RGB"), dtype=float)
    assert np.mean(np.any(first < 200, axis=-1)) > 0.02  # something is drawn
    assert np.abs(first - middle).mean() > 1.0  # and it moves


def test_html_animation_of_a_range_and_the_reader(run60: Path, tmp_path: Path) -> None:
    out = tmp_path / "run.html"
    assert (
        main(["animate", str(run60), "--out", str(out), "--start", "30", "--end", "31", "-q"]) == 0
    )
    text = out.read_text("utf-8")
    windows = pd.read_csv(run60 / "windows.csv")
    t = windows["t"] / 1000
    frames = int(((t >= 30) & (t <= 31)).sum())
    assert frames >= 3
    assert "<script" in text and text.count("data:image/png;base64") == frames
    view = window_view(windows)
    assert view.n == 2 and view.truth.shape == (len(windows), 2, 2)
    assert np.array_equal(view.truth[:, 1, 0], windows["f2_x"].to_numpy())
    assert np.array_equal(view.estimate[:, 0, 1], windows["f1_y_est"].to_numpy())


def test_mp4_renders_and_decodes_back_frame_by_frame(run60: Path, tmp_path: Path) -> None:
    """The MP4 path for real: rendered through imageio-ffmpeg's ffmpeg (a test dependency),
    then decoded by the same ffmpeg, which must find one frame per window in the range."""
    import re
    import subprocess

    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    out = tmp_path / "run.mp4"
    assert (
        main(
            [
                "animate",
                str(run60),
                "--out",
                str(out),
                "--start",
                "10",
                "--end",
                "12",
                "--fps",
                "5",
                "-q",
            ]
        )
        == 0
    )
    windows = pd.read_csv(run60 / "windows.csv")
    t = windows["t"] / 1000
    frames = int(((t >= 10) & (t <= 12)).sum())
    assert frames >= 5
    proc = subprocess.run(
        [imageio_ffmpeg.get_ffmpeg_exe(), "-v", "info", "-i", str(out), "-f", "null", "-"],
        capture_output=True,
        text=True,
        check=True,
    )
    decoded = re.findall(r"frame=\s*(\d+)", proc.stderr)
    assert decoded and int(decoded[-1]) == frames, proc.stderr[-500:]
    assert "Video: h264" in proc.stderr or "Video: mpeg4" in proc.stderr, proc.stderr[-800:]
    assert not list(tmp_path.glob("*.tmp*"))


def test_animate_input_errors(run60: Path, tmp_path: Path, capsys, monkeypatch) -> None:
    assert main(["animate", str(tmp_path), "--out", str(tmp_path / "a.gif")]) == 2
    assert "not a scenario run directory (no windows.csv" in capsys.readouterr().err
    assert main(["animate", str(run60), "--out", str(tmp_path / "a.avi")]) == 2
    assert "ends in .avi, but it is written as gif or mp4 or html" in capsys.readouterr().err
    assert (
        main(
            [
                "animate",
                str(run60),
                "--out",
                str(tmp_path / "a.gif"),
                "--start",
                "500",
                "--end",
                "600",
            ]
        )
        == 2
    )
    assert "no window between 500.0 and 600.0 s" in capsys.readouterr().err
    import shutil
    import sys

    monkeypatch.setattr(shutil, "which", lambda name: None)
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)
    assert main(["animate", str(run60), "--out", str(tmp_path / "a.mp4")]) == 2
    assert "MP4 needs ffmpeg" in capsys.readouterr().err
    assert not list(tmp_path.glob("a.*"))
