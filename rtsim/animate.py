"""An animation of a scenario run: the robots, the laser and the Hough windows above, the
schedule below, one frame per processing window (``rtsim animate RUN_DIR --out FILE``).

Drawn from what ``rtsim scenario`` wrote — ``windows.csv`` (poses, w, w_sch, critical,
v_leader), ``jobs.csv`` (the schedule) and ``manifest.json`` (follower radius, r_H) — through
`window_view`, the one place that knows windows.csv's column names. Each frame shows
the window's scan: every follower's true pose (filled) and the leader's estimate (hollow),
its Hough window (a circle of radius r_H around the estimate; red in a critical window, when
min MSB < w_sch), and the laser beams that hit each follower's disc (recomputed from the
geometry at the laser's 0.5° resolution; shadowing is not redrawn). Below, a Gantt strip of
the current and the previous window (each task's jobs from first start to finish) with the
window's w and w_sch drawn as intervals from its release.

Formats by the output's suffix: ``.gif`` (Pillow), ``.html`` (matplotlib's JavaScript
player, one self-contained file), ``.mp4`` (ffmpeg: the one on PATH, else the one that the
``imageio-ffmpeg`` package ships; a clear error when neither is there).
"""

from __future__ import annotations

import json
import math
import os
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rtsim.analysis.kinematics import R_H_DEFAULT
from rtsim.errors import InputError
from rtsim.io.atomic import write_json
from rtsim.io.manifest import build_manifest
from rtsim.io.outdir import FileSet, sidecar
from rtsim.world.follower import FollowerParams

__all__ = ["WindowView", "window_view", "load_run", "animate_run", "FORMATS", "BEAM_STEP"]

FORMATS = (".gif", ".html", ".mp4")
#: The laser's angular resolution (361 beams over 180°, docs/model/index.md).
BEAM_STEP = math.radians(0.5)


@dataclass(frozen=True)
class WindowView:
    """What the animation reads of windows.csv, as arrays (one entry per window)."""

    t: np.ndarray  # release, ms
    w: np.ndarray
    w_sch: np.ndarray
    critical: np.ndarray
    v_leader: np.ndarray
    leader: np.ndarray  # (windows, 3): x, y, heading
    truth: np.ndarray  # (windows, n, 2)
    estimate: np.ndarray  # (windows, n, 2)

    @property
    def n(self) -> int:
        return int(self.truth.shape[1])


def window_view(df: pd.DataFrame) -> WindowView:
    """The columns the animation needs (the only place that names them; docs/outputs.md)."""
    n = 0
    while f"f{n + 1}_x" in df.columns:
        n += 1

    def arr(col: str) -> np.ndarray:
        return df[col].to_numpy(dtype=float)

    truth = (
        np.stack(
            [np.stack([arr(f"f{i}_x"), arr(f"f{i}_y")], axis=-1) for i in range(1, n + 1)], axis=1
        )
        if n
        else np.zeros((len(df), 0, 2))
    )
    est = (
        np.stack(
            [np.stack([arr(f"f{i}_x_est"), arr(f"f{i}_y_est")], axis=-1) for i in range(1, n + 1)],
            axis=1,
        )
        if n
        else np.zeros((len(df), 0, 2))
    )
    return WindowView(
        arr("t"),
        arr("w"),
        arr("w_sch"),
        df["critical"].to_numpy(dtype=bool),
        arr("v_leader"),
        np.stack([arr("leader_x"), arr("leader_y"), arr("leader_heading")], -1),
        truth,
        est,
    )


#: What animate reads from a scenario run directory.
RUN_FILES = ("windows.csv", "jobs.csv", "manifest.json", "summary.json")


