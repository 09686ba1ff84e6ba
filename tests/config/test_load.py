"""The typed configuration layer: every error of a file at once, strict types, the JSON
Schemas (shipped, and checking every file the project ships with a standard validator),
dotted overrides, ``--set`` and the did-you-mean."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import jsonschema
import pytest

from rtsim._suggest import close_match
from rtsim.cli import main
from rtsim.config.scenario import load_scenario
from rtsim.config.schema import KINDS, json_schema, schema_text, shipped_schema
from rtsim.config.taskset import load_taskset
from rtsim.errors import InputError, ScenarioError, TaskSetError

ROOT = Path(__file__).resolve().parents[2]

FILES = {
    "taskset": sorted(
        [*(ROOT / "rtsim" / "data").glob("*.toml"), *(ROOT / "tasksets").glob("*.toml")]
    ),
    "scenario": sorted(
        [
            *(ROOT / "rtsim" / "data" / "scenarios").glob("*.toml"),
            *(ROOT / "experiments" / "scenarios").glob("*.toml"),
        ]
    ),
    "sweep": sorted(
        [
            *(ROOT / "rtsim" / "data" / "sweeps").glob("*.toml"),
            *(ROOT / "experiments" / "sweeps").glob("*.toml"),
        ]
    ),
}


# -- every error at once ---------------------------------------------------------------
def test_a_task_set_with_three_mistakes_reports_all_three(tmp_path: Path) -> None:
    p = tmp_path / "three.toml"
    p.write_text(
        '[[tasks]]\nname = "a"\nwcet = -1\nperiod = 40\nprio = 1\n'
        '[[tasks]]\nname = "b"\nwcet = 2\nperiod = "forty"\n'
    )
    with pytest.raises(TaskSetError) as info:
        load_taskset(p)
    lines = str(info.value).split("\n")
    assert lines == [
        f"{p}: task 'a': wcet: must be positive, got -1",
        f"{p}: task 'a': unknown key 'prio' (did you mean 'priority'?)",
        f"{p}: task 'b': period: must be a number (ms) or a multiple of the window such as "
        "\"2w\", got 'forty'",
    ]
    assert info.value.lines == tuple(lines)  # type: ignore[attr-defined]


def test_the_cli_prints_every_error_one_line_each_and_exits_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    p = tmp_path / "three.toml"
    p.write_text(
        '[[tasks]]\nname = "a"\nwcet = -1\nperiod = 40\nprio = 1\n'
        '[[tasks]]\nname = "b"\nwcet = 2\nperiod = "forty"\n'
    )
    assert main(["analyze", str(p)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 3 and all(line.startswith(f"rtsim: {p}: task '") for line in err), err


def test_a_sweep_file_with_three_mistakes_reports_all_three(tmp_path: Path) -> None:
    from rtsim.errors import SweepError
    from rtsim.sweep import load_sweep

    p = tmp_path / "three.toml"
    p.write_text('[sweep]\nkind = "bounds"\nseed = -1\ncombin = "zip"\n[grid]\nn = "1..x"\n')
    with pytest.raises(SweepError) as info:
        load_sweep(p)
    assert str(info.value).split("\n") == [
        f"{p}: sweep.seed: must be an integer >= 0, got -1",
        f"{p}: sweep: unknown key 'combin' (did you mean 'combine'?)",
        f"{p}: grid.n: cannot parse range '1..x' (expected a..b or a..b:step) (use a TOML "
        "list for text values)",
    ]


def test_a_scenario_with_several_mistakes_reports_them_all(tmp_path: Path) -> None:
    text = (ROOT / "experiments" / "scenarios" / "test2.toml").read_text()
    text = text.replace("speed = 30", "speed = -30").replace("followers = 2", 'followers = "four"')
    assert "step_ms = 10" in text
    text = text.replace("step_ms = 10", "step_mss = 10")
    p = tmp_path / "s.toml"
    p.write_text(text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(p)
    lines = str(info.value).split("\n")
    assert f"{p}: leader.speed: must be positive, got -30" in lines
    assert f"{p}: formation.followers: must be an integer, got 'four'" in lines
    assert f"{p}: world: unknown key 'step_mss' (did you mean 'step_ms'?)" in lines
    assert len(lines) == 3


@pytest.mark.parametrize(
    ("text", "line"),
    [
        ("wcet = 1.0\nperiod = 40\npriority = 1.0\n", "priority: must be an integer, got 1.0"),
        ('wcet = "5"\nperiod = 40\n', "wcet: must be a number, got '5'"),
        ("wcet = true\nperiod = 40\n", "wcet: must be a number, got True"),
        (
            "wcet = 1\nperiod = 40\noverload = 3\n",
            "overload: must be one of finish-late, abort, skip, got 3",
        ),
    ],
)
def test_no_coercion(tmp_path: Path, text: str, line: str) -> None:
    p = tmp_path / "t.toml"
    p.write_text('[[tasks]]\nname = "a"\n' + text)
    with pytest.raises(
        TaskSetError,
        match="^" + str(p) + ": task 'a': " + line.replace("(", r"\(").replace(")", r"\)") + "$",
    ):
        load_taskset(p)


def test_values_keep_their_toml_types() -> None:
    """An int in the file reaches the runtime objects as the loaders always gave it."""
    s = load_scenario("test2")
    assert s.world.formation.rho_d == (325, 325) and s.n == 2
    assert s.load_taskset() is s.load_taskset()  # built once, with the scenario
    assert s.load_taskset().window.n == s.n


# -- did-you-mean ------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("word", "choices", "expected"),
    [
        ("prio", ["name", "wcet", "period", "deadline", "priority"], "priority"),
        ("prio", ["name", "wcet", "period", "deadline"], None),  # never 'period'
        ("perod", ["name", "wcet", "period"], "period"),
        ("nmae", ["name", "tasks"], "name"),
        ("grdi", ["sweep", "grid"], "grid"),
        ("accel", ["speed", "accel_max", "decel_max"], "accel_max"),
        ("xyz", ["speed", "start"], None),
    ],
)
def test_did_you_mean(word: str, choices: list[str], expected: str | None) -> None:
    assert close_match(word, choices) == expected


def test_did_you_mean_is_guessed_in_one_place() -> None:
    """Only rtsim/_suggest.py guesses a name (difflib); the registry, the models, the sweep
    file, the adjustment policies' keys and the command line all ask it."""
    guessers = sorted(
        str(p.relative_to(ROOT))
        for p in (ROOT / "rtsim").rglob("*.py")
        if "difflib" in p.read_text("utf-8")
    )
    assert guessers == ["rtsim/_suggest.py"]


