"""Scenario figures drawn from a synthetic windows table (schema: docs/outputs.md)."""

from __future__ import annotations

import io
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.image as mpimg  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

from rtsim.errors import InputError  # noqa: E402
from rtsim.plots.scenario import (  # noqa: E402
    BOUND_KINDS,
    COLORS,
    SCENARIO_FIGURES,
    critical_spans,
    figure_data,
    followers,
    plot_bounds,
    plot_modes,
    plot_msb,
    plot_operating_space,
    plot_paths,
    plot_speed,
    plot_window_slack,
    save_figure,
    write_scenario_figures,
)

W_SCH = 237.0
N = 300
TURN = range(100, 160)  # windows in the turn
CRITICAL = (range(120, 151), range(200, 206))  # two critical stretches
MISSED = (10, 11)


def make_windows(n: int = N, n_followers: int = 2) -> pd.DataFrame:
    """A windows table by construction: path-diversion dips below w_sch in the critical runs."""
    idx = np.arange(n)
    crit = np.zeros(n, bool)
    for r in CRITICAL:
        crit[[i for i in r if i < n]] = True
    turn = np.isin(idx, list(TURN))
    pd_bound = np.where(crit, 150.0, 390.0)
    sep = np.where(turn, 500.0, np.inf)
    sep[crit] = 200.0  # separation binds in the critical windows too (below path diversion? no)
    loc = np.full(n, np.inf)
    loc[50:60] = 2000.0
    bear = np.full(n, 5000.0)
    msb_min = np.minimum.reduce([pd_bound, sep, loc, bear])
    w = np.maximum(W_SCH, np.minimum(msb_min, 1000.0))
    t = np.concatenate([[0.0], np.cumsum(w)[:-1]])
    v_d = np.full(n, 25.0)
    v = np.where(crit, 12.5, 25.0)
    ang = idx / n * np.pi
    cols: dict[str, object] = {
        "window": idx,
        "t": t,
        "w": w,
        "deadline": t + w,
        "w_sch": np.full(n, W_SCH),
        "msb_min": msb_min,
        "binding": np.where(crit, "path_diversion:2", "path_diversion:1"),
        "margin": msb_min - W_SCH,
        "slack": np.maximum(0.0, w - W_SCH),
        "v_leader_desired": v_d,
        "v_leader": v,
        "v_leader_target": v,
        "v_leader_max": v,
        "method": np.where(crit, "coupled", "none"),
        "feasible": np.ones(n, bool),
        "critical": crit,
        "missed": np.isin(idx, MISSED),
        "response": np.full(n, 200.0),
        "finish": t + 200.0,
        "points": np.full(n, 40),
        "hough_ms": np.full(n, 30.0),
        "tracks_lost": np.zeros(n, int),
        "segment": np.where(turn, "turn", "straight"),
        "curvature": np.where(turn, 0.005, 0.0),
        "leader_x": 300 * np.cos(ang),
        "leader_y": 300 * np.sin(ang),
        "leader_heading": ang,
    }
    for i in range(1, n_followers + 1):
        fx, fy = 300 * np.cos(ang - 0.2 * i), (300 - 20 * i) * np.sin(ang - 0.2 * i)
        for suffix, noise in (("", 0.0), ("_est", 1.5)):
            cols[f"f{i}_x{suffix}"] = fx + noise * np.sin(idx)
            cols[f"f{i}_y{suffix}"] = fy + noise * np.cos(idx)
            cols[f"f{i}_heading{suffix}"] = ang
            cols[f"f{i}_rho{suffix}"] = np.full(n, 390.0)
            cols[f"f{i}_beta{suffix}"] = np.full(n, np.pi)
            cols[f"f{i}_theta{suffix}"] = np.zeros(n)
            cols[f"f{i}_v{suffix}"] = v
        scale = 1.0 if i == n_followers else 1.3  # the last follower binds
        for kind, b in zip(BOUND_KINDS, (loc, sep, pd_bound, bear), strict=True):
            cols[f"f{i}_msb_{kind}_pred"] = b * scale
        viol = {kind: (idx % 97 == i) & (kind == "separation") for kind in BOUND_KINDS}
        for kind, b in zip(BOUND_KINDS, (loc, sep, pd_bound, bear), strict=True):
            # the truth: a little above the prediction (at least 1.2·w: unbroken), and 0.9·w
            # where the window broke the bound
            cols[f"f{i}_msb_{kind}_true"] = np.where(
                viol[kind], 0.9 * w, np.maximum(b * scale + 3.0, 1.2 * w)
            )
        for kind in BOUND_KINDS:
            cols[f"f{i}_viol_{kind}"] = viol[kind]
        cols[f"f{i}_lost"] = np.zeros(n, bool)
    return pd.DataFrame(cols)


