"""The curated public API: every package's ``__all__`` resolves, and the top level is pinned."""

from __future__ import annotations

import importlib

import pytest

PACKAGES = [
    "rtsim",
    "rtsim.model",
    "rtsim.analysis",
    "rtsim.sim",
    "rtsim.world",
    "rtsim.control",
    "rtsim.coupling",
    "rtsim.sweep",
    "rtsim.plots",
    "rtsim.validate",
    "rtsim.io",
    "rtsim.notebook",
    "rtsim.overrides",
    "rtsim.export",
    "rtsim.examples",
    "rtsim.report",
    "rtsim.animate",
]


@pytest.mark.parametrize("name", PACKAGES)
def test_all_names_resolve(name: str) -> None:
    mod = importlib.import_module(name)
    assert mod.__all__, name
    assert len(set(mod.__all__)) == len(mod.__all__), "duplicate names in __all__"
    for attr in mod.__all__:
        assert getattr(mod, attr) is not None, f"{name}.{attr}"


def test_top_level_namespace_is_pinned() -> None:
    import rtsim

    assert sorted(rtsim.__all__) == sorted(
        [
            "__version__",
            "InputError",
            "OverrideError",
            "RtsimError",
            "ScenarioError",
            "SweepError",
            "TaskSetError",
            "Segment",
            "Task",
            "TaskSet",
            "WindowSpec",
            "analyze",
            "load_scenario",
            "load_taskset",
            "run_scenario",
            "run_sweep",
            "simulate",
            "window_bounds",
        ]
    )


def test_run_sweep_is_not_shadowed_by_the_sweep_package() -> None:
    """``rtsim.run_sweep`` (a grid in one call, a DataFrame) stays the facade's after
    ``import rtsim.sweep`` (issue 34), beside the file-driven ``rtsim.sweep.run_sweep``."""
    import rtsim
    import rtsim.sweep
    from rtsim._facade import run_sweep

    assert rtsim.run_sweep is run_sweep and rtsim.sweep.run_sweep is not run_sweep
    assert "grid" in run_sweep.__doc__ and "point_seed" in run_sweep.__doc__


def test_top_level_entry_points_are_the_subpackages_and_load_lazily() -> None:
    """``rtsim.run_scenario`` and friends are the subpackages' own functions, and importing
    rtsim alone loads neither SimPy nor the coupling."""
    import subprocess
    import sys

    import rtsim
    from rtsim.analysis import analyze
    from rtsim.config.scenario import load_scenario
    from rtsim.coupling import run_scenario
    from rtsim.sim import simulate

    assert rtsim.run_scenario is run_scenario and rtsim.load_scenario is load_scenario
    # these two also read a task-set file, above the simulator and the analysis
    assert rtsim.simulate.__wrapped__ is simulate and rtsim.analyze.__wrapped__ is analyze
    assert "run_scenario" in dir(rtsim)
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        rtsim.nope  # noqa: B018
    code = "import sys, rtsim; print('simpy' in sys.modules, 'rtsim.coupling' in sys.modules)"
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.strip()
    assert out == "False False"


def test_subpackage_entry_points_are_exported() -> None:
    """The functions the README's library example uses."""
    from rtsim.analysis import analyze, window_bounds
    from rtsim.config.scenario import load_scenario
    from rtsim.config.taskset import load_taskset
    from rtsim.coupling import run_scenario
    from rtsim.sim import simulate
    from rtsim.sweep import run_sweep
    from rtsim.validate import run_validation

    for fn in (
        analyze,
        window_bounds,
        run_scenario,
        load_scenario,
        load_taskset,
        simulate,
        run_sweep,
        run_validation,
    ):
        assert callable(fn)


def test_analysis_and_world_do_not_import_simpy() -> None:
    """Analysis, world and control stay pure: importing them never loads SimPy."""
    import subprocess
    import sys

    code = "import sys, rtsim.analysis, rtsim.world, rtsim.control; print('simpy' in sys.modules)"
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.strip()
    assert out == "False"


def test_cli_commands_are_all_registered() -> None:
    from rtsim.cli import COMMANDS, build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    assert sorted(sub.choices) == sorted(COMMANDS)