def test_registry_names_and_renamed_names_use_the_same_guess() -> None:
    from rtsim.control.predict import PREDICTORS
    from rtsim.world.formation import FOLLOWER_MODELS

    with pytest.raises(
        InputError,
        match=r"got 'follow-the-lead' \(did you mean "
        r"'follow-the-leader'\?\)$",
    ):
        FOLLOWER_MODELS.resolve("follow-the-lead", "formation.model")
    with pytest.raises(InputError, match=r"'estimate' was renamed; did you mean 'paper'\?"):
        PREDICTORS.resolve("estimate", "adjust.predictor")


# -- JSON Schemas -----------------------------------------------------------------------
def _without_defaults(node: object) -> object:
    """A schema without ``"additionalProperties": true``, JSON Schema's default (pydantic 2.6
    writes it for an open mapping, later releases leave it out): the same schema either way."""
    if isinstance(node, dict):
        return {
            k: _without_defaults(v)
            for k, v in node.items()
            if not (k == "additionalProperties" and v is True)
        }
    if isinstance(node, list):
        return [_without_defaults(v) for v in node]
    return node


@pytest.mark.parametrize("kind", KINDS)
def test_shipped_schemas_equal_the_generated_ones(kind: str) -> None:
    shipped, made = json.loads(shipped_schema(kind)), json.loads(schema_text(kind))
    assert _without_defaults(shipped) == _without_defaults(made), (
        "run: python -m rtsim.config.schema"
    )
    jsonschema.Draft202012Validator.check_schema(json_schema(kind))