@pytest.fixture(scope="module")
def df() -> pd.DataFrame:
    return make_windows()


def expected_spans(d: pd.DataFrame, runs) -> list[tuple[float, float]]:
    """Runs of windows → (start, end) in s: end = next window's start, or t + w at the end."""
    t, w = d["t"].to_numpy() / 1000, d["w"].to_numpy() / 1000
    return [(t[r[0]], t[r[-1] + 1] if r[-1] + 1 < len(d) else t[-1] + w[-1]) for r in runs]


def flat(spans) -> list[float]:
    return [float(x) for span in spans for x in span]


def gid_patches(ax, gid: str) -> list[Rectangle]:
    return [p for p in ax.patches if p.get_gid() == gid]


def shaded(ax, gid: str) -> list[tuple[float, float]]:
    """The (start, end) of each shaded span: the first is an axvspan (it carries the legend
    entry), the others one collection of rectangles (`_shade`)."""
    spans = [(p.get_x(), p.get_x() + p.get_width()) for p in gid_patches(ax, gid)]
    for c in ax.collections:
        if c.get_gid() == gid and c.get_transform() == ax.get_xaxis_transform():
            spans += [(v[:, 0].min(), v[:, 0].max()) for v in (p.vertices for p in c.get_paths())]
    return sorted(spans)


def labelled_lines(ax) -> dict[str, matplotlib.lines.Line2D]:
    return {ln.get_label(): ln for ln in ax.get_lines() if not ln.get_label().startswith("_")}


def test_followers_discovered_numerically():
    d = make_windows(n=20, n_followers=11)
    assert followers(d) == list(range(1, 12))  # f10, f11 after f2, not after f1


@pytest.mark.parametrize(
    ("plot", "n_axes"),
    [
        (plot_paths, 1),
        (plot_window_slack, 1),
        (plot_bounds, 1),
        (plot_speed, 1),
        (plot_operating_space, 2),
    ],
)
def test_every_figure_is_a_figure_without_pyplot(df, plot, n_axes):
    import matplotlib.pyplot as plt

    before = plt.get_fignums()
    fig = plot(df, title="x")
    assert isinstance(fig, Figure)
    assert len(fig.axes) == n_axes
    assert plt.get_fignums() == before  # no pyplot global figure was created


def test_bounds_lines_per_kind_with_consistent_colours(df):
    ax = plot_bounds(df).axes[0]
    lines = labelled_lines(ax)
    kinds = [lab for lab in lines if "MSB predicted" in lab]
    assert len(kinds) == 4
    assert len([lab for lab in lines if "MSB true" in lab]) == 4
    for kind in BOUND_KINDS:
        (lab,) = [lab for lab in kinds if lab.startswith(kind.replace("_", " "))]
        assert matplotlib.colors.same_color(lines[lab].get_color(), COLORS[kind])
    assert any("w_{sch}" in lab for lab in lines) and "processing window w" in lines
    # the same kind has the same colour in the side-by-side figure
    mode_ax = plot_modes({"a": df, "b": df}, kind="bounds").axes[1]
    mlines = labelled_lines(mode_ax)
    lab = next(lab for lab in mlines if lab.startswith("path diversion"))
    assert matplotlib.colors.same_color(mlines[lab].get_color(), COLORS["path_diversion"])


