"""Whole output directories (issue 13 item 2): staged beside the target and swapped in.

The kill test runs ``rtsim scenario`` in a subprocess over an earlier run and kills it (-9)
at random moments: after every kill the directory is entirely the earlier run or entirely
the new one, and the next complete run leaves no staging directory behind.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import random
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import rtsim.io.outdir as outdir
from rtsim.cli import main
from rtsim.errors import InputError
from rtsim.io.outdir import clean_leftovers, is_rtsim_output, stage

ROOT = Path(__file__).resolve().parent.parent
TEST2 = ROOT / "experiments" / "scenarios" / "test2.toml"
EXAMPLE = ROOT / "tasksets" / "example.toml"


def _staging(d: Path) -> list[Path]:
    return [p for p in d.parent.iterdir() if p.name.startswith(f".{d.name}.rtsim-")]


def _scenario(out: Path, *extra: str, seed: int = 1, duration: str = "5") -> int:
    return main(["scenario", str(TEST2), "--duration", duration, "--seed", str(seed),
                 *extra, "--out", str(out)])


def _whole(d: Path) -> dict:
    """Check ``d`` is one complete scenario run; returns its manifest."""
    man = json.loads((d / "manifest.json").read_text())
    entries = {p.name for p in d.iterdir()}
    assert entries == set(man["outputs"]) | {"manifest.json"}, entries ^ set(man["outputs"])
    summary = json.loads((d / "summary.json").read_text())
    assert summary["seed"] == man["seed"]
    rows = sum(1 for _ in open(d / "windows.csv")) - 1
    assert rows == summary["windows"]
    return man


# --- the library ---------------------------------------------------------------------------


def test_stage_commit_swaps_in_and_leaves_nothing(tmp_path: Path) -> None:
    target = tmp_path / "out"
    for k in range(3):  # new, then replacing an earlier output twice
        with stage(target) as staged:
            assert staged.path.parent == tmp_path and staged.path.name.startswith(".out.rtsim-")
            assert not (target / f"f{k}.txt").exists()
            (staged.path / f"f{k}.txt").write_text(str(k))
            (staged.path / "manifest.json").write_text(json.dumps(
                {"rtsim_version": "x", "outputs": [f"f{k}.txt"]}))
            staged.commit()
        assert sorted(p.name for p in target.iterdir()) == sorted(["manifest.json", f"f{k}.txt"])
        assert _staging(target) == []


def test_two_runs_into_one_target_swap_one_after_the_other(tmp_path: Path) -> None:
    target = tmp_path / "out"
    a, b = stage(target), stage(target)  # both staged before either finishes
    for staged, name in ((a, "a.txt"), (b, "b.txt")):
        (staged.path / name).write_text(name)
        (staged.path / "manifest.json").write_text(json.dumps({"rtsim_version": "x",
                                                           "outputs": [name]}))
    a.commit()
    assert sorted(p.name for p in target.iterdir()) == ["a.txt", "manifest.json"]
    b.commit()
    assert sorted(p.name for p in target.iterdir()) == ["b.txt", "manifest.json"]
    assert _staging(target) == []


def test_fallback_swap_without_exchange(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(outdir, "exchange", lambda a, b: False)
    target = tmp_path / "out"
    target.mkdir()
    (target / "old.txt").write_text("old")
    (target / "manifest.json").write_text(json.dumps({"rtsim_version": "x",
                                                      "outputs": ["old.txt"]}))
    with stage(target) as staged:
        (staged.path / "new.txt").write_text("new")
        staged.commit()
    assert sorted(p.name for p in target.iterdir()) == ["new.txt"]
    assert _staging(target) == []


def test_abort_leaves_the_target_alone(tmp_path: Path) -> None:
    target = tmp_path / "out"
    target.mkdir()
    with pytest.raises(RuntimeError), stage(target) as staged:
        (staged.path / "half.csv").write_text("x")
        raise RuntimeError("killed")
    assert list(target.iterdir()) == [] and _staging(target) == []


def test_leftovers_of_killed_runs_are_removed_but_live_ones_kept(tmp_path: Path) -> None:
    target = tmp_path / "out"
    dead = tmp_path / ".out.rtsim-999-dead"
    live = tmp_path / ".out.rtsim-998-live"
    other = tmp_path / ".other.rtsim-1-x"
    for d in (dead, live, other):
        d.mkdir()
        (d / "windows.csv").write_text("partial")
    fd = os.open(live, os.O_RDONLY)
    fcntl.flock(fd, fcntl.LOCK_EX)  # a live run holds its staging directory's lock
    try:
        assert clean_leftovers(target) == [dead]
        assert live.exists() and other.exists() and not dead.exists()
    finally:
        os.close(fd)
    assert clean_leftovers(target) == [live]


def test_fallback_kill_between_renames_restores_the_earlier_run(tmp_path: Path) -> None:
    target = tmp_path / "out"
    saved = tmp_path / ".out.rtsim-5-abc.old"  # the earlier run, renamed aside
    saved.mkdir()
    (saved / "manifest.json").write_text(json.dumps({"rtsim_version": "x", "outputs": []}))
    clean_leftovers(target)
    assert (target / "manifest.json").exists() and not saved.exists()


@pytest.mark.parametrize("setup,match", [
    ("user", "not empty and not an earlier rtsim output"),
    ("unlisted", "not empty and not an earlier rtsim output"),
    ("corrupt", "not empty and not an earlier rtsim output"),
    ("file", "exists and is not a directory"),
    ("symlink", "is a symlink"),
])
def test_refuses_a_directory_it_must_not_replace(tmp_path: Path, setup: str, match: str) -> None:
    target = tmp_path / "out"
    if setup == "file":
        target.write_text("mine")
    elif setup == "symlink":
        (tmp_path / "real").mkdir()
        target.symlink_to(tmp_path / "real")
    else:
        target.mkdir()
        (target / "thesis.tex").write_text("mine")
        if setup == "unlisted":  # an rtsim manifest that does not list thesis.tex
            (target / "manifest.json").write_text(json.dumps(
                {"rtsim_version": "x", "outputs": ["windows.csv"]}))
        elif setup == "corrupt":
            (target / "manifest.json").write_text("{not json")
    before = sorted(p.name for p in tmp_path.iterdir())
    with pytest.raises(InputError, match=match) as exc:
        stage(target)
    assert "--out" in str(exc.value) and "\n" not in str(exc.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    if setup not in ("file", "symlink"):
        assert (target / "thesis.tex").read_text() == "mine"


def test_refuses_the_working_directory_and_its_ancestors(tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    inner = tmp_path / "a" / "b"
    inner.mkdir(parents=True)
    monkeypatch.chdir(inner)
    for t in (".", str(inner), str(tmp_path / "a"), ".."):
        with pytest.raises(InputError, match="working directory"):
            stage(t)


def test_is_rtsim_output(tmp_path: Path) -> None:
    assert not is_rtsim_output(ROOT)  # a repository is nobody's output
    d = tmp_path / "old_reproduce"
    d.mkdir()
    for name in ("summary.csv", "report.html", "test1"):
        (d / name).mkdir() if name == "test1" else (d / name).write_text("x")
    (d / "manifest.json").write_text(json.dumps(
        {"rtsim_version": "0.1", "outputs": ["summary.csv", "test1/adjust/windows.csv"]}))
    assert is_rtsim_output(d)  # earlier versions left report.html unlisted
    (d / ".hidden").write_text("x")
    assert not is_rtsim_output(d)
    (d / ".hidden").unlink()
    (d / "manifest.json").write_text(json.dumps({"outputs": ["summary.csv", "test1"]}))
    assert not is_rtsim_output(d)  # not rtsim's manifest


# --- the commands --------------------------------------------------------------------------


def test_scenario_rerun_leaves_no_file_of_the_earlier_run(tmp_path: Path) -> None:
    out = tmp_path / "run"
    assert _scenario(out, "--parquet") == 0
    first = _whole(out)
    assert "paths.png" in first["outputs"] and "windows.parquet" in first["outputs"]
    assert _scenario(out, "--no-figures", seed=2) == 0
    man = _whole(out)
    assert man["seed"] == 2
    assert not list(out.glob("*.png")) and not (out / "windows.parquet").exists()
    assert _staging(out) == []


def test_unwritable_out_is_refused_before_the_simulation(tmp_path: Path, capsys,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    import rtsim.coupling

    def boom(*a: object, **k: object) -> None:
        raise AssertionError("the simulation ran")

    monkeypatch.setattr(rtsim.coupling, "run_scenario", boom)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    for bad in ("/sys/rtsim_test_out", str(blocker / "out")):
        assert _scenario(Path(bad)) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("rtsim: --out ") and "cannot write in" in err
        assert len(err.splitlines()) == 1
    user = tmp_path / "mine"
    user.mkdir()
    (user / "notes.txt").write_text("keep")
    assert _scenario(user) == 2
    assert "not an earlier rtsim output" in capsys.readouterr().err
    assert (user / "notes.txt").read_text() == "keep"


def test_simulate_files_reserved_before_and_renamed_together(tmp_path: Path, capsys,
                                                             monkeypatch: pytest.MonkeyPatch
                                                             ) -> None:
    import rtsim.cli.simulate as sim

    assert main(["simulate", str(EXAMPLE), "--horizon", "1000",
                 "--jobs", "/sys/rtsim_test/jobs.csv"]) == 2
    assert "--jobs /sys/rtsim_test/jobs.csv: cannot write in" in capsys.readouterr().err

    def fail(*a: object, **k: object) -> None:
        raise RuntimeError("histogram failed")

    monkeypatch.setattr(sim, "_save_histograms", fail)
    with pytest.raises(RuntimeError):
        main(["simulate", str(EXAMPLE), "--horizon", "1000", "--jobs",
              str(tmp_path / "jobs.csv"), "--histogram", str(tmp_path / "h.png")])
    assert list(tmp_path.iterdir()) == []  # neither the jobs nor a temporary file


def test_simulate_never_writes_into_another_runs_directory(tmp_path: Path, capsys) -> None:
    out = tmp_path / "run"
    assert _scenario(out, "--no-figures") == 0
    before = sorted((p.name, p.read_bytes()) for p in out.iterdir())
    for name in ("sim_jobs.csv", "jobs.csv"):
        assert main(["simulate", str(EXAMPLE), "--horizon", "1000",
                     "--jobs", str(out / name)]) == 2
        assert "output directory of `rtsim scenario`" in capsys.readouterr().err
    assert sorted((p.name, p.read_bytes()) for p in out.iterdir()) == before
    # beside a user's own files: a manifest of its own beside the file
    user = tmp_path / "user"
    user.mkdir()
    (user / "manifest.json").write_text("{}")
    assert main(["simulate", str(EXAMPLE), "--horizon", "1000",
                 "--jobs", str(user / "sim_jobs.csv")]) == 0
    assert (user / "manifest.json").read_text() == "{}"
    side = json.loads((user / "sim_jobs.csv.manifest.json").read_text())
    assert side["command"] == "simulate" and side["outputs"] == ["sim_jobs.csv"]
    # a directory of its own: manifest.json, replaced by a rerun writing the same files
    own = tmp_path / "own"
    for horizon in ("1000", "2000"):
        assert main(["simulate", str(EXAMPLE), "--horizon", horizon,
                     "--jobs", str(own / "jobs.csv")]) == 0
        man = json.loads((own / "manifest.json").read_text())
        assert man["inputs"]["horizon"] == float(horizon) and man["outputs"] == ["jobs.csv"]
    assert sorted(p.name for p in own.iterdir()) == ["jobs.csv", "manifest.json"]


def test_reproduce_refuses_docs_inside_out(tmp_path: Path, capsys) -> None:
    out = tmp_path / "paper"
    assert main(["reproduce", "--quick", "--out", str(out), "--docs", str(out / "docs")]) == 2
    assert "--docs" in capsys.readouterr().err
    assert not out.exists()


# --- kill -9 at random moments ----------------------------------------------------------


_RUN = ("import sys; from rtsim.cli import main; sys.exit(main(['scenario', sys.argv[1], "
        "'--duration', '10', '--seed', sys.argv[2], '--parquet', '--out', sys.argv[3]]))")


def _digest(d: Path) -> str:
    return hashlib.sha256((d / "windows.csv").read_bytes()).hexdigest()


@pytest.mark.slow
def test_kill_minus_9_never_leaves_a_mixed_directory(tmp_path: Path) -> None:
    out = tmp_path / "run"
    env = {**os.environ, "MPLBACKEND": "Agg"}

    def start(seed: int) -> subprocess.Popen[bytes]:
        return subprocess.Popen([sys.executable, "-c", _RUN, str(TEST2), str(seed), str(out)],
                                cwd=ROOT, env=env, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)

    t0 = time.perf_counter()
    assert start(1).wait(timeout=120) == 0
    full = time.perf_counter() - t0  # one complete run, start-up included
    digests = {1: _digest(out)}
    assert start(2).wait(timeout=120) == 0
    digests[2] = _digest(out)
    assert digests[1] != digests[2]
    rng = random.Random(13)
    for k in range(6):
        seed = 1 + k % 2  # alternate, so "new" and "old" differ
        old = json.loads((out / "manifest.json").read_text())["seed"]
        proc = start(seed)
        time.sleep(rng.uniform(0.3, 1.1) * full)
        proc.kill()
        proc.wait()
        man = _whole(out)
        assert man["seed"] in (old, seed)
        assert _digest(out) == digests[man["seed"]]
    assert start(1).wait(timeout=120) == 0
    assert _whole(out)["seed"] == 1 and _digest(out) == digests[1]
    assert _staging(out) == []  # the leftovers of every killed run are gone
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


_NAMES = st.sampled_from(["windows.csv", "jobs.csv", "paths.png", ".hidden", "notes.txt",
                          "sub", "report.html", "summary.json"])


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(present=st.sets(_NAMES, max_size=6), listed=st.sets(_NAMES, max_size=6),
       manifest=st.sampled_from(["rtsim", "foreign", "none", "corrupt"]))
def test_only_an_earlier_rtsim_output_is_replaced(tmp_path_factory: pytest.TempPathFactory,
                                                  present: set[str], listed: set[str],
                                                  manifest: str) -> None:
    """Random directory contents: stage() accepts exactly the empty directory and the one
    whose rtsim manifest lists every entry (report.html aside); a refused one is untouched."""
    target = tmp_path_factory.mktemp("h") / "out"
    target.mkdir()
    for name in present:
        (target / name).mkdir() if name == "sub" else (target / name).write_text(name)
    if manifest != "none":
        body = {"rtsim": {"rtsim_version": "1", "outputs": sorted(listed)},
                "foreign": {"outputs": sorted(listed)}}.get(manifest)
        (target / "manifest.json").write_text(json.dumps(body) if body else "{")
    entries = {p.name for p in target.iterdir()}
    ok = not entries or (manifest == "rtsim" and
                         entries <= listed | {"manifest.json", "report.html"})
    if ok:
        with stage(target) as staged:
            (staged.path / "new.txt").write_text("new")
            staged.commit()
        assert [p.name for p in target.iterdir()] == ["new.txt"]
    else:
        with pytest.raises(InputError, match="not an earlier rtsim output"):
            stage(target)
        assert {p.name for p in target.iterdir()} == entries
    assert _staging(target) == []