def load_run(run_dir: str | os.PathLike[str]) -> tuple[pd.DataFrame, pd.DataFrame, dict]:
    """windows.csv, jobs.csv and manifest.json of a scenario run directory.

    The run must be whole: windows.csv has as many rows as ``summary.json`` counts windows
    (a truncated or edited table is refused), and at least one window.
    """
    d = Path(run_dir)
    for name in RUN_FILES:
        if not (d / name).is_file():
            raise InputError(
                f"{d}: not a scenario run directory (no {name}; rtsim scenario writes one)"
            )
    try:
        manifest = json.loads((d / "manifest.json").read_text("utf-8"))
        summary = json.loads((d / "summary.json").read_text("utf-8"))
        windows, jobs = pd.read_csv(d / "windows.csv"), pd.read_csv(d / "jobs.csv")
    except (ValueError, OSError, RecursionError) as exc:
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{d}: cannot read the run: {why}") from None
    count = summary.get("windows") if isinstance(summary, dict) else None
    if not isinstance(count, int):
        raise InputError(f"{d / 'summary.json'}: no window count; not a scenario run's summary")
    if count == 0:
        raise InputError(f"{d}: the run has no processing window; nothing to animate")
    if len(windows) != count or windows.iloc[-1].isna().all():
        raise InputError(
            f"{d / 'windows.csv'}: {len(windows)} rows where summary.json counts "
            f"{count} windows (truncated or edited); run rtsim scenario again"
        )
    return windows, jobs, manifest


def _geometry(manifest: dict) -> tuple[float, float]:
    """(follower radius cm, r_H cm) from a scenario manifest."""
    sc = manifest.get("inputs", {}).get("scenario", {})
    radius = float(sc.get("follower", {}).get("radius", FollowerParams.radius))
    r_h = sc.get("thresholds", {}).get("r_H", R_H_DEFAULT)  # the run's r_H (sensing.r_H)
    return radius, float(r_h)


def hit_beams(leader: np.ndarray, pos: np.ndarray, radius: float) -> np.ndarray:
    """Angles (world frame) of the laser beams, on the leader's 0.5° grid, that meet a disc of
    ``radius`` at ``pos`` (no shadowing); empty when the leader is inside the disc."""
    dx, dy = pos[0] - leader[0], pos[1] - leader[1]
    d = math.hypot(dx, dy)
    if not math.isfinite(d) or d <= radius:
        return np.zeros(0)
    bearing = math.atan2(dy, dx) - leader[2]
    half = math.asin(radius / d)
    k = np.arange(
        math.ceil((bearing - half) / BEAM_STEP), math.floor((bearing + half) / BEAM_STEP) + 1
    )
    return leader[2] + k * BEAM_STEP