def test_bounds_plot_clips_infinite_values_and_notes_it(df):
    ax = plot_bounds(df).axes[0]
    top = ax.get_ylim()[1]
    assert 1.5 * W_SCH <= top <= 4 * W_SCH
    assert "off-scale" in ax.get_title(loc="right")
    sep = next(ln for lab, ln in labelled_lines(ax).items() if lab.startswith("separation"))
    y = np.asarray(sep.get_ydata(), float)[:-1]  # the last point repeats the last window
    assert np.all(np.isfinite(y))  # inf drawn above the axes, not passed to the renderer
    assert np.all(y[np.isinf(df["f2_msb_separation_pred"])] > top)
    # the truth beside it: dots per window, only those on the scale
    (true,) = [ln for ln in ax.get_lines() if ln.get_gid() == "true_separation"]
    t = np.minimum(df["f1_msb_separation_true"], df["f2_msb_separation_true"]).to_numpy()
    np.testing.assert_allclose(true.get_ydata(), t[t <= top])
    assert {f"pred_{k}" for k in BOUND_KINDS} | {f"true_{k}" for k in BOUND_KINDS} <= {
        ln.get_gid() for ln in ax.get_lines()
    }


def test_critical_shading_spans_match_critical_windows(df):
    want = expected_spans(df, CRITICAL)
    assert flat(critical_spans(df)) == pytest.approx(flat(want))
    for fig in (plot_window_slack(df), plot_bounds(df), plot_operating_space(df)):
        assert flat(shaded(fig.axes[0], "critical")) == pytest.approx(flat(want))


def test_speed_shades_turns_and_plots_both_speeds(df):
    ax = plot_speed(df).axes[0]
    got = shaded(ax, "turn")
    assert flat(got) == pytest.approx(flat(expected_spans(df, [TURN])))
    lines = labelled_lines(ax)
    # steps over the window starts, plus the end of the last window (t + w) at its value
    v, t = df["v_leader"].to_numpy(), df["t"].to_numpy()
    np.testing.assert_array_equal(lines["actual $V_L$ (at t)"].get_ydata(), np.append(v, v[-1]))
    assert [ln for ln in ax.get_lines() if ln.get_gid() == "target"]
    np.testing.assert_allclose(
        lines["actual $V_L$ (at t)"].get_xdata(), np.append(t, t[-1] + df["w"].iloc[-1]) / 1000
    )


def test_window_figure_marks_misses_and_slack(df):
    ax = plot_window_slack(df).axes[0]
    (miss,) = [ln for ln in ax.get_lines() if ln.get_gid() == "miss"]
    np.testing.assert_allclose(miss.get_xdata(), df["t"].to_numpy()[list(MISSED)] / 1000)
    assert "(2)" in miss.get_label()
    lines = labelled_lines(ax)
    slack = next(ln for lab, ln in lines.items() if lab.startswith("slack"))
    np.testing.assert_allclose(slack.get_ydata()[:-1], np.maximum(0, df["w"] - W_SCH))


def test_paths_highlight_critical_windows_at_the_binding_follower(df):
    ax = plot_paths(df).axes[0]
    assert ax.get_aspect() == 1.0
    (crit,) = [c for c in ax.collections if c.get_gid() == "critical"]
    sel = df["critical"].to_numpy()
    # every critical window of the table binds on follower 2 ("path_diversion:2")
    np.testing.assert_allclose(crit.get_offsets(), df.loc[sel, ["f2_x", "f2_y"]])
    # without a binding column: the leader's position
    ax = plot_paths(df.drop(columns=["binding"])).axes[0]
    (crit,) = [c for c in ax.collections if c.get_gid() == "critical"]
    np.testing.assert_allclose(crit.get_offsets(), df.loc[sel, ["leader_x", "leader_y"]])
    assert len([c for c in ax.collections if c.get_gid() == "estimate"]) == 2
    assert len([ln for ln in ax.get_lines() if ln.get_gid() == "start"]) == 3


def test_msb_figure_is_the_papers_picture(df):
    """Figs 10/14: min MSB predicted at V_Ld (msb_min) as a step line, the true minimum over
    every follower and kind as dots, and in critical windows a marker per binding kind."""
    ax = plot_msb(df).axes[0]
    (pred,) = [ln for ln in ax.get_lines() if ln.get_gid() == "msb_pred"]
    np.testing.assert_allclose(np.asarray(pred.get_ydata(), float)[:-1], df["msb_min"])
    (true,) = [ln for ln in ax.get_lines() if ln.get_gid() == "msb_true"]
    every = np.column_stack([df[f"f{i}_msb_{k}_true"] for i in (1, 2) for k in BOUND_KINDS])
    m = every.min(axis=1)
    np.testing.assert_allclose(true.get_ydata(), m[m <= ax.get_ylim()[1]])
    (bind,) = [ln for ln in ax.get_lines() if ln.get_gid() == "binding_path_diversion"]
    assert len(bind.get_xdata()) == int(df["critical"].sum())
    assert "(37)" in bind.get_label()


