"""The sweep engine: equal tables serially, on processes and on Dask; failures; seeds; resume."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pandas as pd
import pytest

from rtsim.cli import main
from rtsim.config.taskset import load_taskset, parse_taskset
from rtsim.sweep import KindSpec, Sweep, load_sweep, parse_sweep, register_kind, run_sweep
from rtsim.sweep.kinds import KINDS, _need

# the sweep files here name their helper functions (code): the user opts in
pytestmark = pytest.mark.usefixtures("allow_code")

HERE = Path(__file__).resolve().parents[1]
ROOT = HERE.parent
SMOKE = ROOT / "experiments" / "sweeps" / "smoke.toml"


@pytest.fixture(autouse=True)
def _helpers_importable(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(HERE))
    monkeypatch.setenv(
        "PYTHONPATH", os.pathsep.join([str(HERE), *filter(None, [os.environ.get("PYTHONPATH")])])
    )


def call_sweep(
    tmp_path: Path,
    function: str,
    n: int = 6,
    options: str = "",
    extra: str = "",
    seed: int = 3,
    name: str = "call.toml",
) -> Path:
    path = tmp_path / name
    path.write_text(
        f'[sweep]\nkind = "call"\nfunction = "sweep_helpers:{function}"\n'
        f"seed = {seed}\n{extra}\n[sweep.options]\n{options}\n"
        f'[grid]\ni = "0..{n - 1}"\n',
        encoding="utf-8",
    )
    return path


@pytest.fixture(scope="module")
def smoke_serial(tmp_path_factory: pytest.TempPathFactory) -> pd.DataFrame:
    return run_sweep(SMOKE, tmp_path_factory.mktemp("serial"), workers=1)


def test_smoke_serial_processes_and_dask_give_equal_tables(
    smoke_serial: pd.DataFrame, tmp_path: Path
) -> None:
    from distributed import LocalCluster

    procs = run_sweep(SMOKE, tmp_path / "procs", workers=2)
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        dask = run_sweep(SMOKE, tmp_path / "dask", dask=cluster.scheduler_address)
    pd.testing.assert_frame_equal(smoke_serial, procs)
    pd.testing.assert_frame_equal(smoke_serial, dask)
    stored = pd.read_parquet(tmp_path / "dask" / "results.parquet")
    pd.testing.assert_frame_equal(smoke_serial, stored)
    assert 8 <= len(smoke_serial) <= 12
    assert (smoke_serial["status"] == "ok").all() and (smoke_serial["error"] == "").all()
    # Point order: n outer, r_H inner, as in the file.
    assert list(zip(smoke_serial["n"], smoke_serial["r_H"], strict=True))[:3] == [
        (1, 10),
        (1, 25),
        (2, 10),
    ]
    timings = pd.read_csv(tmp_path / "procs" / "timings.csv")
    assert list(timings["index"]) == list(range(len(procs)))
    assert (timings["wall_s"] > 0).all() and (timings["cpu_s"] > 0).all()
    assert os.getpid() not in set(timings["pid"])  # worker processes, not this one
    assert not {"wall_s", "host", "pid"} & set(smoke_serial.columns)


def test_smoke_points_equal_direct_simulation(smoke_serial: pd.DataFrame) -> None:
    """One point's metrics recomputed with the loader and simulator called directly."""
    import tomllib

    from rtsim.analysis.bounds import window_bounds
    from rtsim.sim import simulate

    row = smoke_serial.iloc[7]
    data = tomllib.loads((ROOT / "tasksets" / "barrel_robots.toml").read_text())
    data["window"].update(n=int(row["n"]), r_H=int(row["r_H"]))
    for t in data["tasks"]:
        t["bcet"] = {"dead_reckoning": 2, "command": 10}[t["name"]]
    ts = parse_taskset(data, "direct")
    res = simulate(ts, 20000, seed=int(row["point_seed"]), exec_model="uniform", suspension="idle")
    assert row["w"] == pytest.approx(
        window_bounds(
            load_taskset(ROOT / "tasksets" / "barrel_robots.toml").with_window(
                n=int(row["n"]), r_H=int(row["r_H"])
            )
        ).w_sch,
        abs=1e-9,
    )
    for name, s in res.tasks.items():
        assert row[f"max_response.{name}"] == s.max_response
        assert row[f"mean_response.{name}"] == s.mean_response
        assert row[f"misses.{name}"] == s.misses
        assert row[f"jobs.{name}"] == s.completed
    assert row["jobs"] == sum(s.completed for s in res.tasks.values())


