"""The closed-form leg kinematics (compiled) agree with PlaCo to 1e-9 m on thousands of candidates, and
with their numpy statement (the oracle) to rounding."""

from __future__ import annotations

import numpy as np
import pytest

from jethr1_plan.kinematics import Stance
from jethr1_plan.kinematics.closed_form import ClosedFormPostureSolver, check_structure, solve_postures
from jethr1_plan.kinematics.placo import PlacoPostureSolver
from jethr1_plan.reasons import Reason
from tests.conftest import JOINT_NAMES
from tests.oracles.leg import com_batch, fast_com, leg_ik, link_poses


def _random_stances(rng, n):
    for _ in range(n):
        support = rng.choice(["left", "right"])
        sgn = 1.0 if support == "left" else -1.0
        sup = np.array([0.0, sgn * 0.1125, 0.0])
        swing = np.array([rng.uniform(-0.3, 0.6), rng.uniform(-0.35, 0.35) - sgn * 0.1, rng.uniform(-0.05, 0.12)])
        yield Stance(support, sup, rng.uniform(-0.3, 0.3), swing, rng.uniform(-0.3, 0.3), rng.uniform(-1.5, 1.5))


def test_closed_form_agrees_with_placo_on_thousands_of_candidates(robot):
    rng = np.random.default_rng(11)
    placo_solver, analytic = PlacoPostureSolver(robot), ClosedFormPostureSolver(robot)
    wrapper = robot.wrapper()
    compared = 0
    for stance in _random_stances(rng, 60):
        mid = 0.5 * (stance.support_xyz + stance.swing_xyz)
        p = mid + np.array([0, 0, 0.3]) + rng.uniform(-0.12, 0.12, (100, 3))
        a = analytic.solve_batch(stance, p)
        b = placo_solver.solve_batch(stance, p)
        both = (a.status == Reason.OK) & (b.status == Reason.OK)
        # PlaCo converges where the closed form says the posture exists and is within limits
        assert np.all(b.status[a.status == Reason.OK] == Reason.OK)
        assert np.all(a.status[b.status == Reason.UNREACHABLE] == Reason.UNREACHABLE)
        # PlaCo stops within its 1e-6 tolerance; the closed form is exact
        np.testing.assert_allclose(a.q[both], b.q[both], atol=1e-6)
        np.testing.assert_allclose(a.com[both], b.com[both], atol=1e-6)
        # the closed-form joints put PlaCo's soles on their targets to 1e-9 m, and PlaCo's CoM is ours
        for i in np.flatnonzero(a.status == Reason.OK):
            T = np.eye(4)
            c, s = np.cos(stance.body_yaw), np.sin(stance.body_yaw)
            T[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
            T[:3, 3] = p[i]
            wrapper.set_T_world_fbase(T)
            wrapper.state.q[7:] = a.q[i]
            wrapper.update_kinematics()
            for side in ("left", "right"):
                np.testing.assert_allclose(wrapper.get_T_world_frame(f"{side}_foot"), stance.foot_pose(side),
                                           atol=1e-9)
            np.testing.assert_allclose(wrapper.com_world(), a.com[i], atol=1e-12)
        compared += int((a.status == Reason.OK).sum())
    assert compared > 2000


def test_batched_forward_kinematics_matches_placo(robot):
    rng = np.random.default_rng(5)
    q = rng.uniform(robot.lower_rad, robot.upper_rad, (300, 12))
    p, yaw = rng.uniform(-0.3, 0.3, (300, 3)), rng.uniform(-np.pi, np.pi, 300)
    com = com_batch(robot, p, yaw, q)
    poses = link_poses(robot, p, yaw, q)
    wrapper = robot.wrapper()
    for i in range(0, 300, 7):
        T = np.eye(4)
        T[:3, :3] = [[np.cos(yaw[i]), -np.sin(yaw[i]), 0], [np.sin(yaw[i]), np.cos(yaw[i]), 0], [0, 0, 1]]
        T[:3, 3] = p[i]
        wrapper.set_T_world_fbase(T)
        wrapper.state.q[7:] = q[i]
        wrapper.update_kinematics()
        np.testing.assert_allclose(com[i], wrapper.com_world(), atol=1e-12)
        for frame in ("left_foot", "right_fan", "right_shank"):
            Tf = wrapper.get_T_world_frame(frame)
            R, pos = poses[frame]
            np.testing.assert_allclose(pos[:, i], Tf[:3, 3], atol=1e-12)
            np.testing.assert_allclose(R[:, :, i], Tf[:3, :3], atol=1e-12)


def test_limits_and_reach_are_reported(robot):
    feet = {"left": (np.array([0.0, 0.1125, 0.0]), 0.0), "right": (np.array([0.0, -0.1125, 0.0]), 0.0)}
    q, _, status = solve_postures(robot, np.array([[0.0, 0.0, 0.40], [0.0, 0.0, 0.60], [0.0, 0.0, 0.38]]),
                                    np.array([0.0, 0.0, 2.2]), feet)
    assert status.tolist() == [Reason.OK, Reason.UNREACHABLE, 2]  # 2.2 rad of trunk yaw is beyond the hip-yaw limits
    assert q[0, JOINT_NAMES.index("left_knee")] > 0


@pytest.mark.parametrize("side", ["left", "right"])
def test_straight_leg_is_the_reach_boundary(robot, side):
    sgn = 1.0 if side == "left" else -1.0
    foot = np.array([0.0, sgn * robot.hip_offset_m, 0.0])
    feet = {side: (foot, 0.0), ("right" if side == "left" else "left"): (-foot, 0.0)}
    z = np.array([robot.leg_length_m - 1e-9, robot.leg_length_m + 1e-6])
    _, _, status = solve_postures(robot, np.stack([np.zeros(2), np.zeros(2), z], axis=1), 0.0, feet)
    assert status[1] == Reason.UNREACHABLE and status[0] != Reason.UNREACHABLE


def test_the_compiled_closed_form_is_the_numpy_one(robot):
    """physics.compiled.postures against the numpy statement of the same formulas (tests/oracles/leg.py),
    feet turned as well as straight."""
    rng = np.random.default_rng(17)
    n = 20_000
    P = rng.uniform([-0.2, -0.3, 0.15], [0.5, 0.3, 0.5], (n, 3))
    yaw = rng.uniform(-1.6, 1.6, n)
    feet = {"left": (np.column_stack([rng.uniform(-0.2, 0.6, n), rng.uniform(0.0, 0.4, n), rng.uniform(0, 0.1, n)]),
                     rng.uniform(-0.5, 0.5, n)),
            "right": (np.array([0.0, -0.1125, 0.0]), 0.0)}
    q, com, status = solve_postures(robot, P, yaw, feet)
    geom = check_structure(robot)
    q_ref, reach = [], np.ones(n, dtype=bool)
    for side in ("left", "right"):
        xyz, fyaw = feet[side]
        qs, ok = leg_ik(geom, side, P, yaw, np.broadcast_to(xyz, (n, 3)), fyaw)
        q_ref.append(qs)
        reach &= ok
    q_ref = np.concatenate(q_ref, axis=1)
    assert np.array_equal(status == Reason.UNREACHABLE, ~reach) and reach.sum() > 2000
    np.testing.assert_allclose(q[reach], q_ref[reach], rtol=0, atol=1e-9)
    np.testing.assert_allclose(com[reach], fast_com(robot, P, yaw, q_ref)[reach], rtol=0, atol=1e-12)
