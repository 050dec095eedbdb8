"""Paper B's yaw MPC (B-34..B-38) and the `mpc` body-yaw mode."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from jethr1_plan.cli import run
from jethr1_plan.control.yaw_mpc import inverse_min_jerk, mpc_smooth
from jethr1_plan.scenario import load_scenario
from tests.conftest import ROOT


def test_double_integrator_and_look_ahead():
    dt = 0.02
    ref = np.concatenate([np.zeros(100), np.full(100, -1.2)])  # a step at row 100
    theta, rate, acc = mpc_smooth(ref, dt, horizon_s=1.6, alpha=1.0, beta=1e-2, lo=-1.0, hi=1.0)
    # (B-34): each state follows from the previous one and the applied acceleration
    np.testing.assert_allclose(theta[1:], theta[:-1] + dt * rate[:-1] + 0.5 * dt * dt * acc[:-1], atol=1e-12)
    np.testing.assert_allclose(rate[1:], rate[:-1] + dt * acc[:-1], atol=1e-12)
    assert theta[90] < -0.01  # it sees the turn coming and starts before the step
    assert theta.min() >= -1.0 - 1e-6  # the bound (the hip-yaw limit) holds
    assert theta[-1] == pytest.approx(-1.0, abs=1e-3)
    # a larger acceleration weight gives a gentler turn
    _, rate2, _ = mpc_smooth(ref, dt, horizon_s=1.6, alpha=1.0, beta=1.0, lo=-1.0, hi=1.0)
    assert np.abs(rate2).max() < np.abs(rate).max()


def test_inverse_min_jerk():
    t = np.linspace(0, 1, 11)
    s = t**3 * (10 - 15 * t + 6 * t * t)
    np.testing.assert_allclose(inverse_min_jerk(s), t, atol=1e-4)


def test_mpc_plans_are_feasible_with_a_gentler_turn(tmp_path, capsys):
    doc = yaml.safe_load((ROOT / "configs" / "forward_ditch_450.yaml").read_text())
    doc["steps"][0]["path"]["samples"] = 30
    doc["timing"] = {"swing_s": 7.5, "transfer_s": 3.0, "rate_hz": 25.0}
    summaries = {}
    for mode, extra in (("eq4", {}), ("mpc", {"beta": 0.1})):
        doc["body_yaw"] = {"mode": mode, **extra}
        path = tmp_path / f"{mode}.yaml"
        path.write_text(yaml.safe_dump(doc))
        assert run(["plan", str(path), "-o", str(tmp_path / "o"), "--no-progress", "--json"]) == 0
        summaries[mode] = json.loads(capsys.readouterr().out)
        assert run(["verify", str(tmp_path / "o" / mode)]) == 0
    assert summaries["mpc"]["yaw"]["peak_rate_rad_s"] < summaries["eq4"]["yaw"]["peak_rate_rad_s"]
    assert summaries["mpc"]["peak_thrust_n"] <= 23.0


def test_scientific_notation_in_scenarios(tmp_path):
    doc = (ROOT / "configs" / "side_step.yaml").read_text().replace("method: gas", "method: gas\nbody_yaw: "
                                                                    "{mode: mpc, beta: 1e-10}")
    path = tmp_path / "s.yaml"
    path.write_text(doc)
    assert load_scenario(path).body_yaw.beta == 1e-10
