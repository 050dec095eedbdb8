"""Posture kinematics through PlaCo, checked by an independent forward kinematics of the URDF."""

from __future__ import annotations

import numpy as np
import pytest

from jethr1_plan.kinematics import Stance
from jethr1_plan.kinematics.placo import PlacoPostureSolver
from jethr1_plan.reasons import Reason
from tests.conftest import JOINT_NAMES


def _stance(swing, yaw):
    return Stance("right", np.array([0.0, -0.1125, 0.0]), 0.0, np.asarray(swing, float), 0.0, yaw)


def test_ik_converges_and_forward_kinematics_agrees(robot, reference):
    solver = PlacoPostureSolver(robot)
    rng = np.random.default_rng(0)
    stance = _stance([0.25, 0.05, 0.04], -0.6)
    p = np.array([0.1, -0.05, 0.36]) + rng.uniform(-0.03, 0.03, (40, 3))
    batch = solver.solve_batch(stance, p)
    assert np.all(batch.status == Reason.OK)
    for pb, q, com in zip(p, batch.q, batch.com, strict=True):
        poses = reference.link_poses(pb, stance.body_yaw, dict(zip(JOINT_NAMES, q, strict=True)))
        for side in ("left", "right"):
            T, T_ref = poses[f"{side}_foot"], stance.foot_pose(side)
            assert np.linalg.norm(T[:3, 3] - T_ref[:3, 3]) <= 1e-6
            assert np.linalg.norm(T[:3, :3] - T_ref[:3, :3]) / np.sqrt(2) <= 1e-6
        assert np.all(q >= robot.lower_rad) and np.all(q <= robot.upper_rad)
        np.testing.assert_allclose(reference.com(pb, stance.body_yaw, dict(zip(JOINT_NAMES, q, strict=True)))[1],
                                   com, atol=1e-12)


def test_result_does_not_depend_on_batch_neighbours(robot):
    solver = PlacoPostureSolver(robot)
    stance = _stance([0.2, 0.1, 0.03], -0.3)
    p = np.array([[0.05, 0.0, 0.37], [0.12, -0.06, 0.33], [0.0, 0.02, 0.4]])
    together = solver.solve_batch(stance, p)
    for i in range(3):
        alone = solver.solve_batch(stance, p[i:i + 1])
        np.testing.assert_allclose(alone.q[0], together.q[i], atol=1e-8)


def test_out_of_reach_is_reported_without_ik(robot):
    solver = PlacoPostureSolver(robot)
    batch = solver.solve_batch(_stance([0.9, 0.0, 0.0], 0.0), np.array([[0.0, 0.0, 0.4]]))
    assert batch.status[0] == Reason.UNREACHABLE
    assert np.isnan(batch.com[0]).all()


def test_joint_limit_is_reported(robot):
    # trunk yawed beyond the hip-yaw range: the legs cannot keep the feet facing forward
    solver = PlacoPostureSolver(robot)
    yaw = robot.upper_rad[JOINT_NAMES.index("left_hip_yaw")] + 0.3
    batch = solver.solve_batch(_stance([0.0, 0.1125, 0.0], yaw), np.array([[0.0, 0.0, 0.38]]))
    assert batch.status[0] == Reason.JOINT_LIMIT


def test_leg_geometry_read_from_the_model(robot):
    assert robot.thigh_m + robot.shank_m + robot.ankle_height_m == pytest.approx(robot.leg_length_m)
