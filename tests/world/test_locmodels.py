"""Localization models as plug-ins (rtsim.world.locmodels): the registry, a new model's
measurement reaching World.scan and its σ_fix reaching the predicted-centre bound."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtsim.analysis.kinematics import msb_localization_predicted
from rtsim.config.scenario import load_scenario
from rtsim.errors import ScenarioError
from rtsim.world import SensingParams, World, WorldConfig
from rtsim.world import rounded_rectangle as rr
from rtsim.world.config import LocalizationParams
from rtsim.world.formation import in_line
from rtsim.world.locmodels import LOCALIZATION_MODELS, GaussianModel, localization_model


class Doubled(GaussianModel):
    """Twice the configured noise, at every range."""

    name = "doubled"

    @classmethod
    def fix_sd(cls, sensing: SensingParams, rho: float) -> float:
        return 2.0 * sensing.position_noise


class Ranged(GaussianModel):
    name = "ranged-test"

    @classmethod
    def fix_sd(cls, sensing: SensingParams, rho: float) -> float:
        return sensing.position_noise * (1.0 + rho / 1000.0)


@pytest.fixture
def registered():
    LOCALIZATION_MODELS.register("doubled", Doubled)
    LOCALIZATION_MODELS.register("ranged-test", Ranged)
    yield
    del LOCALIZATION_MODELS["doubled"]
    del LOCALIZATION_MODELS["ranged-test"]


def test_the_built_ins_are_registered() -> None:
    assert list(LOCALIZATION_MODELS)[:2] == ["gaussian", "hough"]
    assert LOCALIZATION_MODELS.group == "rtsim.localization_models"


def test_an_unknown_model_is_one_line_with_a_suggestion() -> None:
    with pytest.raises(ScenarioError, match="did you mean 'hough'"):
        load_scenario("test1", {"localization.model": "houg"})
    with pytest.raises(ScenarioError, match="localization.model"):
        localization_model("nope")


def test_code_that_is_not_a_model_is_refused() -> None:
    with pytest.raises(ScenarioError, match="not a LocalizationModel"):
        localization_model("math:pi")


def _errors(model: str) -> list[tuple[float, float]]:
    cfg = WorldConfig(
        rr(800, 400, 120.0),
        30.0,
        in_line(3, 100.0, math.radians(15), r_F=15.0),
        sensing=SensingParams(position_noise=1.5),
        localization=LocalizationParams(model=model),
    )
    w = World(cfg, np.random.default_rng(7))
    out = []
    for t in (0.0, 200.0, 400.0):
        s = w.scan(t)
        out += [(m[0] - x[0], m[1] - x[1]) for m, x in zip(s.measured, s.truth, strict=True)]
    return out


def test_a_new_models_noise_reaches_the_scan(registered: None) -> None:
    # the same seed draws the same normals; only the model's σ scales them
    base, doubled = _errors("gaussian"), _errors("doubled")
    assert len(base) == 9
    for (bx, by), (dx, dy) in zip(base, doubled, strict=True):
        assert dx == pytest.approx(2.0 * bx, abs=1e-9)
        assert dy == pytest.approx(2.0 * by, abs=1e-9)


def test_a_new_models_sigma_reaches_the_predicted_bound(registered: None) -> None:
    predicted = {"localization.centre": "predicted", "thresholds.localization": "predicted"}
    sc = load_scenario("test1", {**predicted, "localization.model": "ranged-test"})
    w = sc.world
    rho = max(w.formation.rho_d)
    sigma = w.sensing.position_noise * (1.0 + rho / 1000.0)  # by hand: 1.39 cm at 390 cm
    assert sigma > w.sensing.position_noise
    want = msb_localization_predicted(
        w.thresholds.r_H,
        fix_sd=sigma,
        heading_sd=w.ekf.init_heading_sd,
        speed_sd=w.follower.speed_noise,
        turn_sd=w.follower.turn_noise,
        v_max=w.follower.max_speed,
    )
    assert w.thresholds.predicted_ms == pytest.approx(want, rel=1e-12)
    base = load_scenario("test1", {**predicted, "localization.model": "gaussian"})
    assert w.thresholds.predicted_ms < base.world.thresholds.predicted_ms
