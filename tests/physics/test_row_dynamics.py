"""The ground's wrench the rows' motion needs (physics.row_dynamics): against Newton's laws for motions
whose answer is known in closed form, and against pinocchio's RNEA (tests/oracles/plan_audit.py) on a
written plan, reading only its files."""

from __future__ import annotations

import json

import numpy as np
import pytest

from jethr1_plan.geometry import GRAVITY
from jethr1_plan.physics.row_dynamics import row_dynamics

DT = 0.02  # [s]


def _standing(robot, n: int, base_xyz: np.ndarray):
    """n rows of the robot standing still in its seed posture, the trunk at ``base_xyz`` (n, 3)."""

    w = robot.wrapper()
    q = np.clip(np.zeros(len(robot.joint_names)), robot.lower_rad, robot.upper_rad)
    for side in ("left", "right"):  # knees bent
        idx = robot.legs[side].index
        q[idx[2]], q[idx[3]], q[idx[4]] = -0.5, 1.0, -0.5
    base = np.tile(np.eye(4), (n, 1, 1))
    base[:, :3, 3] = base_xyz
    w.set_T_world_fbase(base[0])
    w.state.q[7:] = q
    w.update_kinematics()
    com0 = w.com_world() - base[0][:3, 3]  # the CoM relative to the trunk (a rigid posture)
    return base, np.tile(q, (n, 1)), com0


def test_a_rigid_translation_shifts_the_zmp_by_the_cart_table_law(robot):
    """The whole robot translating rigidly with horizontal acceleration a: no angular momentum changes,
    the ground pushes m·(a, 0, g) through the CoM, so the ZMP is c_xy − c_z·a/g and f_z = m·g."""
    a = np.array([1.2, -0.7])  # [m/s²]
    t = np.arange(5) * DT
    xyz = np.column_stack([0.5 * a[0] * t**2, 0.5 * a[1] * t**2, np.full(5, 0.35)])
    base, q, com0 = _standing(robot, 5, xyz)
    dyn = row_dynamics(robot, base, q, np.zeros((5, len(robot.fans))), np.array(["both"] * 5), DT)
    m, g = robot.mass_kg, GRAVITY
    for i in (1, 2, 3):
        c = xyz[i] + com0
        np.testing.assert_allclose(dyn.zmp[i], c[:2] - c[2] * a / g, atol=1e-9)
        assert dyn.vertical_force_n[i] == pytest.approx(m * g, rel=1e-9)
        assert dyn.friction_ratio[i] == pytest.approx(np.linalg.norm(a) / g, rel=1e-9)


def test_a_trunk_falling_faster_than_gravity_needs_a_pull(robot):
    """Falling at 1.5 g, the ground would have to pull with m·(g − 1.5 g) = −m·g/2."""
    t = np.arange(5) * DT
    xyz = np.column_stack([np.zeros(5), np.zeros(5), 0.35 - 0.5 * 1.5 * GRAVITY * t**2])
    base, q, _ = _standing(robot, 5, xyz)
    dyn = row_dynamics(robot, base, q, np.zeros((5, len(robot.fans))), np.array(["both"] * 5), DT)
    np.testing.assert_allclose(dyn.vertical_force_n[1:4], -0.5 * robot.mass_kg * GRAVITY, rtol=1e-9)
    assert np.all(np.isnan(dyn.zmp[1:4])) and np.all(dyn.margin[1:4] == -np.inf)


def test_a_fan_takes_its_share_of_the_weight_by_moment_balance(robot):
    """At rest with a fan pushing F at p: the ground carries m·g − F and its ZMP is the moment balance
    (m·g·c − F·p)/(m·g − F)."""
    base, q, com0 = _standing(robot, 3, np.tile([0.0, 0.0, 0.35], (3, 1)))
    w = robot.wrapper()
    w.set_T_world_fbase(base[0])
    w.state.q[7:] = q[0]
    w.update_kinematics()
    thrust = np.zeros((3, len(robot.fans)))
    thrust[:, 0] = 15.0
    p = w.get_T_world_frame(robot.fans[0].frame)[:3, 3]
    c = base[0][:3, 3] + com0
    dyn = row_dynamics(robot, base, q, thrust, np.array(["both"] * 3), DT)
    W = robot.mass_kg * GRAVITY
    np.testing.assert_allclose(dyn.zmp[1], (W * c[:2] - 15.0 * p[:2]) / (W - 15.0), atol=1e-9)
    assert dyn.vertical_force_n[1] == pytest.approx(W - 15.0, rel=1e-9)


def test_the_summary_states_the_dynamic_zmp_pinocchio_finds_in_the_files(side_step_plan):
    """pinocchio (RNEA on the CSV's rows, the fans' written thrust) finds the quasistatic ZMP the CSV
    writes and the dynamic margin summary.json states, at the same row."""
    import csv

    from tests.oracles.plan_audit import audit_plan

    audit = audit_plan(side_step_plan)
    with open(side_step_plan / "trajectory.csv", newline="") as f:
        written = np.array([[float(r["zmp_x_m"]), float(r["zmp_y_m"])] for r in csv.DictReader(f)])
    np.testing.assert_allclose(audit.zmp_static, written, atol=1e-7)
    dyn = json.loads((side_step_plan / "summary.json").read_text())["dynamics"]
    inner = audit.margin_dynamic[1:-1]
    assert dyn["least_zmp_margin_at"]["row"] == int(np.argmin(inner)) + 1
    assert dyn["least_zmp_margin_m"] == pytest.approx(float(inner.min()), abs=1e-7)
    assert dyn["rows_outside_support"] == int(np.sum(inner < 0)) == 0  # the robust side step: never off the sole
    assert dyn["rows_needing_pull"] == 0


def test_the_rows_own_ends_are_exact_on_a_uniformly_accelerated_motion():
    """``ends="rows"``: the first and last rows' velocity and acceleration from the rows alone (one-sided
    stencils) are exact where the rows accelerate uniformly (joints and a trunk sliding without turning);
    ``ends="hold"`` sees the robot stop beyond them."""
    from jethr1_plan.geometry import pose_matrix
    from jethr1_plan.physics.row_dynamics import row_derivatives

    dt, n = 0.01, 12
    t = np.arange(n) * dt
    acc, v0 = np.array([0.7, -2.0, 0.3]), np.array([0.05, 0.4, -0.2])
    q = v0 * t[:, None] + 0.5 * acc * t[:, None] ** 2
    base = np.array([pose_matrix((0.1 + 0.2 * ti + 0.5 * 1.5 * ti**2, 0.0, 0.3), 0.0) for ti in t])
    v, a = row_derivatives(base, q, dt, ends="rows")
    for row in (0, n - 1):
        np.testing.assert_allclose(a[row, 6:], acc, atol=1e-9)
        np.testing.assert_allclose(v[row, 6:], v0 + acc * t[row], atol=1e-9)
        np.testing.assert_allclose(a[row, :3], [1.5, 0.0, 0.0], atol=1e-9)
        np.testing.assert_allclose(v[row, :3], [0.2 + 1.5 * t[row], 0.0, 0.0], atol=1e-9)
    _, held = row_derivatives(base, q, dt)
    assert abs(held[n - 1, 6] - acc[0]) > 1.0  # the stop within one row the old ends wrote