def test_same_seed_same_table_other_seed_other_stochastic_metrics(
    smoke_serial: pd.DataFrame, tmp_path: Path
) -> None:
    text = SMOKE.read_text()
    again = run_sweep(SMOKE, tmp_path / "again", workers=1)
    pd.testing.assert_frame_equal(smoke_serial, again)
    other_text = text.replace("seed = 1\n", "seed = 2\n")
    assert other_text != text
    import tomllib

    other = run_sweep(
        parse_sweep(tomllib.loads(other_text), str(SMOKE), SMOKE.parent, other_text),
        tmp_path / "other",
        workers=1,
    )
    assert (other["seed"] == 2).all() and (smoke_serial["seed"] == 1).all()  # as asked
    assert (other["point_seed"] != smoke_serial["point_seed"]).all()
    for col in ("mean_response.command", "mean_response.dead_reckoning"):
        assert (other[col] != smoke_serial[col]).all(), col
    # The window chain has no best case: its responses do not depend on the seed.
    pd.testing.assert_series_equal(other["w"], smoke_serial["w"])


def test_failed_point_is_recorded_and_the_rest_complete(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = call_sweep(tmp_path, "flaky", n=5, options="fail_at = 2")
    out = tmp_path / "out"
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "1", "--quiet"]) == 1
    df = pd.read_parquet(out / "results.parquet")
    assert list(df["status"]) == ["ok", "ok", "failed", "ok", "ok"]
    assert df.loc[2, "error"] == "ValueError: point i=2 is broken on purpose"
    assert pd.isna(df.loc[2, "double"])
    assert list(df.loc[df["status"] == "ok", "double"]) == [0, 2, 6, 8]
    assert (df.loc[df["status"] == "ok", "error"] == "").all()
    rec = json.loads(next((out / "points").glob("000002-*.json")).read_text())
    assert rec["status"] == "failed" and "broken on purpose" in rec["error"]
    # Rerunning skips the failed point too (exit 1 again); --retry-failed recomputes it.
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "1", "--quiet"]) == 1
    log = tmp_path / "calls.log"
    os.environ["RTSIM_SWEEP_TEST_LOG"] = str(log)
    try:
        assert (
            main(
                [
                    "sweep",
                    str(spec),
                    "--out",
                    str(out),
                    "--workers",
                    "1",
                    "--quiet",
                    "--retry-failed",
                ]
            )
            == 1
        )
    finally:
        del os.environ["RTSIM_SWEEP_TEST_LOG"]
    assert not log.exists()  # only i=2 ran, and it raised before logging


