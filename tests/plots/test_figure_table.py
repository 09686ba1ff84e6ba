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
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
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


def _kept_the_simple_way(path: Path, chunk: int) -> pd.DataFrame:
    """The figures' table built the plain way (as before issue 36, item 4): windows.csv
    parsed in chunks of ``chunk`` rows, each reduced and thinned by the bins of the run's
    time span, the kept rows of every chunk concatenated at the end."""
    whole = read_columns(path, ["t", "w", "w_sch"])
    t, w = whole["t"].to_numpy(float), whole["w"].to_numpy(float)
    t0, span = t[0], t[-1] + w[-1] - t[0]
    w_sch = float(whole["w_sch"].max())
    parts = []
    for part in pd.read_csv(path, usecols=sd.figure_columns(N), chunksize=chunk):
        small = sd.reduce_chunk(part)
        bins = np.floor(np.clip((small["t"].to_numpy() - t0) * (sd.FIGURE_BINS / span), 0, None))
        keep = sd.keep_extremes(
            small, bins.astype(np.int64), sd.FIGURE_DOT_CELL * w_sch, sd.BOUNDS_CLIP * w_sch
        )
        parts.append(small[keep])
    return pd.concat(parts, ignore_index=True)


@pytest.mark.parametrize("chunk", [97, 2048])
def test_the_table_is_the_whole_tables_kept_rows_and_figure_columns(
    long_csv: Path, chunk: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`read_figure_table` (three passes, the kept rows copied into columns allocated once)
    gives the table built by concatenating each chunk's kept rows, column for column, dtype
    for dtype, value for value; and every figure's data (`figure_data`) taken from it equals
    the same figure's data taken from the wide table (each follower's bound columns, not
    their minima) at the kept windows: the figures draw the same values either way."""
    monkeypatch.setattr(sd, "FIGURE_READ_ROWS", chunk)
    thin = sd.read_figure_table(long_csv, N)
    pd.testing.assert_frame_equal(thin, _kept_the_simple_way(long_csv, chunk))
    wide = read_columns(long_csv, sd.figure_columns(N))
    wide = wide.set_index("window", drop=False).loc[thin["window"]].reset_index(drop=True)
    assert [c for c in wide.columns if "_msb_" in c] and not [c for c in thin if "_msb_" in c]
    for name in sd.FIGURE_NAMES:
        pd.testing.assert_frame_equal(sd.figure_data(thin, name), sd.figure_data(wide, name))


def test_a_column_read_as_two_types_is_joined_as_pandas_joins_it(
    long_csv: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A column whose first chunk is empty (parsed as floats) and later chunks text: the
    table holds it as `pandas.concat` of the kept rows does (object), and an empty
    windows.csv gives the empty table of the figures' columns."""
    monkeypatch.setattr(sd, "FIGURE_READ_ROWS", 97)
    df = pd.read_csv(long_csv)
    df.loc[:150, "binding"] = np.nan
    path = tmp_path / "windows.csv"
    df.to_csv(path, index=False)
    thin = sd.read_figure_table(path, N)
    want = _kept_the_simple_way(path, 97)
    chunks = [c["binding"].dtype for c in pd.read_csv(path, usecols=["binding"], chunksize=97)]
    assert chunks[0] == np.float64 and chunks[-1] != np.float64
    assert want["binding"].dtype == object
    pd.testing.assert_frame_equal(thin, want)
    df.iloc[:0].to_csv(path, index=False)
    empty = sd.read_figure_table(path, N)
    assert len(empty) == 0
    assert list(empty.columns) == list(sd.reduce_chunk(df.loc[:0, sd.figure_columns(N)]).columns)


def _old_shade(ax, spans: list[tuple[float, float]], kind: str, label: str) -> None:
    """The shading as drawn before: one axvspan per span."""
    from rtsim.plots.scenario import COLORS

    for k, (a, b) in enumerate(spans):
        ax.axvspan(
            a, b, color=COLORS[kind], alpha=0.15, lw=0, gid=kind, label=label if k == 0 else None
        )


@pytest.mark.parametrize("seed", [0, 1])
def test_one_collection_of_spans_draws_the_pixels_of_a_patch_per_span(seed: int) -> None:
    """`_shade` (the first span a patch, the others one collection) gives the RGBA buffer of
    a patch per span, byte for byte at 300 dpi: spans wide and narrower than a pixel, two
    within one pixel column, under a line, with the legend."""
    from rtsim.plots.figure import new_figure
    from rtsim.plots.scenario import _shade

    rng = np.random.default_rng(seed)
    edges = np.sort(rng.uniform(0, 3600, 1200))
    spans = [(float(a), float(b)) for a, b in edges.reshape(-1, 2)]
    spans.append((spans[-1][1] + 1e-3, spans[-1][1] + 2e-3))  # within the same pixel
    images = []
    for shade in (_old_shade, _shade):
        fig = new_figure(figsize=(7.0, 2.8), layout="constrained")
        ax = fig.add_subplot()
        shade(ax, spans, "critical", "critical")
        ax.plot([0, 3600], [0, 1], color="k", lw=1)
        ax.set_xlim(0, 3600)
        ax.legend()
        canvas = FigureCanvasAgg(fig)
        canvas.draw()
        images.append(bytes(canvas.buffer_rgba()))
    assert images[0] == images[1]


