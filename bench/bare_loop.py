"""A bare PlaCo loop that replays recorded IK runs: the yardstick of the benchmarks."""

from __future__ import annotations

import time

import jethr1_plan.arithmetic  # noqa: F401  (first: NumPy's and OpenBLAS's kernels pinned before they load)

import numpy as np
import placo


def bare_replay_seconds(robot_model, log: list) -> float:
    """Wall time [s] of a PlaCo loop doing the same IK iterations on the same candidates.

    For each recorded run: set the trunk pose and the start joints, point both sole tasks at their
    targets, ``iterations`` × (update_kinematics + solve), then update_kinematics + com_world.
    """
    robot = robot_model.wrapper()
    solver = placo.KinematicsSolver(robot)
    solver.mask_fbase(True)
    left = solver.add_frame_task("left_foot", np.eye(4))
    left.configure("left_foot", "soft", 1.0, 1.0)
    right = solver.add_frame_task("right_foot", np.eye(4))
    right.configure("right_foot", "soft", 1.0, 1.0)
    # targets change once per batch in the evaluator; set them only when they change here too
    last = None
    t0 = time.perf_counter()
    for T_trunk, p, q0, T_left, T_right, iters in log:
        if last is not T_left:
            left.T_world_frame = T_left
            right.T_world_frame = T_right
            last = T_left
        T = T_trunk.copy()
        T[:3, 3] = p
        robot.set_T_world_fbase(T)
        robot.state.q[7:] = q0
        for _ in range(iters):
            robot.update_kinematics()
            solver.solve(True)
        robot.update_kinematics()
        robot.com_world()
    return time.perf_counter() - t0