def test_rtsim_schema_prints_it(capsys: pytest.CaptureFixture[str]) -> None:
    for kind in KINDS:
        assert main(["schema", kind]) == 0
        assert json.loads(capsys.readouterr().out) == json_schema(kind)


@pytest.mark.parametrize(
    ("kind", "path"),
    [(k, p) for k, ps in FILES.items() for p in ps],
    ids=lambda v: v if isinstance(v, str) else v.name,
)
def test_every_shipped_file_is_valid_under_its_schema(kind: str, path: Path) -> None:
    data = tomllib.loads(path.read_text("utf-8"))
    jsonschema.validate(data, json_schema(kind), cls=jsonschema.Draft202012Validator)


def test_every_kind_has_files() -> None:
    assert all(len(v) >= 2 for v in FILES.values()), FILES


@pytest.mark.parametrize(
    ("edit", "value"),
    [
        (("formation", "followers"), "four"),  # no coercion: a string is not an integer
        # (2.0: JSON Schema counts it as an integer; the loader does not, test_no_coercion)
        (("formation", "followers"), 0),  # out of range
        (("leader", "speed"), "30"),
        (("leader", "speed"), 5000),
        (("leader", "sped"), 30),  # unknown key
    ],
)
def test_the_schema_refuses_what_the_loader_refuses(edit: tuple[str, str], value: object) -> None:
    data = tomllib.loads((ROOT / "experiments" / "scenarios" / "test2.toml").read_text())
    data[edit[0]][edit[1]] = value
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(data, json_schema("scenario"), cls=jsonschema.Draft202012Validator)
    with pytest.raises(ScenarioError):
        from rtsim.config.scenario import parse_scenario

        parse_scenario(data, "test2.toml", ROOT / "experiments" / "scenarios")


# -- overrides ---------------------------------------------------------------------------
def test_overrides_are_errors_named_for_what_the_user_did() -> None:
    from rtsim.errors import OverrideError

    with pytest.raises(
        OverrideError,
        match=r"^test2\.toml: overrides\.leader\.sped: unknown "
        r"parameter path .*did you mean 'speed'",
    ):
        load_scenario("test2", overrides={"leader.sped": 3})
    with pytest.raises(
        ScenarioError,
        match=r"^test2\.toml: formation\.followers: must be an "
        r"integer, got 'four'$",
    ):
        load_scenario("test2", overrides={"formation.followers": "four"})
    with pytest.raises(TaskSetError, match=r"\[window\]: n: must be an integer >= 1, got 0$"):
        load_taskset(None, overrides={"n": 0})


def test_parse_assignment() -> None:
    from rtsim.config.dotted import parse_assignment

    assert parse_assignment("formation.followers=4") == ("formation.followers", 4)
    assert parse_assignment("leader.speed = 2.5") == ("leader.speed", 2.5)
    assert parse_assignment("formation.model=follow-the-leader") == (
        "formation.model",
        "follow-the-leader",
    )
    assert parse_assignment('name="a b"') == ("name", "a b")
    assert parse_assignment("r_H=[10, 25]") == ("r_H", [10, 25])
    assert parse_assignment("ekf.backend=fast") == ("ekf.backend", "fast")
    for bad in ("novalue", "=3", "x=[1,"):
        with pytest.raises(InputError, match="--set"):
            parse_assignment(bad)


