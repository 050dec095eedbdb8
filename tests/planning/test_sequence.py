"""Swing rows under the robust policy: paced where the rows' own motion would move the ZMP off the sole."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from jethr1_plan.cli import run
from jethr1_plan.scenario import load_scenario
from tests.conftest import ROOT

SCATTERED = ROOT / "configs" / "scattered_steps.yaml"


@pytest.fixture(scope="module")
def scattered(tmp_path_factory):
    out = tmp_path_factory.mktemp("scattered")
    assert run(["plan", str(SCATTERED), "-o", str(out), "--no-progress"]) == 0
    return out / "scattered_steps"


def test_a_paced_robust_plan_keeps_the_multibody_zmp_on_the_sole(scattered):
    """scattered_steps's first swing, timed by the minimum-jerk law, put the multibody ZMP 3.7 mm off the
    sole on one row (its trunk turns sharply at a sample); paced, pinocchio (an independent RNEA on the
    written rows) finds every inner row's ZMP inside its support, as summary.json says."""
    from tests.oracles.plan_audit import audit_plan

    audit = audit_plan(scattered)
    inner = audit.margin_dynamic[1:-1]
    assert np.all(inner >= 0.0)
    dyn = json.loads((scattered / "summary.json").read_text())["dynamics"]
    assert dyn["rows_outside_support"] == 0
    assert dyn["least_zmp_margin_m"] == pytest.approx(float(inner.min()), abs=1e-7)


def test_a_paced_swing_keeps_the_scenarios_rows(scattered):
    """Pacing changes when each row passes along the swing, not how many rows there are: every swing
    keeps the scenario's duration."""
    sc = load_scenario(SCATTERED)
    with open(scattered / "trajectory.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    for k in range(len(sc.steps)):
        n = sum(r["phase"] == "swing" and int(r["step"]) == k for r in rows)
        assert n == round(sc.timing.swing_s * sc.timing.rate_hz)
