"""The scenario figures' table read back in bounded chunks and thinned per pixel column
(issue 35, item 11: a coupled run with every output grew ~55 MB per simulated hour because
the figures read and drew the whole windows table, and held all six figures until the
collector ran)."""

from __future__ import annotations

import gc
import io
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.image as mpimg  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402
from traced import traced_peak as _peak  # noqa: E402

import rtsim.plots.scenario_data as sd  # noqa: E402
from rtsim.config.scenario import load_scenario  # noqa: E402
from rtsim.coupling import run_scenario  # noqa: E402
from rtsim.io.columns import read_columns  # noqa: E402
from rtsim.plots.scenario import SCENARIO_FIGURES, write_scenario_figures  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
TEST2 = ROOT / "experiments" / "scenarios" / "test2.toml"
N = 2


@pytest.fixture(scope="module")
def long_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A windows.csv about four windows to a time bin: a minute of Test 2 repeated, each
    copy later by the minute's length (window numbers renumbered)."""
    res = run_scenario(load_scenario(TEST2), duration_s=60, record_jobs=False)
    df = res.windows
    assert df is not None and len(df) > 100
    span = float(df["t"].iloc[-1] + df["w"].iloc[-1])
    reps = -(-4 * sd.FIGURE_BINS // len(df))
    big = pd.concat([df.assign(t=df["t"] + k * span) for k in range(reps)], ignore_index=True)
    big["window"] = range(1, len(big) + 1)
    path = tmp_path_factory.mktemp("long") / "windows.csv"
    big.to_csv(path, index=False)
    return path


def _png(df: pd.DataFrame, stem: str) -> np.ndarray:
    buf = io.BytesIO()
    fig = SCENARIO_FIGURES[stem](df, title="t")
    fig.savefig(buf, format="png", dpi=300)
    return mpimg.imread(io.BytesIO(buf.getvalue()))


def _differing(a: np.ndarray, b: np.ndarray) -> float:
    """The fraction of pixels whose colour differs by more than half the range."""
    assert a.shape == b.shape
    return float((np.abs(a - b).max(axis=2) > 0.5).mean())


@pytest.mark.slow
@pytest.mark.parametrize("stem", ["msb", "bounds", "paths"])
def test_the_thinned_table_draws_the_whole_tables_figure(
    long_csv: Path, stem: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """At 300 dpi the figure drawn from `read_figure_table` (its lines and dots thinned
    again as they are drawn) differs from the one drawn from every row, every point of
    every line and dot, in under 0.1 % of its pixels, while a table of every fourth row (as
    many rows as the bins) differs in more: the bins keep each line's extremes per pixel
    column and the dots of each band."""
    whole = read_columns(long_csv, sd.figure_columns(N))
    thin = sd.read_figure_table(long_csv, N)
    assert len(thin) < len(whole)
    with monkeypatch.context() as m:
        m.setattr(sd, "FIGURE_BINS", 10**9)  # no thinning as the figure is drawn
        reference = _png(whole, stem)
    assert _differing(_png(thin, stem), reference) < 1e-3
    assert _differing(_png(whole.iloc[::4].reset_index(drop=True), stem), reference) > 1e-3


@pytest.mark.parametrize("chunk", [97, 2048])
def test_each_bin_keeps_its_extremes_spans_and_misses(
    long_csv: Path, chunk: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Read in chunks of any length, the table holds in every time bin the smallest and
    largest value of every line the figures draw, the critical spans and the misses of the
    whole table, and the minima over followers of the bound columns it replaces."""
    monkeypatch.setattr(sd, "FIGURE_READ_ROWS", chunk)
    whole = read_columns(long_csv, sd.figure_columns(N))
    whole["missed"] = whole["window"] % 97 == 0  # misses to keep
    path = long_csv.parent / f"missed-{chunk}.csv"
    whole.to_csv(path, index=False)
    thin = sd.read_figure_table(path, N)
    assert not [c for c in thin.columns if "_msb_" in c]
    reduced = sd.reduce_chunk(whole)
    t0, end = reduced["t"].iloc[0], reduced["t"].iloc[-1] + reduced["w"].iloc[-1]
    for df in (reduced, thin):
        df["bin"] = np.floor((df["t"] - t0) * sd.FIGURE_BINS / (end - t0)).astype(int)
    lines = ["w", "slack", "msb_min", "v_leader", "v_leader_target"]
    lines += [f"bound_{k}_pred" for k in sd.BOUND_KINDS]
    for c in lines:
        for how in ("min", "max"):
            got = thin.groupby("bin")[c].agg(how)
            want = reduced.groupby("bin")[c].agg(how)
            pd.testing.assert_series_equal(got, want, check_names=False)
    assert sd.critical_spans(thin) == sd.critical_spans(reduced)
    assert thin["missed"].sum() == reduced["missed"].sum() > 0
    kept = reduced.set_index("window").loc[thin["window"]]
    for k in sd.BOUND_KINDS:
        for which in ("pred", "true"):
            c = f"bound_{k}_{which}"
            np.testing.assert_array_equal(thin[c].to_numpy(), kept[c].to_numpy())


def test_the_six_figures_are_not_held_at_once(long_csv: Path, tmp_path: Path) -> None:
    """Writing the six figures peaks below 1.5 times the largest single figure's peak: each
    is freed before the next is drawn (without it the peak was about their sum)."""
    df = sd.read_figure_table(long_csv, N)
    single = max(
        _peak(lambda stem=stem: write_one(df, stem, tmp_path)) for stem in SCENARIO_FIGURES
    )
    every = _peak(lambda: write_scenario_figures(df, tmp_path / "all", dpi=100))
    assert every < 1.5 * single, (every, single)


def write_one(df: pd.DataFrame, stem: str, out: Path) -> None:
    from rtsim.plots.scenario import save_figure

    save_figure(SCENARIO_FIGURES[stem](df, title="t"), out / f"{stem}.png", dpi=100)
    gc.collect()


@pytest.mark.parametrize("m", [10, 5000, 20_000])
def test_line_points_keep_each_bins_range_and_dot_points_each_band(m: int) -> None:
    """`line_points`: every point of a short line; of a long one, per bin the first, last,
    smallest and largest point of each value (so a steps-post line spans in each bin the
    range of every point), and every NaN. `dot_points`: a dot within DOT_BAND × top of each
    dropped one in its bin."""
    rng = np.random.default_rng(m)
    x = np.cumsum(rng.uniform(0.1, 0.5, m))
    y = rng.normal(100, 30, m)
    y[rng.random(m) < 0.01] = np.nan
    keep = sd.line_points(x, [y])
    if m <= sd.FIGURE_BINS:
        assert keep.all()
        assert sd.dot_points(x, y, 300.0).all()
        return
    assert keep[0] and keep[-1] and keep[np.isnan(y)].all() and keep.sum() < m
    b = np.clip(np.floor((x - x[0]) * sd.FIGURE_BINS / (x[-1] - x[0])), 0, sd.FIGURE_BINS - 1)
    for how in ("min", "max"):
        got = pd.Series(y[keep]).groupby(b[keep]).agg(how)
        want = pd.Series(y).groupby(b).agg(how)
        pd.testing.assert_series_equal(got, want)
    ok = ~np.isnan(y)
    xs, ys = x[ok], y[ok]
    dots = sd.dot_points(xs, ys, 300.0)
    bs = np.clip(np.floor((xs - xs[0]) * sd.FIGURE_BINS / (xs[-1] - xs[0])), 0, sd.FIGURE_BINS - 1)
    band = sd.DOT_BAND * 300.0
    for i in np.flatnonzero(~dots)[:200]:
        same = (bs == bs[i]) & dots
        assert np.min(np.abs(ys[same] - ys[i])) < band
