"""Pure analysis (no SimPy): the paper's window bounds, exact response times, utilization tests.

Times in ms, lengths in cm. Each function cites the equation or theorem it implements.
"""

from rtsim.analysis.bounds import (
    BOUND_SCHEDULER,
    LOWER_BOUNDS,
    WindowBounds,
    lower_bound,
    w_edf,
    w_eq7_of,
    w_eq11_of,
    w_rta,
    w_sch_of,
    w_susp,
    w_txn,
    window_bounds,
)
from rtsim.analysis.edf import EdfAnalysis, EdfTaskResult, analyze_edf, demand, qpa, spuri_wcrt
from rtsim.analysis.kinematics import (
    BOUND_KINDS,
    LocalizationKind,
    Thresholds,
    beta_dot,
    follower_msbs,
    formation_velocity,
    msb_bearing,
    msb_localization,
    msb_localization_full,
    msb_path_diversion,
    msb_separation,
    relative_state,
    rho_dot,
    slack,
    wrap_angle,
    wrap_positive,
)
from rtsim.analysis.rta import Analysis, TaskResult, analyze, busy_window, response_time
from rtsim.analysis.suspension import SuspensionBound, suspension_aware
from rtsim.analysis.transaction import analyze_transactions, transaction_bounds
from rtsim.analysis.unified import unified_bound
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
    k_geometric,
    w_eq7,
    w_eq11,
    w_sch,
)

__all__ = [
    # window bounds (Eqs 1, 5-7, 10-11) and w_rta
    "LASER_POINTS",
    "WindowBounds",
    "e_hough",
    "g_window",
    "hp_utilization",
    "k_geometric",
    "LOWER_BOUNDS",
    "lower_bound",
    "w_eq7",
    "w_eq7_of",
    "w_eq11",
    "w_eq11_of",
    "w_rta",
    "w_sch",
    "w_sch_of",
    "w_susp",
    "w_edf",
    "BOUND_SCHEDULER",
    "window_bounds",
    # exact response-time analysis
    "Analysis",
    "TaskResult",
    "analyze",
    "busy_window",
    "response_time",
    # EDF: processor-demand criterion (QPA), Spuri's bound (docs/model/beyond.md)
    "EdfAnalysis",
    "EdfTaskResult",
    "analyze_edf",
    "demand",
    "qpa",
    "spuri_wcrt",
    # suspension-aware bounds (docs/model/beyond.md)
    "SuspensionBound",
    "suspension_aware",
    "unified_bound",
    # offsets: the window chain and its per-window tasks as one transaction (docs/analysis.md)
    "analyze_transactions",
    "transaction_bounds",
    "w_txn",
    # utilization tests
    "hyperbolic",
    "hyperbolic_product",
    "liu_layland",
    "liu_layland_bound",
    "rm_implicit",
    "total_utilization",
    # kinematics and motion/sensing bounds (docs/model/upper-bounds.md)
    "BOUND_KINDS",
    "LocalizationKind",
    "Thresholds",
    "beta_dot",
    "follower_msbs",
    "formation_velocity",
    "msb_bearing",
    "msb_localization",
    "msb_localization_full",
    "msb_path_diversion",
    "msb_separation",
    "relative_state",
    "rho_dot",
    "slack",
    "wrap_angle",
    "wrap_positive",
]
