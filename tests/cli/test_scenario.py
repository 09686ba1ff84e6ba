"""``rtsim scenario``: output files, determinism of the files, one-line errors (issue 5 §5)."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest

from rtsim.cli import main
from rtsim.coupling import window_columns

TEST2 = Path(__file__).resolve().parents[2] / "experiments" / "scenarios" / "test2.toml"


@pytest.fixture(scope="module")
def outs(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """Two identical runs (seed 5) and one with figures and Parquet."""
    dirs = [tmp_path_factory.mktemp(f"run{i}") for i in range(3)]
    base = ["scenario", str(TEST2), "--duration", "12", "--seed", "5"]
    assert main([*base, "--no-figures", "--out", str(dirs[0])]) == 0
    assert main([*base, "--no-figures", "--out", str(dirs[1])]) == 0
    assert main([*base, "--mode", "fixed-wsch", "--parquet", "--out", str(dirs[2])]) == 0
    return dirs


def test_writes_the_issue_files(outs: list[Path]) -> None:
    d = outs[2]
    for name in (
        "windows.csv",
        "windows.parquet",
        "jobs.csv",
        "summary.json",
        "manifest.json",
        "paths.png",
        "window_slack.png",
        "bounds.png",
        "speed.png",
        "operating_space.png",
    ):
        assert (d / name).is_file() and (d / name).stat().st_size > 0, name
    assert not (outs[0] / "paths.png").exists()
    assert not (outs[0] / "windows.parquet").exists()
    csv = pd.read_csv(d / "windows.csv")
    pq = pd.read_parquet(d / "windows.parquet")
    assert list(csv.columns) == list(pq.columns) == window_columns(2)
    assert len(csv) == len(pq) > 0
    summary = json.loads((d / "summary.json").read_text())
    assert summary["mode"] == "fixed-wsch" and summary["windows"] == len(csv)
    for key in (
        "windows",
        "missed",
        "tracks_lost",
        "violations",
        "critical_share",
        "methods",
        "min_msb_over_wsch",
        "min_speed_ratio",
        "w_sch",
        "duration_s",
        "seed",
        "scenario",
    ):
        assert key in summary
    assert set(summary["violations"]) == {
        "localization",
        "separation",
        "path_diversion",
        "bearing",
        "contact",
    }
    assert summary["duration_s"] == pytest.approx(12.0)


def test_manifest_has_timing_seed_and_scenario(outs: list[Path]) -> None:
    m = json.loads((outs[0] / "manifest.json").read_text())
    assert m["command"] == "scenario" and m["seed"] == 5
    t = m["timing"]
    assert 0 < t["simulation_s"] <= t["total_s"]
    assert m["inputs"]["scenario_text"] == TEST2.read_text()
    assert m["inputs"]["scenario"]["leader"]["speed"] == 30
    assert m["inputs"]["scenario"]["thresholds"]["T_eps"] == 0.025
    assert "rtsim_version" in m and isinstance(m["argv"], list)


def test_same_seed_identical_files(outs: list[Path]) -> None:
    for name in ("windows.csv", "jobs.csv", "summary.json"):
        assert (outs[0] / name).read_bytes() == (outs[1] / name).read_bytes(), name
    m0 = json.loads((outs[0] / "manifest.json").read_text())
    assert "created_utc" in m0  # wall-clock lives only in the manifest


@pytest.mark.parametrize(
    "argv, match",
    [
        (["scenario", "nope.toml", "--out", "{tmp}"], "nope.toml"),
        (["scenario", str(TEST2), "--duration", "-3", "--out", "{tmp}"], "--duration"),
        (["scenario", "{bad}", "--out", "{tmp}"], "speed"),
    ],
)
def test_bad_input_one_line_exit_2(
    argv: list[str], match: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(TEST2.read_text().replace("speed = 30", "speed = -30"))
    args = [a.replace("{tmp}", str(tmp_path / "o")).replace("{bad}", str(bad)) for a in argv]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("rtsim: ") and "\n" not in err and match in err
    assert not (tmp_path / "o" / "windows.csv").exists()


def test_unknown_mode_is_a_usage_error(tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["scenario", str(TEST2), "--mode", "fast", "--out", str(tmp_path)])
    assert exc.value.code == 2


def test_packaged_scenario_by_name(tmp_path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """`rtsim scenario test1` runs the packaged copy and records its text in the manifest."""
    import json
    from pathlib import Path

    from rtsim.cli import main

    root = Path(__file__).resolve().parents[2]
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "run"
    assert main(["scenario", "test1", "--duration", "3", "--no-figures", "--out", str(out)]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    text = (root / "experiments" / "scenarios" / "test1.toml").read_text()
    assert manifest["inputs"]["scenario_text"] == text
    assert (out / "windows.csv").stat().st_size > 0
