"""The paper's policy and the two baselines give the same results as before the policy
interface (issue 10: "the paper's policy gives the same results as before this change for the
same world").

The digests were recorded on main at 63334eb, before ``rtsim.control.policy`` existed, from
frozen copies of Test 1 and Test 2 (``tests/data/policy_pin``; copies, so that retuning the
shipped scenarios does not move the pin): 20 simulated s, seed 1, each mode. windows.csv is
hashed as written by ``DataFrame.to_csv``; summary.json without the keys added since
(``policy``, ``lap_time_s``, ``lap_time_note`` and the physical outcomes: ``NEW_KEYS``).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest

from rtsim.coupling.scenario_run import run_scenario

PIN = Path(__file__).parent / "data" / "policy_pin"

DIGESTS = {
    "pin1/adjust": ("448a824885f55c1c", "664bacffcfc7cc84"),
    "pin1/fixed-wsch": ("83be0669ef93d121", "a737842c29e17de0"),
    "pin1/min-msb": ("1073516151c020a4", "eb290df50d5f1737"),
    "pin2/adjust": ("0ad8bf1443933481", "8e7d2b67d8d67ca4"),
    "pin2/fixed-wsch": ("0f7788ad6248da97", "78ab56ff9ff0496c"),
    "pin2/min-msb": ("e695d966ae60dbc9", "a0de6f446f4f4905"),
}


#: summary.json keys added after the pin was recorded (the pin ignores them): the policy, the
#: lap time, and the physical outcomes (rtsim.coupling.physical)
NEW_KEYS = ("policy", "lap_time_s", "lap_time_note", "cross_track_cm", "separation_error_cm",
            "min_robot_distance_cm", "collisions", "distance_cm", "per_follower")


def _digest(res) -> tuple[str, str]:  # type: ignore[no-untyped-def]
    csv = res.windows.to_csv(index=False).encode()
    s = {k: v for k, v in res.summary.items() if k not in NEW_KEYS}
    js = json.dumps(s, sort_keys=True, default=str).encode()
    return hashlib.sha256(csv).hexdigest()[:16], hashlib.sha256(js).hexdigest()[:16]


@pytest.mark.parametrize("key", sorted(DIGESTS))
def test_results_unchanged(key: str) -> None:
    name, mode = key.split("/")
    res = run_scenario(PIN / f"{name}.toml", mode=mode, duration_s=20.0, seed=1)
    assert _digest(res) == DIGESTS[key]