def test_figure_data_is_the_table(df):
    for name in SCENARIO_FIGURES:
        data = figure_data(df, name)
        assert len(data) == len(df)
        for col in data.columns:
            if col in df.columns:
                np.testing.assert_array_equal(data[col].to_numpy(), df[col].to_numpy())
    bounds = figure_data(df, "bounds")
    for kind in BOUND_KINDS:  # independent: the element-wise min of the two followers
        for which in ("pred", "true"):
            a = df[f"f1_msb_{kind}_{which}"].to_numpy()
            b = df[f"f2_msb_{kind}_{which}"].to_numpy()
            np.testing.assert_array_equal(bounds[f"bound_{kind}_{which}"], np.where(a < b, a, b))
    assert np.isinf(bounds["bound_localization_pred"]).sum() == N - 10
    space = figure_data(df, "operating_space")
    for which in ("pred", "true"):
        every = np.column_stack([df[f"f{i}_msb_{k}_{which}"] for i in (1, 2) for k in BOUND_KINDS])
        np.testing.assert_array_equal(space[f"msb_min_{which}"], every.min(axis=1))
    assert {"f2_x_est", "f2_y", "leader_x"} <= set(figure_data(df, "paths").columns)


def test_figure_data_from_csv_round_trip(df, tmp_path):
    """A table read back from CSV (text booleans, 'inf') gives the same figure data."""
    path = tmp_path / "windows.csv"
    df.to_csv(path, index=False)
    back = pd.read_csv(path)
    for name in SCENARIO_FIGURES:
        pd.testing.assert_frame_equal(
            figure_data(back, name), figure_data(df, name), check_dtype=False
        )
    spans = critical_spans(back.astype({"critical": str}))
    assert flat(spans) == pytest.approx(flat(expected_spans(df, CRITICAL)))


def test_write_scenario_figures_pngs_and_data(df, tmp_path):
    paths = write_scenario_figures(
        df, tmp_path / "figs", prefix="test1_", label="Test 1", data=True
    )
    pngs = [p for p in paths if p.suffix == ".png"]
    assert sorted(p.name for p in pngs) == sorted(f"test1_{s}.png" for s in SCENARIO_FIGURES)
    for p in pngs:
        raw = p.read_bytes()
        assert raw[:8] == b"\x89PNG\r\n\x1a\n"
        img = mpimg.imread(io.BytesIO(raw), format="png")
        assert img.shape[0] > 300 and img[..., :3].std() > 0.05  # not blank
    for p in (p for p in paths if p.suffix == ".csv"):  # data behind each figure
        back = pd.read_csv(p)
        want = figure_data(df, p.stem.removeprefix("test1_"))
        pd.testing.assert_frame_equal(back, want, check_dtype=False)
    assert not [q for q in (tmp_path / "figs").iterdir() if q.name.startswith(".")]


def test_save_figure_closes_pyplot_figure(tmp_path):
    import matplotlib.pyplot as plt

    fig = plt.figure()
    fig.add_subplot().plot([0, 1], [1, 0])
    assert fig.number in plt.get_fignums()
    out = save_figure(fig, Path(tmp_path) / "a.png")
    assert out.read_bytes()[:4] == b"\x89PNG"
    assert fig.number not in plt.get_fignums()