# -- --set on the command line ------------------------------------------------------------
def test_scenario_set_runs_and_is_recorded_as_given(tmp_path: Path) -> None:
    out = tmp_path / "o"
    assert (
        main(
            [
                "scenario",
                "test2",
                "--set",
                "formation.followers=4",
                "--set",
                "leader.speed=25",
                "--duration",
                "2",
                "--no-figures",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    man = json.loads((out / "manifest.json").read_text())
    assert man["inputs"]["set"] == ["formation.followers=4", "leader.speed=25"]
    scen = man["inputs"]["scenario"]
    assert len(scen["formation"]["rho_d"]) == 4 and scen["leader"]["speed"] == 25
    assert scen["taskset"]["window"]["n"] == 4  # the follower count has one source
    summary = json.loads((out / "summary.json").read_text())
    assert summary["n"] == 4


@pytest.mark.parametrize(
    ("argv", "line"),
    [
        (
            ["scenario", "test2", "--set", "formation.followers=four", "--out", "{out}"],
            "rtsim: test2.toml: formation.followers: must be an integer, got 'four'",
        ),
        (
            ["scenario", "test2", "--set", "leader.sped=3", "--out", "{out}"],
            "rtsim: test2.toml: overrides.leader.sped: unknown parameter path (no key 'sped' in "
            "test2.toml (did you mean 'speed'?))",
        ),
        (
            ["analyze", "barrel_robots.toml", "--set", "window.n=0"],
            "rtsim: {ts}: [window]: n: must be an integer >= 1, got 0",
        ),
        (
            ["simulate", "barrel_robots.toml", "--horizon", "100", "--set", "novalue"],
            "rtsim: --set 'novalue': expected KEY=VALUE (a dotted key such as "
            "formation.followers=4)",
        ),
    ],
)
def test_a_bad_set_exits_2_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], line: str
) -> None:
    ts = str(ROOT / "tasksets" / "barrel_robots.toml")
    argv = [
        ts if a == "barrel_robots.toml" else str(tmp_path / "o") if a == "{out}" else a
        for a in argv
    ]
    assert main(argv) == 2
    assert capsys.readouterr().err == line.replace("{ts}", ts) + "\n"


def test_analyze_and_simulate_set(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    ts = str(ROOT / "tasksets" / "barrel_robots.toml")
    assert main(["analyze", ts, "--json", "--set", "n=3"]) == 0
    with_set = json.loads(capsys.readouterr().out)
    from rtsim.analysis.bounds import window_bounds

    want = window_bounds(load_taskset(ts).with_window(n=3)).w_sch
    assert with_set["w"] == want
    jobs = tmp_path / "jobs.csv"
    assert (
        main(
            [
                "simulate",
                ts,
                "--horizon",
                "500",
                "--set",
                "tasks.command.wcet=20",
                "--jobs",
                str(jobs),
            ]
        )
        == 0
    )
    man = json.loads((tmp_path / "manifest.json").read_text())
    assert man["inputs"]["set"] == ["tasks.command.wcet=20"]
    assert {t["name"]: t["wcet"] for t in man["inputs"]["taskset"]["tasks"]}["command"] == 20


def test_sweep_set_applies_at_every_point(tmp_path: Path) -> None:
    from rtsim.sweep.spec import load_sweep

    spec = load_sweep("smoke", set_=["window.delta_t=50", "tasks.command.bcet=12"])
    fixed = dict(spec.fixed)
    assert fixed["window.delta_t"] == 50 and fixed["tasks.command.bcet"] == 12
    assert spec.resolved()["set_args"] == ["window.delta_t=50", "tasks.command.bcet=12"]
    assert "set_args" not in load_sweep("smoke").resolved()  # old fingerprints unchanged


def test_reproduce_parses_once_and_passes_set_through(monkeypatch: pytest.MonkeyPatch) -> None:
    """``rtsim reproduce`` hands its parsed options to `rtsim.reproduce.run` as typed
    `ReproduceOptions` (one parser, no command line rebuilt from them)."""
    import rtsim.reproduce as rp

    seen = []
    monkeypatch.setattr(rp, "run", lambda args, **kw: seen.append(args) or 0)
    assert main(["reproduce", "--quick", "--out", "o", "--set", "leader.speed=20"]) == 0
    assert all(isinstance(a, rp.ReproduceOptions) for a in seen)
    assert [(a.set, a.quick, a.out, a.seed) for a in seen] == [(("leader.speed=20",), True, "o", 0)]
