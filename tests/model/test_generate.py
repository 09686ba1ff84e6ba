"""Task-set generators (UUniFast, UUniFast-Discard, periods) and ``rtsim generate``."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from rtsim.cli import main
from rtsim.config.taskset import load_taskset
from rtsim.errors import InputError
from rtsim.model.generate import (
    PeriodSpec,
    draw_periods,
    parse_periods,
    random_taskset,
    uunifast,
    uunifast_discard,
)


@pytest.mark.parametrize(("n", "u"), [(1, 0.7), (2, 0.5), (5, 0.95), (10, 0.3)])
def test_uunifast_sums_to_u(n, u):
    rng = np.random.default_rng(n)
    for _ in range(50):
        us = uunifast(n, u, rng)
        assert us.shape == (n,)
        assert np.all(us >= 0) and math.isclose(us.sum(), u, rel_tol=1e-12)


def test_uunifast_is_uniform_on_the_simplex():
    # uniform on the simplex: each u_i/U ~ Beta(1, n-1); for n = 3, P(u_1 < U/2) = 1 - 1/4
    # and E[u_i] = U/3 for every i (UUniFast's point: no position is favoured)
    rng = np.random.default_rng(0)
    x = np.array([uunifast(3, 1.0, rng) for _ in range(20_000)])
    se = math.sqrt(0.75 * 0.25 / len(x))
    assert abs((x[:, 0] < 0.5).mean() - 0.75) < 4 * se
    assert np.allclose(x.mean(axis=0), 1 / 3, atol=4 * math.sqrt(1 / 18 / len(x)))


def test_uunifast_discard_keeps_each_below_one():
    rng = np.random.default_rng(1)
    for _ in range(100):
        us = uunifast_discard(4, 2.5, rng)
        assert np.all(us <= 1.0) and math.isclose(us.sum(), 2.5, rel_tol=1e-12)
    with pytest.raises(InputError, match="above n = 2"):
        uunifast_discard(2, 2.5, rng)
    with pytest.raises(InputError, match="n must be a positive integer"):
        uunifast(0, 0.5, rng)


def test_loguniform_periods():
    rng = np.random.default_rng(2)
    ps = draw_periods(20_000, PeriodSpec(10, 1000), rng)
    assert ps.min() >= 10 and ps.max() <= 1000
    # log-uniform: half below the geometric mean 100, a third in each decade-and-a-half
    assert abs((ps < 100).mean() - 0.5) < 4 * math.sqrt(0.25 / len(ps))
    rounded = draw_periods(100, PeriodSpec(10, 1000, granularity=5), rng)
    assert np.all(rounded % 5 == 0)


def test_periods_from_a_set_and_parsing():
    rng = np.random.default_rng(3)
    spec = parse_periods("10,20,40")
    assert spec.choices == (10.0, 20.0, 40.0)
    ps = draw_periods(3000, spec, rng)
    assert set(ps) == {10.0, 20.0, 40.0}
    assert parse_periods("loguniform:5..50") == PeriodSpec(5.0, 50.0)
    for bad in ("loguniform:10", "10..20", "loguniform:50..5"):
        with pytest.raises(InputError, match="periods"):
            parse_periods(bad)


def test_random_taskset_dm_priorities_and_constrained_deadlines():
    rng = np.random.default_rng(4)
    ts = random_taskset(6, 0.8, rng, "loguniform:10..1000", deadline_factor=(0.5, 1.0))
    assert math.isclose(sum(t.wcet / t.period for t in ts.tasks), 0.8, rel_tol=1e-9)
    ds = [t.deadline for t in ts.tasks]
    assert ds == sorted(ds)  # deadline-monotonic: priority order = deadline order
    assert all(t.wcet <= t.deadline <= t.period for t in ts.tasks)
    assert [t.priority for t in ts.tasks] == list(range(1, 7))


def test_generate_cli_writes_loadable_sets(tmp_path, capsys):
    out = tmp_path / "sets"
    argv = [
        "generate",
        "--tasks",
        "5",
        "--utilization",
        "0.7",
        "--periods",
        "10,20,40",
        "--count",
        "4",
        "--seed",
        "9",
        "--out",
        str(out),
    ]
    assert main(argv) == 0
    capsys.readouterr()
    files = sorted(out.glob("set_*.toml"))
    assert [f.name for f in files] == [f"set_{i:04d}.toml" for i in range(4)]
    for f in files:
        ts = load_taskset(f)
        assert len(ts.tasks) == 5
        assert math.isclose(sum(t.wcet / t.period for t in ts.tasks), 0.7, rel_tol=1e-12)
        assert {t.period for t in ts.tasks} <= {10.0, 20.0, 40.0}
    man = json.loads((out / "manifest.json").read_text())
    assert man["seed"] == 9 and man["inputs"]["count"] == 4
    # set i does not depend on --count, and the same seed gives the same files
    again = tmp_path / "again"
    assert main(argv[:-6] + ["--count", "2", "--seed", "9", "--out", str(again)]) == 0
    assert (again / "set_0001.toml").read_text() == (out / "set_0001.toml").read_text()


def test_generate_cli_overload_and_errors(tmp_path, capsys):
    out = tmp_path / "over"
    assert (
        main(
            [
                "generate",
                "--tasks",
                "3",
                "--utilization",
                "1.6",
                "--out",
                str(out),
                "--deadlines",
                "constrained:0.5..1",
            ]
        )
        == 0
    )
    ts = load_taskset(out / "set_0000.toml")
    assert math.isclose(sum(t.wcet / t.period for t in ts.tasks), 1.6, rel_tol=1e-9)
    assert all(t.deadline <= t.period for t in ts.tasks)
    capsys.readouterr()
    assert (
        main(
            [
                "generate",
                "--tasks",
                "3",
                "--utilization",
                "0.5",
                "--periods",
                "a,b",
                "--out",
                str(out),
            ]
        )
        == 2
    )
    assert capsys.readouterr().err.startswith("rtsim: --periods")
    assert (
        main(
            [
                "generate",
                "--tasks",
                "3",
                "--utilization",
                "0.5",
                "--deadlines",
                "tight",
                "--out",
                str(out),
            ]
        )
        == 2
    )
    assert "--deadlines" in capsys.readouterr().err
