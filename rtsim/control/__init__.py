"""Control: the adjustment algorithm of the processing window (paper §3.3,
docs/model/adjustment.md). Pure."""

from rtsim.control.adjust import (
    CAP_FACTOR,
    FLOOR_FRAC,
    FLOOR_W,
    METHODS,
    MODES,
    Adjustment,
    FollowerEstimate,
    Predictor,
    adjust,
    predict_msbs,
    predictor,
)
from rtsim.control.closed_forms import coupled_speed, paper_speed
from rtsim.control.policy import (
    ADJUSTMENT_POLICIES,
    Decision,
    Policy,
    PolicyInput,
    decide,
    register_adjustment_policy,
)
from rtsim.control.predict import min_bound

__all__ = [
    "CAP_FACTOR",
    "FLOOR_FRAC",
    "FLOOR_W",
    "METHODS",
    "MODES",
    "ADJUSTMENT_POLICIES",
    "Adjustment",
    "Decision",
    "FollowerEstimate",
    "Policy",
    "PolicyInput",
    "Predictor",
    "adjust",
    "coupled_speed",
    "decide",
    "min_bound",
    "paper_speed",
    "predict_msbs",
    "predictor",
    "register_adjustment_policy",
]
