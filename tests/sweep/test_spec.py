"""Sweep files: parsing, one-line errors, grid points, per-point seeds, overrides, fingerprint."""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import pytest

from rtsim.cli import main
from rtsim.errors import SweepError
from rtsim.sweep import load_sweep, point_seed, points
from rtsim.sweep.grid import point_input

# the sweep files here name their helper functions (code): the user opts in
pytestmark = pytest.mark.usefixtures("allow_code")

HERE = Path(__file__).resolve().parents[1]
ROOT = HERE.parent
PAPER = ROOT / "tasksets" / "barrel_robots.toml"


@pytest.fixture(autouse=True)
def _helpers_importable(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(HERE))


def write(tmp_path: Path, body: str, name: str = "sweep.toml") -> Path:
    path = tmp_path / name
    path.write_text(body, encoding="utf-8")
    return path


def test_ranges_lists_and_scalars(tmp_path: Path) -> None:
    spec = load_sweep(
        write(
            tmp_path,
            f"""
[sweep]
kind = "bounds"
base = "{PAPER}"
[grid]
n = "1..4"
r_H = "0.1..0.3:0.1"
e_cal = 0.002
k = [30, 34]
""",
        )
    )
    grid = dict(spec.grid)
    assert grid["n"] == (1, 2, 3, 4) and all(type(v) is int for v in grid["n"])
    assert grid["r_H"] == (0.1, 0.2, 0.3)
    assert grid["e_cal"] == (0.002,)
    assert grid["k"] == (30, 34)
    assert len(points(spec)) == 4 * 3 * 1 * 2


def test_product_order_and_zip(tmp_path: Path) -> None:
    body = """
[sweep]
kind = "call"
function = "sweep_helpers:echo"
combine = "{c}"
[grid]
a = [1, 2, 3]
b = ["x", "y", "z"]
"""
    prod = points(load_sweep(write(tmp_path, body.format(c="product"))))
    assert [tuple(p.params.values()) for p in prod] == [
        (1, "x"),
        (1, "y"),
        (1, "z"),
        (2, "x"),
        (2, "y"),
        (2, "z"),
        (3, "x"),
        (3, "y"),
        (3, "z"),
    ]
    assert [p.index for p in prod] == list(range(9))
    zipped = points(load_sweep(write(tmp_path, body.format(c="zip"))))
    assert [tuple(p.params.values()) for p in zipped] == [(1, "x"), (2, "y"), (3, "z")]


def _by_hand(sweep_seed: int, params: dict) -> int:
    text = json.dumps({"params": params, "seed": sweep_seed}, sort_keys=True, separators=(",", ":"))
    return int(hashlib.sha256(text.encode()).hexdigest()[:16], 16) % 2**63


def test_point_seed_formula_and_independence_from_index(tmp_path: Path) -> None:
    body = """
[sweep]
kind = "call"
function = "sweep_helpers:echo"
seed = 7
[grid]
a = {a}
b = [0.5, 1.5]
"""
    small = points(load_sweep(write(tmp_path, body.format(a="[1, 2]"))))
    for p in small:
        assert p.seed == _by_hand(7, p.params)
        assert 0 <= p.seed < 2**63
    assert len({p.seed for p in small}) == len(small)
    # A value added in front shifts every index but keeps every seed.
    big = points(load_sweep(write(tmp_path, body.format(a="[0, 1, 2]"))))
    seeds = {json.dumps(p.params): p.seed for p in big}
    for p in small:
        assert seeds[json.dumps(p.params)] == p.seed
    assert [p.index for p in big if p.params["a"] == 1] == [2, 3]
    assert point_seed(8, {"a": 1, "b": 0.5}) != point_seed(7, {"a": 1, "b": 0.5})


def test_seed_in_grid_overrides_the_derived_seed(tmp_path: Path) -> None:
    spec = load_sweep(
        write(
            tmp_path,
            """
[sweep]
kind = "call"
function = "sweep_helpers:echo"
combine = "zip"
[grid]
a = [1, 2]
seed = [11, 12]
""",
        )
    )
    pts = points(spec)
    assert [p.seed for p in pts] == [11, 12]
    assert point_input(spec, pts[0]).params == {"a": 1}