@pytest.mark.parametrize(
    "values", [["a:1", "b:2", None, "a:1", "c"], ["x:y:z", "", "q", None], [1.0, 2.5, np.nan]]
)
@pytest.mark.parametrize("dtype", [None, "str", object])
def test_text_field_is_pandas_split_per_row(values: list[object], dtype: object) -> None:
    """`text_field` gives per row what ``.str.split(':').str[0]`` and
    ``.str.rsplit(':', n=1).str[-1]`` give, NaN for a missing cell."""
    s = pd.Series(values, dtype=dtype)  # type: ignore[call-overload]
    first = s.astype(str).str.split(":").str[0].to_numpy()
    last = s.astype(str).str.rsplit(":", n=1).str[-1].to_numpy()
    for got, want in ((sd.text_field(s), first), (sd.text_field(s, last=True), last)):
        assert pd.Series(got, dtype=object).equals(pd.Series(want, dtype=object))


def test_as_floats_takes_a_float_column_as_it_is() -> None:
    """A float column's values without a copy; text as numbers, NaN where it is none."""
    df = pd.DataFrame({"a": [1.5, np.inf, np.nan], "b": ["1", "x", ""]})
    a = sd.as_floats(df["a"])
    assert np.shares_memory(a, df["a"].to_numpy())
    np.testing.assert_array_equal(a, [1.5, np.inf, np.nan])
    np.testing.assert_array_equal(sd.as_floats(df["b"]), [1.0, np.nan, np.nan])


def _zigzag_png(
    travel_limit: int | None, monkeypatch: pytest.MonkeyPatch, alpha: float = 1.0
) -> tuple[bytes, int]:
    """A steps-post line swinging up and down the axes in each of 2,000 columns, drawn as
    `_step` draws it (with ``travel_limit``) or without the effect (None); the RGBA bytes
    and the number of paths handed to Agg."""
    from matplotlib.backends.backend_agg import RendererAgg

    import rtsim.plots.scenario as sc
    from rtsim.plots.figure import new_figure

    x = np.repeat(np.arange(2000.0), 4)
    y = np.tile([0.0, 100.0, 10.0, 90.0], 2000)
    calls = []
    real = RendererAgg.draw_path

    def counted(self, gc, path, transform, rgbFace=None):  # noqa: N803
        calls.append(len(path.vertices))
        return real(self, gc, path, transform, rgbFace)

    fig = new_figure(figsize=(7.0, 2.8))
    ax = fig.add_subplot()
    (line,) = ax.plot(x, y, drawstyle="steps-post", lw=1.3, color="#0072B2", alpha=alpha)
    if travel_limit is not None:
        monkeypatch.setattr(sc, "AGG_LINE_TRAVEL", travel_limit)
        line.set_path_effects([sc._Pieces()])
    ax.set_ylim(0, 50)  # half of each swing is clipped away
    canvas = FigureCanvasAgg(fig)
    with monkeypatch.context() as m:
        m.setattr(RendererAgg, "draw_path", counted)
        canvas.draw()
    return bytes(canvas.buffer_rgba()), max(calls)


