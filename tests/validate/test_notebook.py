"""Notebook-facing API: short reprs, HTML reprs, summary frames, dotted overrides."""

from __future__ import annotations

import pytest

from rtsim.config.scenario import load_scenario
from rtsim.config.taskset import load_taskset
from rtsim.coupling import run_scenario
from rtsim.errors import InputError
from rtsim.sim import simulate


def test_load_scenario_overrides_use_the_sweep_paths() -> None:
    base = load_scenario("test2")
    s = load_scenario("test2", overrides={"leader.speed": 20, "formation.followers": 4})
    assert base.world.leader_speed == 30 and base.n == 2
    assert s.world.leader_speed == 20 and s.n == 4


@pytest.mark.parametrize(
    ("overrides", "match"),
    [
        (
            {"leader.sped": 3},
            r"test2\.toml: overrides\.leader\.sped: unknown parameter path .*"
            r"did you mean 'speed'",
        ),
        ({"formation.followers": 0}, r"test2\.toml: formation\.followers: must be an integer"),
        ({"leader.speed": -1}, r"test2\.toml: leader\.speed: must be positive"),
        ({"mode": "adjust"}, r"overrides\.mode: a run option"),
    ],
)
def test_bad_overrides_are_one_line_input_errors(overrides: dict, match: str) -> None:
    with pytest.raises(InputError, match=match) as info:
        load_scenario("test2", overrides=overrides)
    assert "\n" not in str(info.value)


def test_an_override_typo_is_an_override_error_not_a_sweep_error() -> None:
    from rtsim.errors import OverrideError, SweepError

    for bad in ({"leader.sped": 3}, {"mode": "adjust"}, {"formation.folowers": 4}):
        with pytest.raises(OverrideError) as info:
            load_scenario("test2", overrides=bad)
        assert not isinstance(info.value, SweepError), bad
    import rtsim

    assert rtsim.OverrideError is OverrideError and issubclass(OverrideError, InputError)


def test_run_scenario_with_overrides_equals_the_edited_file(tmp_path) -> None:
    from importlib import resources

    text = (resources.files("rtsim") / "data" / "scenarios" / "test2.toml").read_text("utf-8")
    assert "\nspeed = 30" in text
    edited = tmp_path / "test2.toml"
    edited.write_text(text.replace("\nspeed = 30", "\nspeed = 20", 1), "utf-8")
    a = run_scenario("test2", duration_s=4, overrides={"leader.speed": 20})
    b = run_scenario(edited, duration_s=4)
    assert a.summary["v_leader_desired"] == 20
    assert a.windows.equals(b.windows)
    with pytest.raises(InputError, match="overrides need a scenario file"):
        run_scenario(load_scenario("test2"), overrides={"leader.speed": 20})


def test_scenario_result_repr_is_short_and_html_has_the_summary() -> None:
    r = run_scenario("test1", duration_s=3, record_jobs=False)
    text = repr(r)
    assert text.startswith("<ScenarioResult scenario=test1, mode=plan") and len(text) < 300
    df = r.summary_frame()
    assert len(df) == 1 and df.loc[0, "windows"] == r.summary["windows"]
    assert df.loc[0, "violations.separation"] == r.summary["violations"]["separation"]
    html = r._repr_html_()
    assert "<table" in html and "violations.separation" in html and len(html) < 20_000


def test_sim_result_repr_and_summary_frame() -> None:
    res = simulate(load_taskset(), 3000)
    assert repr(res).startswith("<SimResult tasks=3, horizon=3000")
    assert f"misses={res.misses}" in repr(res)
    assert list(res.summary_frame()["name"]) == list(res.tasks)
    assert "<table" in res._repr_html_()


def test_sweep_outcome_repr(tmp_path) -> None:
    from rtsim.sweep import Sweep
    from rtsim.sweep.spec import parse_sweep

    spec = parse_sweep({"sweep": {"kind": "bounds"}, "grid": {"n": "1..3"}}, "t.toml")
    out = Sweep(spec, tmp_path / "s").run(workers=1, progress=False)
    assert repr(out).startswith("<SweepOutcome points=3, computed=3, skipped=0, failed=0")
    assert "w_sch" in out._repr_html_()


def test_figure_formatter_is_registered_in_an_ipython_shell() -> None:
    IPython = pytest.importorskip("IPython")  # noqa: N806 - the module's name
    from IPython.core.interactiveshell import InteractiveShell
    from matplotlib.figure import Figure

    from rtsim.notebook import enable_figure_display

    shell = InteractiveShell.instance()
    try:
        assert IPython.get_ipython() is shell
        assert enable_figure_display()
        fig = Figure(figsize=(2, 2))
        fig.add_subplot().plot([0, 1], [0, 1])
        data, _ = shell.display_formatter.format(fig)
        assert data["image/png"][:8] == b"\x89PNG\r\n\x1a\n"
    finally:
        InteractiveShell.clear_instance()


def test_validation_outcome_repr(tmp_path) -> None:
    import pandas as pd

    from rtsim.analysis.validation import Failure
    from rtsim.validate import ValidationOutcome

    fail = Failure(
        config="n=6",
        task="window",
        mode="counted-idle",
        check="response",
        value=307.3,
        bound=305.5,
        severity="warning",
    )
    out = ValidationOutcome(
        pd.DataFrame({"n": [1, 2]}),
        [fail],
        {"rows": 2, "paper/wcet-cpu": {"w_sch_over_w_sim": {"min": 1.001}}},
        [],
        tmp_path,
    )
    assert repr(out) == (
        f"<ValidationOutcome ok=True, rows=2, failures=0, warnings=1, "
        f"point_errors=0, out_dir={tmp_path}>"
    )
    assert list(out.summary_frame().columns) == ["rows", "paper/wcet-cpu.w_sch_over_w_sim.min"]
    assert "<code>ValidationOutcome</code>" in out._repr_html_()