def animate_run(
    run_dir: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    start_s: float | None = None,
    end_s: float | None = None,
    fps: int = 10,
    every: int = 1,
    progress: Callable[[int, int], Any] | None = None,
    dpi: int = 80,
) -> Path:
    """Render ``run_dir`` to ``out`` (module docstring); returns the path written.

    ``start_s`` / ``end_s``: simulated seconds (default: the whole run); one frame per window,
    or per ``every``-th window.
    ``progress(i, total)`` is called after each frame.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)

    out = Path(out)
    if out.suffix.lower() not in FORMATS:
        raise InputError(f"{out}: --out must end in {', '.join(FORMATS)}")
    with FileSet("animate", inputs=tuple(Path(run_dir) / n for n in RUN_FILES)) as files:
        files.check(out, "--out")
        files.check(sidecar(out), "--out")
        _animate(
            run_dir,
            out,
            files,
            start_s=start_s,
            end_s=end_s,
            fps=fps,
            every=every,
            progress=progress,
            dpi=dpi,
        )
        files.commit()
    return out


def _ffmpeg(out: Path, fps: int, every: int) -> str | None:
    """Check ``fps`` and ``every``; the ffmpeg an MP4 ``out`` needs (None for .gif, .html)."""
    if not (isinstance(fps, int) and 1 <= fps <= 60):
        raise InputError(f"--fps must be an integer in 1..60, got {fps!r}")
    if isinstance(every, bool) or not isinstance(every, int) or every < 1:
        raise InputError(f"--every must be a positive integer, got {every!r}")
    ffmpeg = None
    if out.suffix.lower() == ".mp4":
        ffmpeg = shutil.which("ffmpeg")
        if ffmpeg is None:
            try:
                import imageio_ffmpeg  # type: ignore[import-not-found]

                ffmpeg = imageio_ffmpeg.get_ffmpeg_exe()
            except (ImportError, RuntimeError):
                raise InputError(
                    f"{out}: MP4 needs ffmpeg (install it, or pip install "
                    f"imageio-ffmpeg); .gif and .html need nothing more"
                ) from None
    return ffmpeg


def _frames(t_s: Any, start_s: float | None, end_s: float | None, every: int, run_dir: Any) -> Any:
    """The indices of the windows drawn: every ``every``-th window whose time ``t_s`` (s) is
    in [start_s, end_s]."""
    lo = -math.inf if start_s is None else float(start_s)
    hi = math.inf if end_s is None else float(end_s)
    if not lo < hi:
        raise InputError(f"--start {start_s} must be before --end {end_s}")
    frames = np.flatnonzero((t_s >= lo) & (t_s <= hi))[::every]
    if not len(frames):
        raise InputError(
            f"{run_dir}: no window between {start_s} and {end_s} s "
            f"(the run covers {t_s[0]:.1f}..{t_s[-1]:.1f} s)"
        )
    return frames


def _save(
    anim: Any, fig: Any, out: Path, files: Any, *, fps: int, dpi: int, ffmpeg: str | None
) -> None:
    """Write the animation into the staging area of ``files`` (the format: ``out``'s suffix)."""
    import matplotlib
    from matplotlib import animation

    suffix = out.suffix.lower()
    tmp_file = files.add(out, "--out")  # staged under out's own name: the writers pick the
    if suffix == ".gif":  # format by the suffix
        anim.save(tmp_file, writer=animation.PillowWriter(fps=fps), dpi=dpi)
    elif suffix == ".mp4":
        matplotlib.rcParams["animation.ffmpeg_path"] = ffmpeg
        anim.save(tmp_file, writer=animation.FFMpegWriter(fps=fps), dpi=dpi)
    else:
        fig.set_dpi(dpi)
        tmp_file.write_text(anim.to_jshtml(fps=fps, default_mode="once"), "utf-8")


def _sidecar(
    out: Path,
    files: Any,
    run_dir: str | os.PathLike[str],
    *,
    start_s: float | None,
    end_s: float | None,
    fps: int,
    every: int,
) -> None:
    """The manifest beside ``out``."""
    write_json(
        files.add(sidecar(out), "--out"),
        build_manifest(
            command="animate",
            seed=None,
            extra={"outputs": [out.name]},
            inputs={
                "run_dir": str(run_dir),
                "start_s": start_s,
                "end_s": end_s,
                "fps": fps,
                "every": every,
            },
        ),
    )


def _animate(
    run_dir: str | os.PathLike[str],
    out: Path,
    files: Any,
    *,
    start_s: float | None,
    end_s: float | None,
    fps: int,
    every: int,
    progress: Callable[[int, int], Any] | None,
    dpi: int,
) -> None:
    """Render into the staging area of ``files`` (see `animate_run`)."""
    import matplotlib
    from matplotlib import animation
    from matplotlib.collections import LineCollection
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle

    ffmpeg = _ffmpeg(out, fps, every)
    windows, jobs, manifest = load_run(run_dir)
    view = window_view(windows)
    t_s = view.t / 1000.0
    frames = _frames(t_s, start_s, end_s, every, run_dir)
    radius, r_h = _geometry(manifest)
    tasks = list(dict.fromkeys(jobs["task"].astype(str)))
    jobs = jobs[jobs["start"].notna()]

    fig = Figure(figsize=(8, 7.2))
    gs = fig.add_gridspec(
        2, 1, height_ratios=(3.2, 1), left=0.17, right=0.97, top=0.90, bottom=0.07, hspace=0.22
    )
    ax = fig.add_subplot(gs[0])
    gx = fig.add_subplot(gs[1])
    # a view that follows the group: centred on it, as large as its largest extent
    group = np.concatenate([view.leader[frames, None, :2], view.truth[frames]], axis=1)
    centre = np.nanmean(group, axis=1)
    half = float(np.nanmax(np.abs(group - centre[:, None, :]))) + max(radius, r_h) * 3
    ax.set_aspect("equal")
    ax.set_xlabel("x (cm)")
    ax.set_ylabel("y (cm)")
    ax.plot(view.leader[:, 0], view.leader[:, 1], color="0.85", lw=1, zorder=0)
    beams = LineCollection([], colors="tab:orange", linewidths=0.4, alpha=0.6, zorder=1)
    ax.add_collection(beams)
    (leader_dot,) = ax.plot([], [], "k^", ms=9, zorder=4, label="leader")
    truth_dots = ax.scatter([], [], s=60, c="tab:blue", zorder=3, label="followers (truth)")
    est_dots = ax.scatter(
        [],
        [],
        s=60,
        facecolors="none",
        edgecolors="tab:green",
        zorder=3,
        label="leader's estimates",
    )
    hough = [Circle((0, 0), r_h, fill=False, lw=1.2, ls="--", zorder=2) for _ in range(view.n)]
    for c in hough:
        ax.add_patch(c)
    # above the map, never over the robots (the view follows them anywhere in it)
    fig.legend(
        handles=[leader_dot, truth_dots, est_dots],
        loc="upper center",
        ncols=3,
        fontsize=8,
        frameon=False,
        bbox_to_anchor=(0.57, 1.0),
    )
    title = ax.set_title("", fontsize=10)

    colors = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    gx.set_yticks(range(len(tasks)), tasks)
    gx.set_ylim(-0.6, len(tasks) + 0.6)
    gx.invert_yaxis()
    gx.set_xlabel("time (ms)")
    row = {t: i for i, t in enumerate(tasks)}
    job_t, job_s, job_f = (
        jobs["task"].astype(str).to_numpy(),
        jobs["start"].to_numpy(float),
        jobs["finish"].to_numpy(float),
    )

    drawn: set[int] = set()

    def draw(k: int) -> list[Any]:
        i = int(frames[k])
        lead = view.leader[i]
        ax.set_xlim(centre[k, 0] - half, centre[k, 0] + half)
        ax.set_ylim(centre[k, 1] - half * 0.75, centre[k, 1] + half * 0.75)
        leader_dot.set_data([lead[0]], [lead[1]])
        truth_dots.set_offsets(view.truth[i])
        est_dots.set_offsets(view.estimate[i])
        segs = []
        for j in range(view.n):
            for a in hit_beams(lead, view.truth[i, j], radius):
                d = math.hypot(*(view.truth[i, j] - lead[:2]))
                segs.append(
                    [(lead[0], lead[1]), (lead[0] + d * math.cos(a), lead[1] + d * math.sin(a))]
                )
        beams.set_segments(segs)
        for j, c in enumerate(hough):
            c.center = tuple(view.estimate[i, j])
            c.set_edgecolor("tab:red" if view.critical[i] else "tab:green")
        crit = ", critical" if view.critical[i] else ""
        title.set_text(
            f"window {i}, t = {t_s[i]:.2f} s: V_L = {view.v_leader[i]:.1f} cm/s, "
            f"w = {view.w[i]:.1f} ms, w_sch = {view.w_sch[i]:.1f} ms{crit}"
        )
        title.set_color("tab:red" if view.critical[i] else "black")
        # the schedule strip: previous and current window
        for artist in [*gx.collections, *gx.patches, *gx.lines, *gx.texts]:
            artist.remove()
        t0 = view.t[i - 1] if i > 0 else view.t[i]
        t1 = view.t[i] + max(view.w[i], view.w_sch[i]) * 1.05
        sel = (job_f >= t0) & (job_s <= t1)
        for tk, s, f in zip(job_t[sel], job_s[sel], job_f[sel], strict=True):
            gx.broken_barh(
                [(s, f - s)], (row[tk] - 0.35, 0.7), facecolors=colors[row[tk] % len(colors)]
            )
        y = len(tasks) - 0.1
        for r in ((i - 1,) if i > 0 else ()) + (i,):
            gx.hlines(y, view.t[r], view.t[r] + view.w[r], colors="k", lw=2)
            gx.hlines(
                y + 0.35,
                view.t[r],
                view.t[r] + view.w_sch[r],
                colors="tab:red",
                lw=2,
                linestyles=":",
            )
            gx.axvline(view.t[r], color="0.5", lw=0.8)
        gx.text(t1, y, " w", va="center", fontsize=8)
        gx.text(t1, y + 0.35, " w_sch", va="center", fontsize=8, color="tab:red")
        gx.set_xlim(t0, t1 + 0.08 * (t1 - t0))
        if progress is not None and k not in drawn:  # FuncAnimation draws frame 0 twice
            drawn.add(k)
            progress(len(drawn), len(frames))
        return []

    anim = animation.FuncAnimation(
        fig, draw, frames=len(frames), interval=1000 / fps, blit=False, repeat=False
    )
    _save(anim, fig, out, files, fps=fps, dpi=dpi, ffmpeg=ffmpeg)
    _sidecar(out, files, run_dir, start_s=start_s, end_s=end_s, fps=fps, every=every)
