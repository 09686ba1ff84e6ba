"""The geometric beam bound k (SPEC §2) against an independent ray–circle count."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtsim.analysis.bounds import window_bounds
from rtsim.analysis.window import k_geometric
from rtsim.config.taskset import load_taskset, parse_taskset, taskset_to_dict
from rtsim.errors import TaskSetError

R_F = 25.0
ANGLES = np.radians(90.0 + 0.5 * np.arange(361))  # the laser's beams (backward facing)


def ray_circle_hits(cx: float, cy: float, r: float) -> int:
    """Beams (rays from the origin) that meet the disc: |c|² − (c·u)² ≤ r² with c·u > 0."""
    ux, uy = np.cos(ANGLES), np.sin(ANGLES)
    proj = cx * ux + cy * uy
    return int(np.count_nonzero((proj > 0) & (cx * cx + cy * cy - proj * proj <= r * r)))


@pytest.mark.parametrize("rho_min", [60.0, 150.0, 175.0, 250.0, 390.0, 800.0])
def test_k_geometric_is_a_sound_and_tight_count(rho_min):
    k = k_geometric(rho_min)
    rng = np.random.default_rng(int(rho_min))
    worst = 0
    for _ in range(3000):
        rho = rho_min * (1.0 + (rng.random() ** 4) * 0.5)  # mostly near rho_min
        bearing = math.radians(rng.uniform(92.0, 268.0))
        worst = max(worst, ray_circle_hits(rho * math.cos(bearing), rho * math.sin(bearing), R_F))
    # the worst placement: a beam on the disc's edge at ρ = rho_min
    edge = math.radians(180.0) + math.asin(R_F / rho_min) * (1 - 1e-12)
    worst = max(worst, ray_circle_hits(rho_min * math.cos(edge), rho_min * math.sin(edge), R_F))
    assert worst <= k
    assert worst == k  # tight: some placement reaches it


def test_known_values_and_the_paper():
    assert k_geometric(390.0) == 15  # the "about 15 at 390 cm"
    assert k_geometric(150.0) == 39  # SPEC §2: the exact count at 150 cm is 39, not 34
    assert k_geometric(20.0) == 361


def test_window_key_geometric(tmp_path):
    ts = load_taskset()
    data = taskset_to_dict(ts)
    data["window"]["k"] = "geometric"
    data["window"]["rho_min"] = 390
    geo = parse_taskset(data, "g.toml")
    assert geo.window.k == 15.0 and geo.window.rho_min == 390.0
    again = parse_taskset(taskset_to_dict(geo), "h.toml")
    assert again.window == geo.window
    assert window_bounds(geo).w_sch < window_bounds(ts).w_sch
    del data["window"]["rho_min"]
    with pytest.raises(TaskSetError, match=r"g.toml: \[window\]: rho_min: missing"):
        parse_taskset(data, "g.toml")
    data["window"]["k"] = "round"
    with pytest.raises(TaskSetError, match=r"\[window\]: k: must be a number or \"geometric\""):
        parse_taskset(data, "g.toml")
    data["window"]["k"] = 34
    data["window"]["rho_min"] = 100
    with pytest.raises(TaskSetError, match='rho_min: applies only with k = "geometric"'):
        parse_taskset(data, "g.toml")


def test_coupling_flags_windows_whose_scan_breaks_k(tmp_path):
    import tomllib
    from pathlib import Path

    from rtsim.coupling import run_scenario

    scen = Path(__file__).resolve().parents[2] / "experiments" / "scenarios" / "test2.toml"
    text = scen.read_text()
    ts = taskset_to_dict(load_taskset())
    out = {}
    for rho_min in (100.0, 1200.0):  # k = 29 (sound here) and k = 5 (followers are closer)
        ts["window"]["k"], ts["window"]["rho_min"] = "geometric", rho_min
        lines = [
            f"{k} = {v!r}" if not isinstance(v, str) else f'{k} = "{v}"'
            for k, v in ts["window"].items()
        ]
        tasks = "\n".join(
            "[[tasks]]\n"
            + "\n".join(
                f'{k} = "{v}"' if isinstance(v, str) else f"{k} = {v!r}" for k, v in t.items()
            )
            for t in ts["tasks"]
        )
        f = tmp_path / f"geo{int(rho_min)}.toml"
        f.write_text(f'name = "geo"\n{tasks}\n[window]\n' + "\n".join(lines) + "\n")
        tomllib.loads(f.read_text())
        sc = tmp_path / f"s{int(rho_min)}.toml"
        sc.write_text(text.replace('taskset = "barrel_robots"', f'taskset = "{f.name}"'))
        res = run_scenario(sc, duration_s=8, record_jobs=False)
        df = res.windows
        k = load_taskset(f).window.k
        assert (df["assumption_broken"] == (df["points"] > min(361, 2 * k))).all()
        out[rho_min] = res.summary["assumption_broken"]
        assert out[rho_min] == int(df["assumption_broken"].sum())
    assert out[100.0] == 0 and out[1200.0] > 0