def test_a_long_line_is_rasterized_in_pieces_and_a_short_one_as_it_is(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`_Pieces`: a line within `AGG_LINE_TRAVEL` (counted within the axes) gives the bytes
    of the same line drawn without it; a longer one reaches Agg in pieces of at most the
    travel, the largest path handed over shrinking with the limit, and the image differs
    only where the pieces join (by more than half the range in under 0.1 % of the pixels,
    as the thinned figures are checked); a translucent line is drawn
    whole."""
    whole, largest = _zigzag_png(None, monkeypatch)
    same, n_same = _zigzag_png(10**9, monkeypatch)
    assert same == whole and n_same == largest
    cut, n_cut = _zigzag_png(100_000, monkeypatch)
    assert n_cut < largest / 2
    a = np.frombuffer(whole, dtype=np.uint8).reshape(-1, 4).astype(int)
    b = np.frombuffer(cut, dtype=np.uint8).reshape(-1, 4)
    diff = np.abs(a - b).max(axis=1)
    assert diff.any() and (diff > 127).mean() < 1e-3
    translucent, n_whole = _zigzag_png(None, monkeypatch, alpha=0.3)
    assert _zigzag_png(100_000, monkeypatch, alpha=0.3) == (translucent, n_whole)


# --- a long run's figures: the table bounded, paths and dots sketched (issue 35) ---------


@pytest.fixture(scope="module")
def minute() -> pd.DataFrame:
    res = run_scenario(load_scenario(TEST2), duration_s=60, record_jobs=False)
    assert res.windows is not None
    return res.windows


def _repeated(minute: pd.DataFrame, reps: int, path: Path) -> Path:
    """``reps`` copies of a minute of Test 2, each later by the minute's length: the robots
    retrace the same path lap after lap."""
    span = float(minute["t"].iloc[-1] + minute["w"].iloc[-1])
    big = pd.concat(
        [minute.assign(t=minute["t"] + k * span) for k in range(reps)], ignore_index=True
    )
    big["window"] = range(1, len(big) + 1)
    big.to_csv(path, index=False)
    return path


def test_a_short_runs_figures_are_drawn_from_its_whole_table(long_csv: Path) -> None:
    """Up to `FIGURE_ROWS` kept rows, `read_figures` gives `read_figure_table`'s table and
    no sketch: the figures are drawn as before (10 minutes and 1 hour of Test 2 keep
    under 16,384 rows; their PNGs are byte-identical to those drawn before the sketch)."""
    table, sketch = sd.read_figures(long_csv, N)
    assert sketch is None and len(table) <= sd.FIGURE_ROWS
    pd.testing.assert_frame_equal(table, sd.read_figure_table(long_csv, N))


def _held(table: pd.DataFrame, sketch: sd.FigureSketch | None) -> int:
    return len(table) + (sketch.items() if sketch is not None else 0)


def test_a_long_runs_figures_hold_a_bounded_table_and_sketch(
    minute: pd.DataFrame, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Above `FIGURE_ROWS` the figures' table keeps only the lines' rows (within
    FIGURE_BINS × (2 + 2 × plotted values + 6 × FIGURE_EVENTS)) and the paths are
    sketched: R and 4R copies of the same laps (R at least the points a scatter keeps per
    cell) hold tables within the bins' bound and exactly the same paths, while the whole table
    (`read_figure_table`) grows with the windows. Fails if anything the figures hold grows
    with the run's length beyond its grid."""
    monkeypatch.setattr(sd, "FIGURE_ROWS", 500)
    monkeypatch.setattr(sd, "FIGURE_BINS", 256)
    reps = max(-(-4 * sd.FIGURE_BINS // len(minute)), sd.FIGURE_POINTS_PER_CELL)
    got = {}
    for k in (reps, 4 * reps):
        path = _repeated(minute, k, tmp_path / f"w{k}.csv")
        table, sketch = sd.read_figures(path, N)
        assert sketch is not None
        got[k] = (table, sketch, len(sd.read_figure_table(path, N)))
    (t1, s1, whole1), (t4, s4, whole4) = got[reps], got[4 * reps]
    plotted = len(sd._guarded(t4, dots=True))
    # per bin: first and last, each plotted value's extremes, both rows of the first and
    # last FIGURE_EVENTS changes of `critical`, the first and last FIGURE_EVENTS misses
    bound = sd.FIGURE_BINS * (2 + 2 * plotted + 4 * sd.FIGURE_EVENTS + 2 * sd.FIGURE_EVENTS)
    assert len(t1) <= bound and len(t4) <= bound
    assert whole4 > 2 * whole1  # the whole table grows with the windows
    for name in s1.lines:
        np.testing.assert_array_equal(s1.lines[name][0], s4.lines[name][0])
    for name in s1.points:
        np.testing.assert_array_equal(s1.points[name][0], s4.points[name][0])
    bands = int(sd.BOUNDS_CLIP / sd.FIGURE_DOT_CELL) + 2
    for name, (t, _) in s4.dots.items():
        assert len(t) <= sd.FIGURE_BINS * bands * sd.FIGURE_DOTS_PER_CELL, name
    assert s4.counts["msb_min_true"] == 4 * s1.counts["msb_min_true"]


@pytest.mark.slow
@pytest.mark.parametrize("stem", list(SCENARIO_FIGURES))
def test_a_sketched_figure_draws_the_whole_tables_figure(
    minute: pd.DataFrame, tmp_path: Path, stem: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """At 300 dpi a figure drawn from the sketched table (its paths retraced 4 × 2,048 /
    a minute's windows times) differs from the figure drawn from every row of the table,
    every point of every line and dot, in under 0.1 % of its pixels, or in at most 0.02 %
    more than the figure drawn from the thinned table as before (the speed figure: 0.13 %
    against 0.12 %; its lines swing across many pixels within each bin)."""
    path = _repeated(minute, -(-4 * sd.FIGURE_BINS // len(minute)), tmp_path / "w.csv")
    with monkeypatch.context() as m:
        m.setattr(sd, "FIGURE_ROWS", 500)
        table, sketch = sd.read_figures(path, N)
    assert sketch is not None
    whole = read_columns(path, sd.figure_columns(N))
    with monkeypatch.context() as m:
        m.setattr(sd, "FIGURE_BINS", 10**9)  # no thinning as the figure is drawn
        reference = _png(whole, stem)
    buf = io.BytesIO()
    SCENARIO_FIGURES[stem](table, title="t", sketch=sketch).savefig(buf, format="png", dpi=300)
    got = _differing(mpimg.imread(io.BytesIO(buf.getvalue())), reference)
    before = _differing(_png(sd.read_figure_table(path, N), stem), reference)
    assert got < max(1e-3, before + 2e-4), (got, before)
