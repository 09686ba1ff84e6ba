"""The one registry of plug-ins (rtsim.registry): names, installed entry points and
``package.module:Name``, and the rule for code: a name written in an input file loads code only
when the user opts in (``--allow-code``, ``allow_code=True``); one given on the command line or
passed in the API is that opt-in."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from rtsim.errors import InputError, ScenarioError, TaskSetError
from rtsim.registry import Registry, did_you_mean, load_code, opted_in, reading_input

RTSIM = Path(sys.executable).with_name("rtsim")  # the console script: no cwd on sys.path

#: A module that leaves a marker file when it is imported.
EVIL = (
    "from pathlib import Path\n"
    "Path(__file__).with_name('MARKER').write_text('imported')\n"
    "from rtsim.sim.policy import FixedPriority\n"
    "class P(FixedPriority):\n    name = 'evil-fp'\n"
    "def f(params, options, seed):\n    return {'x': 1.0}\n"
)

SET = (
    '[[tasks]]\nname = "a"\nwcet = 1\nperiod = 5\npriority = 1\n'
    '[[tasks]]\nname = "b"\nwcet = 2\nperiod = 10\npriority = 2\n'
)


def _run(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return subprocess.run(
        [str(RTSIM), *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        check=False,
    )


@pytest.fixture
def evil_dir(tmp_path: Path) -> Iterator[Path]:
    (tmp_path / "evil.py").write_text(EVIL)
    (tmp_path / "set.toml").write_text('[scheduler]\npolicy = "evil:P"\n' + SET)
    yield tmp_path
    sys.modules.pop("evil", None)


def test_registry_names_did_you_mean_and_mapping() -> None:
    reg: Registry[int] = Registry("number", "rtsim.test_numbers")
    reg.register("one", 1)
    reg["two"] = 2
    assert reg.resolve("one", "n") == 1 and list(reg) == ["one", "two"] and len(reg) == 2
    with pytest.raises(
        InputError,
        match=r"^n: must be one of one, two or 'package\.module:Name',"
        r" got 'on' \(did you mean 'one'\?\)$",
    ):
        reg.resolve("on", "n")
    del reg["two"]
    assert "two" not in reg and reg.contains("one") and not reg.contains(3)
    assert did_you_mean("margn", ("margin", "z")) == " (did you mean 'margin'?)"
    assert did_you_mean("qqq", ("margin",)) == ""
    with pytest.raises(TypeError):
        reg.register("a:b", 3)


@pytest.mark.parametrize("spec", [":", ".x:Y", "x:", ":Y", "a b:C", "x:Y:Z", "x.:Y"])
def test_malformed_code_names_are_one_line_errors(spec: str) -> None:
    with pytest.raises(InputError, match=r"is not 'package\.module:Name'$"):
        load_code(spec, "--scheduler")


def test_an_installed_entry_point_resolves_without_opt_in(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A distribution on sys.path with an ``rtsim.schedulers`` entry point: a file may name it
    (installed plug-ins are trusted, as pytest's and Sphinx's are)."""
    (tmp_path / "plug_sched.py").write_text(
        "from rtsim.sim.policy import FixedPriority\n"
        "class Plugged(FixedPriority):\n    name = 'plugged'\n"
    )
    info = tmp_path / "plug_sched-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: plug-sched\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[rtsim.schedulers]\nplugged = plug_sched:Plugged\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    from rtsim.config.taskset import load_taskset
    from rtsim.sim import simulate
    from rtsim.sim.policy import SCHEDULERS

    try:
        f = tmp_path / "s.toml"
        f.write_text('[scheduler]\npolicy = "plugged"\n' + SET)
        ts = load_taskset(f)  # no allow_code: an entry point is not code named in a file
        assert ts.scheduler == "plugged" and "plugged" in SCHEDULERS.known()
        assert simulate(ts, 20).scheduler == "plugged"
        assert SCHEDULERS["plugged"].__name__ == "Plugged"
    finally:
        SCHEDULERS.pop("plugged", None)
        sys.modules.pop("plug_sched", None)


