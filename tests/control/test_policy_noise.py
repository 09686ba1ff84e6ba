"""Policies ``noise-aware`` and ``safe`` (rtsim.control.policy, issue 10 item 2).

The hand case of tests/control/test_policy.py: one follower on its slot straight behind the leader
(ρ = ρ_d = 100 cm, β = π, θ = 0, κ = 0) with the formation model: V_F = V_L = v,
ρ̇ = β̇ = 0; T_ρ = 0.01, T_ε = 0.025, T_β = 0.1, r_H = 1. With σ_v = 0.5 cm/s,
σ_p = 1 cm, σ_θ = 0 and σ_ω = 0: σ_β = σ_p / ρ = 0.01 and
S(v) = √(σ_v² + (V_F σ_θ)² + ((v + V_F) σ_β)²) = √(0.25 + (0.02 v)²), so at v = 25:
S = √0.5; the padded bounds with z = 2 are
path 1000·0.025·100 / (25 + 2·0.5) = 2500 / 26, separation 1000·0.01·100 / (2√0.5) = 1000/√2,
localization 1000·1 / (2√0.5) = 1000/√2, bearing 1000·0.1 / (2√0.5 / 100) = 10⁴/√2.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, ClassVar

import pytest

from rtsim.analysis.kinematics import Thresholds
from rtsim.config.scenario import load_scenario
from rtsim.control import FollowerEstimate
from rtsim.control.adjust import Decision
from rtsim.control.policy import (
    ADJUSTMENT_POLICIES,
    MarginPolicy,
    NoiseAwarePolicy,
    PolicyInput,
    make_policy,
    pad_rows,
)
from rtsim.coupling.scenario_run import run_scenario
from rtsim.errors import InputError, ScenarioError

PIN = Path(__file__).parents[1] / "data" / "policy_pin"
THR = Thresholds(r_H=1.0, T_rho=0.01, T_eps=0.025, T_beta=0.1, localization="radial")
F = FollowerEstimate(rho=100.0, beta=math.pi, theta=0.0, v_f=25.0, rho_d=100.0, beta_d=math.pi)
NOISE = {"speed_noise": 0.5, "turn_noise": 0.0, "pose_sd": ((1.0, 0.0),)}


def _ctx(w_sch: float, **kw: Any) -> PolicyInput:
    return PolicyInput([F], v_ld=25.0, w_sch=w_sch, thresholds=THR, **{**NOISE, **kw})


def test_padded_bounds_by_hand() -> None:
    d = NoiseAwarePolicy(z=2.0).decide(_ctx(80.0))
    loc, sep, path, bear = d.rows[0]
    assert path == pytest.approx(2500.0 / 26.0, rel=1e-12)
    assert sep == pytest.approx(1000.0 / math.sqrt(2.0), rel=1e-12)
    assert loc == pytest.approx(1000.0 / math.sqrt(2.0), rel=1e-12)
    assert bear == pytest.approx(1e4 / math.sqrt(2.0), rel=1e-12)
    # 2500/26 = 96.15 ≥ 80: w is the padded bound, at V_Ld
    assert (d.w, d.v_leader, d.method) == (pytest.approx(2500.0 / 26.0), 25.0, "none")


def test_heading_and_turn_noise_by_hand() -> None:
    # σ_θ = 0.02, σ_ω = 0.05 rad/s, T = 0.08 s: σ_θ² = 0.0004 + 0.004² = 0.000416;
    # S² = 0.25 + 25²·0.000416 + (50·0.01)² = 0.76 at v = 25
    ctx = _ctx(80.0, turn_noise=0.05, pose_sd=((1.0, 0.02),))
    raw = ADJUSTMENT_POLICIES["fixed-wsch"]().decide(ctx).rows
    rows = pad_rows(raw, [F], ctx, 25.0, 3.0)
    assert rows[0][1] == pytest.approx(1000.0 / (3.0 * math.sqrt(0.76)), rel=1e-12)
    assert rows[0][3] == pytest.approx(100.0 / (3.0 * math.sqrt(0.76) / 100.0), rel=1e-12)
    assert rows[0][2] == pytest.approx(2500.0 / 26.5, rel=1e-12)


def test_overload_slows_to_the_padded_bound() -> None:
    # 2500 / (v + 1) = 120 → v = 2500/120 − 1 (separation at that v stays ~780 ms)
    d = NoiseAwarePolicy(z=2.0).decide(_ctx(120.0))
    assert d.w == 120.0 and d.method == "numeric" and d.feasible
    assert d.v_leader == pytest.approx(2500.0 / 120.0 - 1.0, rel=1e-6)
    # with a margin μ = 0.2: 0.8·2500 / (v + 1) = 120 → v = 2000/120 − 1
    d = NoiseAwarePolicy(z=2.0, margin=0.2).decide(_ctx(120.0))
    assert d.v_leader == pytest.approx(2000.0 / 120.0 - 1.0, rel=1e-6)
    # a padding that no speed satisfies: 2500 / (v + 10·0.5·...) — z = 10, w_sch = 600
    d = NoiseAwarePolicy(z=10.0).decide(_ctx(600.0, floor_frac=0.2))
    assert d.method == "floor" and d.v_leader == pytest.approx(5.0) and not d.feasible


def test_z_zero_is_the_papers_decision_at_vld() -> None:
    for w_sch in (60.0, 100.0):
        a = NoiseAwarePolicy(z=0.0).decide(_ctx(w_sch))
        b = ADJUSTMENT_POLICIES["adjust"]().decide(_ctx(w_sch))
        assert (a.w, a.v_leader, a.rows) == (b.w, b.v_leader, b.rows)
    # in overload the numeric scan finds the paper's speed
    a = NoiseAwarePolicy(z=0.0).decide(_ctx(120.0))
    assert a.v_leader == pytest.approx(2500.0 / 120.0, rel=1e-6)


def test_safe_without_a_path_is_noise_aware_with_its_margin() -> None:
    for w_sch in (80.0, 120.0):
        assert make_policy("safe", {"margin": 0.1, "z": 1.0}).decide(
            _ctx(w_sch)
        ) == NoiseAwarePolicy(z=1.0, margin=0.1).decide(_ctx(w_sch))
    # with z = 0 it is lookahead + margin
    assert (
        make_policy("safe", {"z": 0.0, "margin": 0.1}).decide(_ctx(80.0)).w
        == MarginPolicy(0.1).decide(_ctx(80.0)).w
    )


def test_bad_z_is_a_one_line_error(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"^adjust\.z: must be in \[0, 10\], got 11\.0$"):
        make_policy("noise-aware", {"z": 11.0})
    text = (PIN / "pin1.toml").read_text(encoding="utf-8")
    bad = tmp_path / "bad.toml"
    bad.write_text(
        text.replace("[adjust]\n", '[adjust]\npolicy = "noise-aware"\nz = -1\n'), encoding="utf-8"
    )
    with pytest.raises(
        ScenarioError, match=r"^.*/bad\.toml: adjust\.z: must be in \[0, 10\], got -1$"
    ):
        load_scenario(bad)


class NoiseRecorder:
    """Records what the coupling gives a policy that asks for the noise."""

    params: ClassVar[dict[str, Any]] = {}
    needs_noise: ClassVar[bool] = True
    seen: ClassVar[list[PolicyInput]] = []

    def decide(self, ctx: PolicyInput) -> Decision:
        NoiseRecorder.seen.append(ctx)
        return ADJUSTMENT_POLICIES["adjust"]().decide(ctx)


def test_the_coupling_gives_the_noise_and_the_ekf_spread() -> None:
    NoiseRecorder.seen.clear()
    run_scenario(PIN / "pin1.toml", duration_s=2.0, seed=0, policy=f"{__name__}:NoiseRecorder")
    sc = load_scenario(PIN / "pin1.toml")
    assert NoiseRecorder.seen
    for ctx in NoiseRecorder.seen:
        assert ctx.speed_noise == sc.world.follower.speed_noise
        assert ctx.turn_noise == sc.world.follower.turn_noise
        assert len(ctx.pose_sd) == sc.world.n
        assert all(sp > 0.0 and sth > 0.0 for sp, sth in ctx.pose_sd)


def test_noise_aware_and_safe_run_from_a_file(tmp_path: Path) -> None:
    text = (PIN / "pin1.toml").read_text(encoding="utf-8")
    for extra, name in (
        ('policy = "noise-aware"\nz = 2', "noise-aware"),
        ('policy = "safe"\nz = 1\nmargin = 0.1', "safe"),
    ):
        f = tmp_path / f"{name}.toml"
        f.write_text(text.replace("[adjust]\n", f"[adjust]\n{extra}\n"), encoding="utf-8")
        res = run_scenario(f, duration_s=3.0, seed=0)
        assert res.summary["policy"] == name
        base = run_scenario(f, duration_s=3.0, seed=0, policy="adjust")
        # padding only shortens windows or slows the leader
        assert res.windows["w"].mean() <= base.windows["w"].mean() + 1e-9