def test_overrides_reach_the_task_set(tmp_path: Path) -> None:
    spec = load_sweep(
        write(
            tmp_path,
            f"""
[sweep]
kind = "analyze"
base = "{PAPER}"
[sweep.options]
window = 300
[sweep.set]
e_sched = 2
"tasks.dead_reckoning.bcet" = 1
[grid]
n = [3]
"window.r_H" = [40]
"tasks.command.wcet" = [30]
""",
        )
    )
    assert spec.targets["n"] == ("path", "window", "n")
    assert spec.targets["e_sched"] == ("path", "window", "e_sched")
    pin = point_input(spec, points(spec)[0])
    assert pin.options == {"window": 300}
    ts = pin.taskset()
    assert ts.window is not None
    assert (ts.window.n, ts.window.r_H, ts.window.e_sched) == (3, 40, 2)
    assert ts.task("command").wcet == 30
    assert ts.task("dead_reckoning").bcet == 1
    assert ts.task("dead_reckoning").wcet == 5  # untouched


def test_options_in_the_grid_merge_over_fixed_options(tmp_path: Path) -> None:
    spec = load_sweep(
        write(
            tmp_path,
            f"""
[sweep]
kind = "simulate"
base = "{PAPER}"
[sweep.options]
horizon = 1000
exec = "wcet"
[grid]
exec = ["wcet", "uniform"]
""",
        )
    )
    assert spec.targets["exec"] == ("option", "exec")
    opts = [point_input(spec, p).options for p in points(spec)]
    assert opts == [{"horizon": 1000, "exec": "wcet"}, {"horizon": 1000, "exec": "uniform"}]


def test_fingerprint_ignores_comments_but_not_content(tmp_path: Path) -> None:
    base = tmp_path / "base.toml"
    base.write_text(PAPER.read_text())
    body = '[sweep]\nkind = "bounds"\nbase = "base.toml"\n[grid]\nn = {n}\n'
    fp = load_sweep(write(tmp_path, body.format(n="[1, 2]"))).fingerprint()
    assert load_sweep(write(tmp_path, "# note\n" + body.format(n="[1,2]"))).fingerprint() == fp
    assert load_sweep(write(tmp_path, body.format(n="[1, 3]"))).fingerprint() != fp
    base.write_text(PAPER.read_text().replace("e_sched = 1 ", "e_sched = 2 "))
    assert load_sweep(write(tmp_path, body.format(n="[1, 2]"))).fingerprint() != fp


OK_HEAD = f'[sweep]\nkind = "bounds"\nbase = "{PAPER}"\n'

BAD = [
    ("unknown-top", OK_HEAD + "[grdi]\nn = [1]\n", r"unknown key 'grdi' \(did you mean 'grid'\?\)"),
    (
        "unknown-sweep-key",
        OK_HEAD + 'combin = "zip"\n[grid]\nn = [1]\n',
        r"sweep: unknown key 'combin' \(did you mean 'combine'\?\)",
    ),
    (
        "unknown-kind",
        '[sweep]\nkind = "boundz"\n[grid]\nn = [1]\n',
        r"sweep.kind: unknown kind 'boundz'.*did you mean 'bounds'",
    ),
    ("no-kind", "[sweep]\n[grid]\nn = [1]\n", r"sweep.kind: missing"),
    ("no-sweep", "[grid]\nn = [1]\n", r"missing \[sweep\]"),
    ("empty-grid", OK_HEAD + "[grid]\n", r"grid: empty grid"),
    ("no-grid", OK_HEAD, r"grid: empty grid"),
    ("empty-list", OK_HEAD + "[grid]\nn = []\n", r"grid.n: empty list"),
    (
        "zip-unequal",
        OK_HEAD + 'combine = "zip"\n[grid]\nn = [1, 2]\nr_H = [1, 2, 3]\n',
        r"equal length \(n=2, r_H=3\)",
    ),
    ("bad-combine", OK_HEAD + 'combine = "cross"\n[grid]\nn = [1]\n', r"sweep.combine"),
    ("bad-range", OK_HEAD + '[grid]\nn = "1..x"\n', r"grid.n: cannot parse"),
    ("bad-range-order", OK_HEAD + '[grid]\nn = "5..1"\n', r"grid.n: range end is below"),
    ("unknown-param", OK_HEAD + "[grid]\nnn = [1]\n", r"grid.nn: unknown parameter.*'n'"),
    (
        "unknown-task",
        OK_HEAD + '[grid]\n"tasks.comand.wcet" = [1]\n',
        r"grid.tasks.comand.wcet: unknown parameter path.*did you mean 'command'",
    ),
    (
        "typo-leaf",
        OK_HEAD + '[grid]\n"window.delta_tt" = [1]\n',
        r"unknown parameter path.*did you mean 'delta_t'",
    ),
    ("path-through-value", OK_HEAD + '[grid]\n"window.n.x" = [1]\n', r"is a value, not a table"),
    (
        "unknown-metric",
        OK_HEAD + 'metrics = ["w_sc"]\n[grid]\nn = [1]\n',
        r"unknown metric 'w_sc'.*did you mean 'w_sch'",
    ),
    (
        "option-for-kind",
        OK_HEAD + "[sweep.options]\nhorizon = 5\n[grid]\nn = [1]\n",
        r"unknown key 'sweep.options.horizon'",
    ),
    (
        "missing-horizon",
        f'[sweep]\nkind = "simulate"\nbase = "{PAPER}"\n[grid]\nn = [1]\n',
        r"sweep.options.horizon: required",
    ),
    ("call-no-function", '[sweep]\nkind = "call"\n[grid]\na = [1]\n', r"sweep.function"),
    (
        "call-not-importable",
        '[sweep]\nkind = "call"\nfunction = "no_such_mod:f"\n[grid]\na = [1]\n',
        r"sweep.function: cannot load",
    ),
    ("negative-seed", OK_HEAD + "seed = -1\n[grid]\nn = [1]\n", r"sweep.seed"),
    ("grid-seed-float", OK_HEAD + "[grid]\nseed = [1.5]\n", r"grid.seed"),
    (
        "missing-base",
        '[sweep]\nkind = "bounds"\nbase = "nope.toml"\n[grid]\nn = [1]\n',
        r"sweep.base: cannot read",
    ),
    (
        "scenario-needs-base",
        '[sweep]\nkind = "scenario"\n[grid]\nmode = ["adjust"]\n',
        r"sweep.base: required",
    ),
    ("set-and-grid", OK_HEAD + "[sweep.set]\nn = 2\n[grid]\nn = [1]\n", r"also given in sweep.set"),
    ("malformed", "[sweep\nkind=", r"malformed TOML"),
]


