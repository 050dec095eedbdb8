"""The re-check of a sweep's members by PlaCo: every member's posture, solved in closed form, put into PlaCo's
model, whose forward kinematics must place both soles and the CoM where the closed form does (to 1e-9 m).
Run inside the sweep's tasks, so it costs the workers' time, not the command's."""

from __future__ import annotations

import functools

import numpy as np

from jethr1_plan.balance_space.spec import SweepSpec
from jethr1_plan.kinematics.closed_form import solve_postures
from jethr1_plan.reasons import Reason
from jethr1_plan.robot.model import RobotModel

__all__ = ["CHECK_CHUNK", "check_members"]

CHECK_CHUNK = 2048  # members re-checked together (a 1 cm block has up to ~20,000)


@functools.lru_cache(maxsize=4)
def _wrapper(robot: RobotModel):
    """One PlaCo model per robot and process (loading one costs ~20 ms)."""
    return robot.wrapper()


def check_members(spec: SweepSpec, swing: np.ndarray, p_body: np.ndarray, yaw: np.ndarray) -> int:
    """Re-check the members at swing soles ``swing`` (k, 3) [m] with pelvis ``p_body`` (k, 3) [m] at ``yaw`` (k,)
    [rad]; return k.

    Raises:
        AssertionError: a posture whose soles or CoM are not where the sweep says (a bug).
    """
    k = len(swing)
    for lo in range(0, k, CHECK_CHUNK):  # a chunk at a time: a block's members' arrays are not all held at once
        _check(spec, swing[lo:lo + CHECK_CHUNK], p_body[lo:lo + CHECK_CHUNK], yaw[lo:lo + CHECK_CHUNK])
    return k


def _check(spec: SweepSpec, swing: np.ndarray, p_body: np.ndarray, yaw: np.ndarray) -> None:
    robot = spec.model
    wrapper = _wrapper(robot)
    support = np.asarray(spec.support, dtype=float)
    feet = {spec.support_side: (support, 0.0), spec.swing_side: (swing, 0.0)}
    qs, coms, statuses = solve_postures(robot, p_body, yaw, feet)
    sole_s, sole_w = robot.legs[spec.support_side].sole, robot.legs[spec.swing_side].sole
    k = len(swing)
    T = np.zeros((k, 4, 4))
    cy, sy = np.cos(yaw), np.sin(yaw)
    T[:, 0, 0], T[:, 0, 1], T[:, 1, 0], T[:, 1, 1], T[:, 2, 2], T[:, 3, 3] = cy, -sy, sy, cy, 1.0, 1.0
    T[:, :3, 3] = p_body
    placed = np.empty((k, 9))  # PlaCo's support sole, swing sole, CoM
    q = wrapper.state.q  # (a view of PlaCo's state)
    for j in range(k):
        wrapper.set_T_world_fbase(T[j])
        q[7:] = qs[j]
        wrapper.update_kinematics()
        placed[j, 0:3] = wrapper.get_T_world_frame(sole_s)[:3, 3]
        placed[j, 3:6] = wrapper.get_T_world_frame(sole_w)[:3, 3]
        placed[j, 6:9] = wrapper.com_world()
    err = np.maximum.reduce([np.linalg.norm(placed[:, 0:3] - support, axis=1),
                             np.linalg.norm(placed[:, 3:6] - swing, axis=1),
                             np.linalg.norm(placed[:, 6:9] - coms, axis=1)])
    bad = np.flatnonzero((statuses != Reason.OK) | ~(err <= 1e-9))
    if len(bad):
        raise AssertionError(f"balance-space cell {swing[bad[0]]} fails its PlaCo re-check")