def test_resume_computes_only_missing_points(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = tmp_path / "calls.log"
    monkeypatch.setenv("RTSIM_SWEEP_TEST_LOG", str(log))
    spec = call_sweep(tmp_path, "slow", n=7)
    out = tmp_path / "out"
    first = Sweep(spec, out).run(workers=1)
    assert (first.computed, first.skipped, first.failed) == (7, 0, 0)
    assert set(pd.read_csv(out / "timings.csv")["pid"]) == {os.getpid()}  # 1 = in-process
    assert sorted(int(x) for x in log.read_text().split()) == list(range(7))
    for f in sorted((out / "points").glob("*.json"))[2:5]:
        f.unlink()
    log.unlink()
    second = Sweep(spec, out).run(workers=1)
    assert (second.computed, second.skipped) == (3, 4)
    assert sorted(int(x) for x in log.read_text().split()) == [2, 3, 4]
    pd.testing.assert_frame_equal(first.table, second.table)
    assert list(first.table["double"]) == [2 * i for i in range(7)]


def test_a_grown_grid_keeps_its_points_another_change_needs_restart(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = call_sweep(tmp_path, "slow", n=3)
    out = tmp_path / "out"
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    before = {f.name: f.read_text() for f in (out / "points").glob("*.json")}
    call_sweep(tmp_path, "slow", n=4)  # same file, one more point: a grown grid (issue 34)
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    after = {f.name: f.read_text() for f in (out / "points").glob("*.json")}
    assert len(after) == 4 and all(after[k] == v for k, v in before.items())  # kept, not rerun
    assert len(pd.read_parquet(out / "results.parquet")) == 4
    call_sweep(tmp_path, "slow", n=4, options='mode = "x"')  # something else changed
    capsys.readouterr()
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "1", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--restart" in err and str(out) in err
    assert (
        main(["sweep", str(spec), "--out", str(out), "--workers", "1", "--quiet", "--restart"]) == 0
    )
    assert len(pd.read_parquet(out / "results.parquet")) == 4
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["sweep_text"] == spec.read_text()
    assert manifest["fingerprint"] == load_sweep(spec).fingerprint()
    assert manifest["argv"] and manifest["rtsim_version"]


def test_metrics_filter_and_bad_metrics(tmp_path: Path) -> None:
    df = run_sweep(
        call_sweep(tmp_path, "slow", n=2, extra='metrics = ["dou*"]'), tmp_path / "a", workers=1
    )
    assert list(df.columns) == ["i", "seed", "point_seed", "status", "error", "double"]
    df = run_sweep(
        call_sweep(tmp_path, "slow", n=2, extra='metrics = ["nothere"]'), tmp_path / "b", workers=1
    )
    assert (df["status"] == "failed").all()
    assert df["error"].str.contains("metric 'nothere' was not produced").all()
    df = run_sweep(call_sweep(tmp_path, "nested", n=2), tmp_path / "c", workers=1)
    assert df["error"].str.contains("metric 'a' is not a scalar").all()


def test_options_and_seed_reach_the_call(tmp_path: Path) -> None:
    df = run_sweep(
        call_sweep(tmp_path, "echo", n=2, options='mode = "x"'), tmp_path / "o", workers=1
    )
    assert list(df["p.i"]) == [0, 1] and list(df["o.mode"]) == ["x", "x"]
    assert list(df["s"]) == list(df["point_seed"])  # the seed the call received
    assert list(df["seed"]) == [3, 3]  # the sweep's seed (the helper's), as asked


def test_missing_kind_module_fails_points_not_the_sweep(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def needs_missing(point: object) -> dict:
        _need("rtsim.no_such_module", "later")
        return {}

    monkeypatch.setitem(KINDS, "later", KINDS["bounds"])
    register_kind(KindSpec("later", needs_missing))
    path = tmp_path / "s.toml"
    path.write_text('[sweep]\nkind = "later"\n[grid]\nn = [1, 2]\n')
    df = run_sweep(path, tmp_path / "out", workers=1)
    assert list(df["status"]) == ["failed", "failed"]
    assert df["error"].str.contains("kind 'later' needs rtsim.no_such_module").all()


def test_bounds_kind_matches_window_bounds(tmp_path: Path) -> None:
    from rtsim.analysis.bounds import window_bounds

    path = tmp_path / "b.toml"
    path.write_text('[sweep]\nkind = "bounds"\n[grid]\nn = [1, 4]\nk = [34, 39]\n')
    df = run_sweep(path, tmp_path / "out", workers=1)
    paper = load_taskset()
    for _, row in df.iterrows():
        wb = window_bounds(paper.with_window(n=int(row["n"]), k=int(row["k"])))
        for col in ("e_hough", "g", "w_eq7", "w_eq11", "w_sch", "w_rta"):
            assert row[col] == getattr(wb, col)


def test_bad_workers_and_points_dir_without_manifest(tmp_path: Path) -> None:
    from rtsim.errors import SweepError

    spec = call_sweep(tmp_path, "slow", n=2)
    with pytest.raises(SweepError, match="at least 1"):
        run_sweep(spec, tmp_path / "w", workers=0)
    (tmp_path / "x" / "points").mkdir(parents=True)
    (tmp_path / "x" / "points" / "000000-0123456789ab.json").write_text("{}")
    with pytest.raises(SweepError, match="no manifest.json"):
        run_sweep(spec, tmp_path / "x", workers=1)


def test_progress_bar_shows_done_and_failures_only_when_asked(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = call_sweep(tmp_path, "flaky", n=4, options="fail_at = 1")
    run_sweep(spec, tmp_path / "a", workers=1, progress=True)
    err = capsys.readouterr().err
    assert "4/4" in err and "failed=1" in err
    run_sweep(spec, tmp_path / "b", workers=1, progress=False)
    assert capsys.readouterr().err == ""
    # The CLI: stderr is not a terminal here, so no bar; the summary (a result) on stdout,
    # the failed point (a diagnostic) on stderr.
    assert main(["sweep", str(spec), "--out", str(tmp_path / "c"), "--workers", "1"]) == 1
    out, err = capsys.readouterr()
    assert "%|" not in err and "4 points (4 run now, 0 already done), 1 failed" in out
    assert "failed point" in err and "failed point" not in out


def test_scenario_kind_matches_a_direct_coupled_run(tmp_path: Path) -> None:
    import tomllib

    from rtsim.config.scenario import parse_scenario
    from rtsim.coupling import run_scenario

    test1 = ROOT / "experiments" / "scenarios" / "test1.toml"
    path = tmp_path / "sc.toml"
    path.write_text(
        f'[sweep]\nkind = "scenario"\nbase = "{test1}"\n[sweep.options]\n'
        'duration = 3\nmode = "adjust"\n[grid]\n"leader.speed" = [20, 30]\n'
    )
    df = run_sweep(path, tmp_path / "out", workers=1)
    assert list(df["status"]) == ["ok", "ok"]
    row = df.iloc[1]
    data = tomllib.loads(test1.read_text())
    data["leader"]["speed"] = 30
    direct = run_scenario(
        parse_scenario(data, str(test1), base=test1.parent),
        policy="adjust",
        duration_s=3.0,
        seed=int(row["point_seed"]),
        record_jobs=False,
    ).summary
    assert row["v_leader_desired"] == 30 == direct["v_leader_desired"]
    for key in ("windows", "missed", "w_sch", "min_msb_over_wsch", "max_response"):
        assert row[key] == direct[key], key
    for kind, count in direct["violations"].items():
        assert row[f"violations.{kind}"] == count
    assert df.loc[0, "v_leader_desired"] == 20


def test_dask_without_the_extra_is_a_clear_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import sys

    from rtsim.errors import SweepError

    monkeypatch.setitem(sys.modules, "distributed", None)  # import fails as if not installed
    with pytest.raises(SweepError, match=r"pip install 'rtsim\[dask\]'"):
        run_sweep(call_sweep(tmp_path, "slow", n=2), tmp_path / "o", dask="tcp://127.0.0.1:1")