@pytest.mark.parametrize("kind", ["window", "bounds", "speed", "paths", "operating_space"])
def test_plot_modes_side_by_side(df, kind):
    worse = df.copy()
    worse["missed"] = worse["critical"]
    worse["f1_viol_bearing"] = True
    worse["f1_msb_bearing_true"] = worse["w"] / 2.5  # every window broke it, 2.5-fold
    modes = {"adjust": df, "fixed-wsch": df, "min-msb": worse}
    fig = plot_modes(modes, kind=kind)
    assert len(fig.axes) == 3
    assert fig.axes[0].get_shared_y_axes().joined(fig.axes[0], fig.axes[2])
    for ax, (mode, d) in zip(fig.axes, modes.items(), strict=True):
        ratio = np.column_stack([d["w"] / d[c] for c in d.columns if c.endswith("_true")])
        title = ax.get_title(loc="left")
        assert title.startswith(mode)
        # violations beyond 5 % and the largest ratio lead, then misses and lost tracks
        assert (
            f"{mode}\nviolations > 5 % {int((ratio > 1.05).sum())} · max ratio "
            f"{ratio.max():.2f} · misses {int(d['missed'].sum())}" in title
        )
    assert "max ratio 2.50 · misses 37" in fig.axes[2].get_title(loc="left")
    # separation broke at 1/0.9 = 1.11 in windows 1, 98, 195, 292 (f1) and 2, 99, 196, 293
    assert "violations > 5 % 8 · max ratio 1.11" in fig.axes[0].get_title(loc="left")


@pytest.mark.parametrize("case", ["one_row", "no_critical", "all_inf", "empty"])
def test_edge_cases_draw(case):
    """One row, no critical window, every bound infinite, no rows: all figures render."""
    three = case == "no_critical"  # also: a third follower is discovered
    d = make_windows(n=1 if case == "one_row" else 40, n_followers=3 if three else 2)
    if case == "all_inf":
        for c in d.columns:
            if "_msb_" in c:
                d[c] = np.inf
        d["msb_min"] = np.inf
    if case == "empty":
        d = d.iloc[:0]
    assert not d["critical"].any()
    fig = Figure(figsize=(12, 3))  # all figures in one canvas: one render per case
    axes = fig.subplots(1, len(SCENARIO_FIGURES))
    for ax, plot in zip(axes, SCENARIO_FIGURES.values(), strict=True):
        assert plot(d, ax=ax) is fig
        assert not shaded(ax, "critical")
        lo, hi = ax.get_ylim()
        assert np.isfinite(lo) and np.isfinite(hi)
    if case == "all_inf":
        # bounds: every MSB is off-scale, so the axis is set by w (a little above its max)
        assert axes[2].get_ylim() == (0, pytest.approx(1.08 * d["w"].max()))
        assert "off-scale" in axes[2].get_title(loc="right")
    if case == "one_row":  # a one-window table draws a segment as wide as the window
        (w_line,) = [ln for ln in axes[1].get_lines() if ln.get_label() == "processing window w"]
        assert list(w_line.get_xdata()) == pytest.approx([0.0, d["w"].iloc[0] / 1000])
    if three:
        assert len([c for c in axes[0].collections if c.get_gid() == "estimate"]) == 3
    fig.savefig(io.BytesIO(), format="png", dpi=30)  # inf, one row, no rows: renders
    plane = plot_operating_space(d)  # the (w_sch, min MSB) panel too
    assert len(plane.axes) == 2
    plane.savefig(io.BytesIO(), format="png", dpi=30)


def test_draws_into_given_axes(df):
    fig = Figure()
    left, right = fig.subplots(1, 2)
    assert plot_speed(df, ax=right, title="speed") is fig
    assert plot_bounds(df, ax=left) is fig
    assert len(fig.axes) == 2 and right.get_title(loc="left") == "speed"
    assert right.get_legend() is not None and not fig.legends


def test_bad_input_names_the_problem(df):
    with pytest.raises(InputError, match="unknown figure 'nope'"):
        figure_data(df, "nope")
    with pytest.raises(InputError, match="missing column 'v_leader'"):
        plot_speed(df.drop(columns=["v_leader"]))
    with pytest.raises(InputError, match="missing column 'f2_msb_bearing_pred'"):
        plot_bounds(df.drop(columns=["f2_msb_bearing_pred"]))
    with pytest.raises(InputError, match="unknown kind 'gantt'"):
        plot_modes({"a": df}, kind="gantt")


def test_data_module_lists_the_drawn_figures() -> None:
    from rtsim.plots.scenario import SCENARIO_FIGURES
    from rtsim.plots.scenario_data import FIGURE_NAMES

    assert FIGURE_NAMES == tuple(SCENARIO_FIGURES)
