"""Paper B's reach analysis (B-1)..(B-5): Dyros-Jet's figures, and Jet-HR1's numerical reach."""

from __future__ import annotations

import json
import math

import pytest

from jethr1_plan.cli import run
from jethr1_plan.studies.reach import DYROS_JET, ReachFigures, step_lengths


def test_dyros_jet_figures():
    f = step_lengths(ReachFigures(**DYROS_JET))
    assert f["fixed_m"] == pytest.approx(0.316, abs=5e-4)  # (B-4), as Paper B states
    assert f["rotating_m"] == pytest.approx(0.3906, abs=5e-5)  # (B-5) at 45 deg (the paper says 0.42)
    assert f["standing_fixed_m"] == pytest.approx(2 * math.sqrt(0.75**2 - 0.68**2))
    assert f["kinematic_limit_m"] == pytest.approx(math.sqrt((2 * math.sqrt(0.75**2 - 0.68**2) + 0.21) ** 2
                                                             - 0.243**2))
    assert f["delta_d_hip_m"] == pytest.approx(0.21 * math.sin(math.pi / 4))


def test_cli_reports_the_discrepancy(capsys):
    assert run(["reach", "--dyros-jet", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert round(d["fixed_m"], 3) == 0.316 and abs(d["rotating_m"] - 0.390) < 1e-3
    assert "0.42" in d["note"] and "0.104" in d["note"]


def test_z0_above_the_leg_is_exit_2():
    assert run(["reach", "--l-leg", "0.4", "--z0", "0.5"]) == 2


def test_jethr1_numerical_reach_grows_with_the_turn(capsys):
    assert run(["reach", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["inputs"]["l_leg"] == pytest.approx(0.46) and d["inputs"]["l_pel"] == pytest.approx(0.2)
    fixed, turned = d["numerical"]["fixed"], d["numerical"]["turned"]
    assert fixed["placo_converged"] and turned["placo_converged"]
    assert turned["step_m"] > fixed["step_m"] + 0.05
    # with the pelvis free between the feet, the straight-leg reach bounds the numerical one
    assert fixed["step_m"] <= d["standing_fixed_m"] + 1e-9