@pytest.mark.parametrize(("body", "match"), [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_sweep_files(tmp_path: Path, body: str, match: str) -> None:
    path = write(tmp_path, body)
    with pytest.raises(SweepError, match=match):
        load_sweep(path)


@pytest.mark.parametrize(
    ("body", "match"), [BAD[1][1:], BAD[12][1:], BAD[8][1:]], ids=["key", "param", "zip"]
)
def test_bad_sweep_file_on_the_cli(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], body: str, match: str
) -> None:
    import re

    path = write(tmp_path, body)
    assert main(["sweep", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"rtsim: {path}: ")
    assert re.search(match, err)
    assert not (tmp_path / "out").exists()


def test_helpers_on_path() -> None:
    assert str(HERE) in sys.path


def test_packaged_base_by_name(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """`base = "test2"` (or "barrel_robots") names a file shipped with rtsim."""
    from pathlib import Path

    from rtsim.sweep import load_sweep

    root = Path(__file__).resolve().parents[2]
    f = tmp_path / "s.toml"
    f.write_text('[sweep]\nkind = "scenario"\nbase = "test2"\n[grid]\n"leader.speed" = [20]\n')
    spec = load_sweep(f)
    assert spec.base.text == (root / "experiments" / "scenarios" / "test2.toml").read_text()
    assert spec.base.source == "test2.toml (packaged)"
    f.write_text('[sweep]\nkind = "bounds"\nbase = "barrel_robots"\n[grid]\nn = [1]\n')
    assert load_sweep(f).base.text == (root / "tasksets" / "barrel_robots.toml").read_text()


@pytest.mark.parametrize(
    "kind, table, match",
    [
        (
            "simulate",
            "[sweep.options]\nhorizon = -5",
            r"sweep\.options\.horizon: must be a positive",
        ),
        (
            "simulate",
            '[sweep.options]\nhorizon = 100\nexec = "fast"',
            r"sweep\.options\.exec: must be 'wcet' or 'uniform', got 'fast'",
        ),
        (
            "scenario",
            '[sweep.options]\nmode = "bogus"',
            r"sweep\.options\.mode: must be one of "
            r"adjust, .*lookahead.* or 'package\.module:Name', got 'bogus'",
        ),
    ],
)
def test_bad_option_values_are_bad_sweep_files(kind, table, match, tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    from rtsim.cli import main

    base = '"test2"' if kind == "scenario" else '"barrel_robots"'
    grid = '"leader.speed" = [20]' if kind == "scenario" else "n = [1]"
    f = tmp_path / "s.toml"
    f.write_text(f'[sweep]\nkind = "{kind}"\nbase = {base}\n{table}\n[grid]\n{grid}\n')
    assert main(["sweep", str(f), "--out", str(tmp_path / "o"), "--workers", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    import re

    assert re.search(match, err[0]), err
    assert not (tmp_path / "o").exists()