def test_api_file_names_code_only_with_allow_code(
    evil_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from rtsim.config.taskset import load_taskset

    monkeypatch.chdir(evil_dir)  # allowed code is imported from the current directory
    monkeypatch.setattr(sys, "path", list(sys.path))

    with pytest.raises(
        TaskSetError,
        match=r"set\.toml: \[scheduler\]: policy: 'evil:P' names "
        r"Python code, .*allow_code=True",
    ):
        load_taskset(evil_dir / "set.toml")
    assert not (evil_dir / "MARKER").exists()
    with opted_in(False), reading_input():
        with pytest.raises(InputError):
            load_code("evil:P", "x")
    assert not (evil_dir / "MARKER").exists()
    assert load_taskset(evil_dir / "set.toml", allow_code=True).scheduler == "evil:P"
    assert (evil_dir / "MARKER").exists()


def test_a_scenario_file_names_code_only_with_allow_code(tmp_path: Path) -> None:
    from rtsim.config.scenario import load_scenario, scenario_bytes

    text = scenario_bytes("test2")[0].decode()
    (tmp_path / "evil.py").write_text(EVIL)
    f = tmp_path / "s.toml"
    text = re.sub(r'(?m)^policy = "[^"]*"', "", text)  # the shipped [adjust] policy, if any
    f.write_text(text.replace("[adjust]", '[adjust]\npolicy = "evil:P"', 1))
    assert "evil:P" in f.read_text()
    try:
        with pytest.raises(ScenarioError, match=r"adjust\.policy: 'evil:P' names Python code"):
            load_scenario(f)
        assert not (tmp_path / "MARKER").exists()
    finally:
        sys.modules.pop("evil", None)


@pytest.mark.parametrize(
    "command",
    [
        ["analyze", "set.toml"],
        ["simulate", "set.toml", "--horizon", "20"],
        ["sweep", "sweep.toml", "--out", "o"],
    ],
)
def test_cli_refuses_code_named_in_a_file_without_importing_it(
    evil_dir: Path, command: list[str]
) -> None:
    (evil_dir / "sweep.toml").write_text(
        '[sweep]\nkind = "call"\nfunction = "evil:f"\n[grid]\na = [1]\n'
    )
    r = _run(*command, cwd=evil_dir)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "names Python code" in lines[0] and "--allow-code" in lines[0]
    assert not (evil_dir / "MARKER").exists()  # the module was never imported
    assert not (evil_dir / "o").exists()
    ok = _run(*command, "--allow-code", cwd=evil_dir)
    assert "names Python code" not in ok.stderr
    assert ok.returncode == (2 if command[0] == "analyze" else 0), ok.stderr
    if command[0] == "analyze":  # loaded, but a policy of one's own has no analysis
        assert "'evil:P' has no analysis" in ok.stderr
    assert (evil_dir / "MARKER").exists()


def test_cli_module_name_on_the_command_line_is_the_opt_in(tmp_path: Path) -> None:
    """``--policy mymod:MyPolicy`` from the directory holding mymod.py (console script, whose
    sys.path does not hold the current directory by itself)."""
    (tmp_path / "mymod.py").write_text(
        "from rtsim.control.policy import FixedWschPolicy\n"
        "class MyPolicy:\n"
        "    def decide(self, ctx):\n"
        "        return FixedWschPolicy().decide(ctx)._replace(method='mine')\n"
    )
    r = _run(
        "scenario",
        "test2",
        "--duration",
        "2",
        "--policy",
        "mymod:MyPolicy",
        "--no-figures",
        "--out",
        "run",
        cwd=tmp_path,
    )
    assert r.returncode == 0, r.stderr
    import json

    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["policy"] == "mymod:MyPolicy" and "mine" in summary["methods"]
    r = _run("simulate", "set.toml", "--horizon", "20", "--scheduler", "mymod:Nope", cwd=tmp_path)
    assert r.returncode == 2


@pytest.mark.parametrize(
    ("option", "spec"),
    [("--scheduler", ":"), ("--scheduler", ".x:Y"), ("--policy", ":"), ("--policy", ".x:Y")],
)
def test_cli_malformed_names_are_one_line_errors(tmp_path: Path, option: str, spec: str) -> None:
    (tmp_path / "set.toml").write_text(SET)
    cmd = (
        ["simulate", "set.toml", "--horizon", "20"]
        if option == "--scheduler"
        else ["scenario", "test2", "--duration", "1", "--out", "o"]
    )
    r = _run(*cmd, option, spec, cwd=tmp_path)
    assert r.returncode == 2
    assert r.stderr.strip().splitlines() == [
        f"rtsim: {option}: {spec!r} is not 'package.module:Name'"
    ]
