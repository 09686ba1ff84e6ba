"""Pure analysis (no SimPy): the paper's window bounds, exact response times, utilization tests.

Times in ms, lengths in cm. Each function cites the equation or theorem it implements.
"""

from rtsim.analysis.bounds import WindowBounds, w_eq7_of, w_eq11_of, w_rta, w_sch_of, window_bounds
from rtsim.analysis.rta import Analysis, TaskResult, analyze, response_time
from rtsim.analysis.utilization import (
    hyperbolic,
    hyperbolic_product,
    liu_layland,
    liu_layland_bound,
    rm_implicit,
    total_utilization,
)
from rtsim.analysis.window import (
    LASER_POINTS,
    e_hough,
    g_window,
    hp_utilization,
    w_eq7,
    w_eq11,
    w_sch,
)

# --- kinematics / MSBs (SPEC §4): imports added here by the owner of rtsim/analysis/kinematics.py

__all__ = [
    # window bounds (Eqs 1, 5-7, 10-11) and w_rta
    "LASER_POINTS",
    "WindowBounds",
    "e_hough",
    "g_window",
    "hp_utilization",
    "w_eq7",
    "w_eq7_of",
    "w_eq11",
    "w_eq11_of",
    "w_rta",
    "w_sch",
    "w_sch_of",
    "window_bounds",
    # exact response-time analysis
    "Analysis",
    "TaskResult",
    "analyze",
    "response_time",
    # utilization tests
    "hyperbolic",
    "hyperbolic_product",
    "liu_layland",
    "liu_layland_bound",
    "rm_implicit",
    "total_utilization",
    # --- kinematics / MSBs (SPEC §4): names added here by the owner of kinematics.py
]
