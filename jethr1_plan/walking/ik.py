"""The QP inverse kinematics of a walk (Paper B, V-D, eqs. B-39, B-40), with PlaCo's KinematicsSolver.

At each control step the whole body's velocity solves a QP whose tasks are both soles' poses (the
support sole still, the swing sole on its (B-21) trajectory), the CoM (the LIPM's, at its height),
the pelvis's yaw (the pelvic rotation θ; with a waist, the torso keeps facing the walk so that the
waist yaw joint carries θ, B-39's equality), and whose constraints are the joint angle and rate
limits (the URDF's), over one control period Δt (B-40: q ← q + Δt·q̇). The arm-swing joints are
left to (B-43) and masked here; any other joint outside the legs holds its home angle.

The CoM task replaces (B-19)'s proportional pelvis update (the pelvis moved until the measured CoM
meets the desired one): the QP places the CoM directly.
"""

from __future__ import annotations

import numpy as np

from jethr1_plan.robot.model import LEG_ROLES, RobotModel

__all__ = ["WalkIK", "yaw_matrix"]

#: task weights: the soles first, then the CoM, then the orientations (soft tasks, PlaCo's weighting)
SOLE_WEIGHT, COM_WEIGHT, ORIENTATION_WEIGHT, HOLD_WEIGHT = 100.0, 10.0, 10.0, 1.0
ITERATIONS = 1  # QP steps per control period (each from the posture the last one reached)
BENT_SEED = {"hip_pitch": -0.4, "knee": 0.8, "ankle_pitch": -0.4}


def yaw_matrix(yaw_rad: float) -> np.ndarray:
    """3 × 3 rotation about z by ``yaw_rad``."""
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class WalkIK:
    """One robot, one solver: the walk's QP IK (B-39) step by step.

    Args:
        robot: the model; dt: the control period [s].
    """

    def __init__(self, robot: RobotModel, dt: float):
        import placo

        self.robot = robot
        self.wrapper = robot.wrapper()
        self.solver = placo.KinematicsSolver(self.wrapper)
        self.solver.dt = dt
        self.soles = {}
        for side, leg in robot.legs.items():
            task = self.solver.add_frame_task(leg.sole, np.eye(4))
            task.configure(f"{side} sole", "soft", SOLE_WEIGHT, SOLE_WEIGHT)
            self.soles[side] = task
        self.com = self.solver.add_com_task(np.zeros(3))
        self.com.configure("com", "soft", COM_WEIGHT)
        self.pelvis = self.solver.add_orientation_task(robot.trunk, np.eye(3))
        self.pelvis.configure("pelvis yaw", "soft", ORIENTATION_WEIGHT)
        w = robot.walking
        self.torso = None
        if w.torso is not None:
            self.torso = self.solver.add_orientation_task(w.torso, np.eye(3))
            self.torso.configure("torso", "soft", ORIENTATION_WEIGHT)
        leg_joints = {j for leg in robot.legs.values() for j in leg.joints}
        home = dict(w.arm_home_rad)
        self.home = np.array([home.get(j, 0.0) for j in robot.joint_names])
        held = [j for j in robot.joint_names if j not in leg_joints and j != w.waist_yaw and j not in w.arm_swing]
        if held:
            hold = self.solver.add_joints_task()
            hold.set_joints({j: home.get(j, 0.0) for j in held})
            hold.configure("hold", "soft", HOLD_WEIGHT)
        for j in w.arm_swing:
            self.solver.mask_dof(j)
        self.arm_index = np.array([robot.joint_names.index(j) for j in w.arm_swing], dtype=np.int64)
        self._targets = {side: np.eye(4) for side in self.soles}

    def stand(self, feet: dict[str, np.ndarray], com: np.ndarray, yaw: float, iterations: int = 200) -> None:
        """Converge (without rate limits) on the standing posture of the walk's start."""
        q = self.home.copy()
        for leg in self.robot.legs.values():
            for role, value in BENT_SEED.items():
                q[leg.index[LEG_ROLES.index(role)]] = value
        T = np.eye(4)
        T[:3, 3] = [com[0], com[1], com[2]]
        self.wrapper.set_T_world_fbase(T)
        self.wrapper.state.q[7:] = q
        self.solver.enable_velocity_limits(False)
        for _ in range(iterations):
            self.step(feet, com, yaw, iterations=1)
        self.solver.enable_velocity_limits(True)

    def step(self, feet: dict[str, np.ndarray], com: np.ndarray, yaw: float, arms: np.ndarray | None = None,
             iterations: int = ITERATIONS) -> None:
        """One control period: the soles at ``feet`` (flat, facing +x), the CoM at ``com`` [m], the
        pelvis turned by ``yaw`` [rad]; the arm-swing joints at ``arms`` (set, not solved)."""
        for side, task in self.soles.items():
            T = self._targets[side]
            T[:3, 3] = feet[side]
            task.T_world_frame = T
        self.com.target_world = np.asarray(com, dtype=float)
        self.pelvis.R_world_frame = yaw_matrix(yaw)
        if arms is not None and len(self.arm_index):
            q = self.wrapper.state.q
            q[7 + self.arm_index] = arms
        for _ in range(iterations):
            self.wrapper.update_kinematics()
            self.solver.solve(True)
        self.wrapper.update_kinematics()

    @property
    def q(self) -> np.ndarray:
        """The joints [rad] (a copy)."""
        return self.wrapper.state.q[7:].copy()

    @property
    def base(self) -> np.ndarray:
        """The trunk's pose: 4 × 4 (a copy)."""
        return self.wrapper.get_T_world_fbase()
