"""The verifier's batched statics against ``physics.statics`` solved one posture at a time."""

from __future__ import annotations

import numpy as np

from jethr1_plan.geometry import SIDES
from jethr1_plan.physics.statics import leg_condition_numbers, static_torques
from jethr1_plan.verify.plan_rows import batched_statics


def test_batched_statics_match_the_row_by_row_solution(robot):
    rng = np.random.default_rng(3)
    wrapper = robot.wrapper()
    supports = np.array(["left", "right", "both", "both", "right", "left", "nowhere"])
    m, nv, nf = len(supports), 6 + len(robot.joint_names), len(robot.fans)
    gravity, jac, fan_z = np.zeros((m, nv)), {s: np.zeros((m, 6, nv)) for s in SIDES}, np.zeros((m, nf, nv))
    thrust = rng.uniform(0.0, 15.0, (m, nf))
    thrust[1, 0] = 0.0
    feet = {s: np.zeros((m, 4, 4)) for s in SIDES}
    expected_tau, expected_kappa = np.full((m, len(robot.joint_names)), np.nan), np.zeros((m, 2))
    for i, sup in enumerate(supports):
        T = np.eye(4)
        c, s = np.cos(0.3 * i), np.sin(0.3 * i)
        T[:2, :2] = [[c, -s], [s, c]]
        T[:3, 3] = (0.01 * i, -0.02, 0.29)
        wrapper.set_T_world_fbase(T)
        q = np.clip(rng.normal(0.0, 0.3, len(robot.joint_names)), robot.lower_rad, robot.upper_rad)
        wrapper.state.q[7:] = q
        wrapper.update_kinematics()
        gravity[i] = wrapper.generalized_gravity()
        for side in SIDES:
            jac[side][i] = wrapper.frame_jacobian(robot.legs[side].sole, "local_world_aligned")
            feet[side][i] = wrapper.get_T_world_frame(robot.legs[side].sole)
        for k, fan in enumerate(robot.fans):
            fan_z[i, k] = wrapper.frame_jacobian(fan.frame, "local_world_aligned")[2]
        on = SIDES if sup == "both" else ((sup,) if sup in SIDES else ())
        if on:
            expected_tau[i], _ = static_torques(robot, wrapper, thrust[i], on)
        kappa = leg_condition_numbers(robot, wrapper)
        expected_kappa[i] = kappa["left"], kappa["right"]
    tau, kappa = batched_statics(robot, gravity, jac, fan_z, thrust, supports, feet)
    assert np.isnan(tau[-1]).all()  # no sole on the ground: no static torques
    np.testing.assert_allclose(tau[:-1], expected_tau[:-1], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(kappa, expected_kappa, rtol=1e-9)
    assert np.ptp(tau[:-1], axis=0).max() > 0.1  # the postures differ: the comparison is not of one row
