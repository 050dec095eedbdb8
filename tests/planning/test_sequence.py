"""Swing rows under the robust policy: paced where the rows' own motion would move the ZMP off the sole."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from jethr1_plan.scenario import load_scenario
from tests.conftest import ROOT

SHIPPED = ROOT / "configs" / "scattered_steps.yaml"


@pytest.fixture(scope="module")
def scattered(tmp_path_factory):
    """scattered_steps with plain arcs (the shipped swings' 20 mm vertical ends taken off): a robust plan whose
    first swing, timed by the minimum-jerk law, turns sharply enough at a sample to need pacing."""
    from jethr1_plan.cli import run

    out = tmp_path_factory.mktemp("scattered_arcs")
    text = SHIPPED.read_text().replace(", lift_m: 0.02, descent_m: 0.02}", "}")
    assert "lift_m" not in text
    (out / "scattered_steps.yaml").write_text(text)
    assert run(["plan", str(out / "scattered_steps.yaml"), "-o", str(out), "--no-progress"]) == 0
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
    sc = load_scenario(scattered.parent / "scattered_steps.yaml")
    with open(scattered / "trajectory.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    for k in range(len(sc.steps)):
        n = sum(r["phase"] == "swing" and int(r["step"]) == k for r in rows)
        assert n == round(sc.timing.swing_s * sc.timing.rate_hz)


def test_summary_names_the_paced_swings_and_the_others_needed_no_pace(scattered):
    """summary.json's ``dynamics.paced_swings`` names each re-timed swing with its pace; pinocchio's margins of
    the written rows confirm it: a paced swing's least margin is the one recorded, and every swing not named
    keeps the multibody ZMP ``balance.sole_margin_m`` inside the sole under the minimum-jerk law."""
    from jethr1_plan.planning.pacing import PACE_ACCEL
    from tests.oracles.plan_audit import audit_plan

    sc = load_scenario(scattered.parent / "scattered_steps.yaml")
    dyn = json.loads((scattered / "summary.json").read_text())["dynamics"]
    paced = {p["step"]: p for p in dyn["paced_swings"]}
    assert list(paced) == [0]  # the first swing, whose minimum-jerk rows left the sole by 3.7 mm
    assert paced[0]["trunk_accel_m_s2"] in PACE_ACCEL and paced[0]["margin_held"]
    margin = audit_plan(scattered).margin_dynamic
    with open(scattered / "trajectory.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    for k in range(len(sc.steps)):
        swing = [i for i, r in enumerate(rows) if r["phase"] == "swing" and int(r["step"]) == k]
        least = float(margin[swing].min())
        if k in paced:
            assert least == pytest.approx(paced[k]["least_zmp_margin_m"], abs=1e-7)
        assert least >= sc.balance.sole_margin_m - 1e-9


class _RowByRow:
    """The closed form, asked one row at a time (not a ``ClosedFormPostureSolver``: the builder solves row by row)."""

    def __init__(self, robot):
        from jethr1_plan.kinematics.closed_form import ClosedFormPostureSolver

        self.inner = ClosedFormPostureSolver(robot)
        self.evaluations = 0

    def solve_batch(self, stance, p_body, warm=None):
        assert len(p_body) == 1
        self.evaluations += 1
        return self.inner.solve_batch(stance, p_body, warm)


@pytest.mark.parametrize("positions", [None, np.linspace(0.0, 1.0, 23) ** 2])
def test_rows_solved_at_once_are_those_solved_row_by_row(robot, positions):
    """A transfer's and a swing's postures solved for every row at once (the closed form), and their edge angles
    and tolerance shares computed together, give the very rows, to the bit, that solving them one by one does:
    P_body, yaw, joints, CoM, thrust, ZMP, window, margin, share and verdict; on a transfer with both fans' thrust
    ramping, a turn of the trunk and rows out of reach, then a swing of the left sole."""
    from jethr1_plan.kinematics.closed_form import ClosedFormPostureSolver
    from jethr1_plan.physics.balance import Tolerance
    from jethr1_plan.planning.sequence import FanThrust, SequenceBuilder

    feet = {"left": np.array([0.0, 0.1125, 0.0]), "right": np.array([0.06, -0.1125, 0.0])}
    built = []
    for solver in (ClosedFormPostureSolver(robot), _RowByRow(robot)):
        seq = SequenceBuilder(robot, solver, 50.0, 23.0, np.radians(40.0), 0.005, Tolerance(0.1, 0.05, 0.01))
        seq.transfer(1, feet, np.array([0.01, 0.03, 0.40]), 0.1, np.array([0.05, -0.02, 0.47]), -0.2, 0.5,
                     FanThrust(np.array([12.0, 0.0]), (0,)), FanThrust(np.array([0.0, 9.0]), (1,)),
                     include_end=True, share=0.8, positions=positions)
        path = np.column_stack([np.linspace(0.0, 0.16, 6), np.full(6, 0.1125), 0.04 * np.sin(np.linspace(0, np.pi, 6))])
        p_samples = np.column_stack([np.linspace(0.05, 0.09, 6), np.linspace(-0.07, -0.04, 6), np.full(6, 0.40)])
        seq.swing(1, "right", feet, path, p_samples, lambda swing: 0.05 * swing[0], 0.5, np.linspace(1.0, 0.6, 6))
        assert solver.evaluations == len(seq.rows)
        built.append(seq.rows.columns)
    batch, single = built
    assert set(batch) == set(single)
    for key in batch:
        a, b = np.asarray(batch[key]), np.asarray(single[key])
        assert a.shape == b.shape, key
        if a.dtype.kind == "f":
            assert np.array_equal(a, b, equal_nan=True), key
        else:
            assert a.tolist() == b.tolist(), key
    feasible = np.asarray(batch["feasible"])
    assert feasible.any() and not feasible.all()  # the far end is out of reach: rows of both kinds
    phase, share = np.asarray(batch["phase"]), np.asarray(batch["tolerance_share"], dtype=float)
    assert (phase == "swing").sum() == 25 and np.isfinite(share).all() and np.ptp(share) > 0


def test_a_swing_refused_at_a_row_ends_there_with_the_same_first_infeasible_row(robot):
    """Where the plan stops at its first infeasible row (``stop_at_infeasible``), a swing's rows end at it: the rows
    before it and it are those of the whole swing, to the bit, and the builder keeps the same first infeasible row
    (step, phase, sample, reason, time, P_body, swing sole) that refuses the plan."""
    from jethr1_plan.kinematics.closed_form import ClosedFormPostureSolver
    from jethr1_plan.physics.balance import Tolerance
    from jethr1_plan.planning.sequence import SequenceBuilder

    feet = {"left": np.array([0.0, 0.1125, 0.0]), "right": np.array([0.06, -0.1125, 0.0])}
    path = np.column_stack([np.linspace(0.0, 0.16, 6), np.full(6, 0.1125), 0.04 * np.sin(np.linspace(0, np.pi, 6))])
    # the trunk rises out of the legs' reach towards the end of the swing
    p_samples = np.column_stack([np.linspace(0.05, 0.09, 6), np.linspace(-0.07, -0.04, 6), np.linspace(0.40, 0.60, 6)])
    built = []
    for stop in (False, True):
        seq = SequenceBuilder(robot, ClosedFormPostureSolver(robot), 50.0, 23.0, np.radians(40.0), 0.005,
                              Tolerance(0.1, 0.05, 0.01))
        seq.stop_at_infeasible = stop
        seq.swing(1, "right", feet, path, p_samples, lambda swing: 0.05 * swing[0], 0.5, np.linspace(1.0, 0.6, 6))
        built.append((seq.rows.columns, seq.first_infeasible))
    (whole, first_whole), (cut, first_cut) = built
    feasible = np.asarray(whole["feasible"])
    k = int(np.flatnonzero(~feasible)[0])
    assert 0 < k < len(feasible) - 1  # feasible rows before it and rows after it
    assert first_cut == first_whole and first_whole is not None and first_whole.phase == "swing"
    assert len(cut["feasible"]) == k + 1 and not cut["feasible"][-1]
    for key in whole:
        a, b = np.asarray(whole[key])[:k + 1], np.asarray(cut[key])
        if a.dtype.kind == "f":
            assert np.array_equal(a, b, equal_nan=True), key
        else:
            assert a.tolist() == b.tolist(), key
