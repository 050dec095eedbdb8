"""The QP inverse kinematics of a walk (Paper B, V-D, eqs. B-39, B-40), with PlaCo's KinematicsSolver.

At each control step the whole body's velocity solves a QP whose tasks are both soles' poses (the
support sole still, the swing sole on its (B-21) trajectory) and the pelvis's yaw (the pelvic
rotation θ; with a waist, the torso keeps facing the walk so that the waist yaw joint carries θ,
B-39's equality), under hard constraints: the CoM on the LIPM's (at its height), the joint angle
limits (the URDF's, the knees' narrowed so that each leg stays bent by the walk's knee margin) and
each joint's window of rates (``joint_window``: its rate limit, its acceleration limit, room to
brake before its angle limits), over one control period Δt (B-40: q ← q + Δt·q̇). The arm-swing
joints are left to (B-43) and masked here; any other joint outside the legs holds its home angle.

The CoM constraint replaces (B-19)'s proportional pelvis update (the pelvis moved until the measured
CoM meets the desired one): the QP places the CoM exactly, so the floating base cannot absorb what
the legs fail to do. What the limits forbid shows as a sole off its target (the soft tasks give) or
as a joint whose window is empty (the generator reports both): never as a snap of a joint.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from jethr1_plan.geometry import SIDES
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.robot.schema import LEG_ROLES
from jethr1_plan.walking.joint_window import rate_window
from jethr1_plan.walking.knees import knee_limits_for_bend

__all__ = ["IKSettings", "WalkIK", "yaw_matrix"]

#: task weights: the soles first, then the orientations (soft tasks, PlaCo's weighting); the CoM is
#: weighted only while standing up, a hard constraint while walking
SOLE_WEIGHT, COM_WEIGHT, ORIENTATION_WEIGHT, HOLD_WEIGHT = 100.0, 10.0, 10.0, 1.0
ITERATIONS = 1  # QP steps per control period (each from the posture the last one reached)
BENT_SEED = {"hip_pitch": -0.4, "knee": 0.8, "ankle_pitch": -0.4}
KNEE_FLOOR_SLACK_RAD = 1e-4  # the IK keeps the knees this much more bent than the success margin [rad]
WINDOW_SLACK_RAD = 1e-12  # the window's bounds on the next angle, widened by this (round-off) [rad]


@dataclass(frozen=True)
class IKSettings:
    """The walk's IK (the walk file's ``ik:``)."""

    max_joint_acceleration_rad_s2: float = 100.0  # every IK joint's and arm joint's acceleration limit


def yaw_matrix(yaw_rad: float) -> np.ndarray:
    """3 × 3 rotation about z by ``yaw_rad``."""
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class WalkIK:
    """One robot, one solver: the walk's QP IK (B-39) step by step.

    Args:
        robot: the model; dt: the control period [s]; knee_bend_rad: the least bend [rad] each
            knee keeps (the IK's floor, :mod:`~jethr1_plan.walking.knees`).
    """

    def __init__(self, robot: RobotModel, dt: float, knee_bend_rad: float = 0.0):
        import placo

        self.robot = robot
        self.dt = dt
        self.wrapper = robot.wrapper()
        model = self.wrapper.model
        if knee_bend_rad > 0:  # the knees' floor: the live model's limits are the QP's joint limits
            for side in SIDES:
                k = robot.legs[side].index[3]
                lo, hi = knee_limits_for_bend(robot, side, knee_bend_rad + KNEE_FLOOR_SLACK_RAD)
                model.lowerPositionLimit[7 + k], model.upperPositionLimit[7 + k] = lo, hi
        self.lower = np.array(model.lowerPositionLimit[7:], dtype=float)
        self.upper = np.array(model.upperPositionLimit[7:], dtype=float)
        self.rate_max = np.array(model.velocityLimit[6:], dtype=float)
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
        arms = set(self.arm_index.tolist())
        self.solved_index = np.array([j for j in range(len(robot.joint_names)) if j not in arms], dtype=np.int64)
        self._targets = {side: np.eye(4) for side in self.soles}
        self._window: Any = None  # the rate window's half-spaces (PlaCo), from walk() on
        self.acc_max = np.inf

    def walk(self, settings: IKSettings) -> None:
        """From the standing posture on: the CoM a hard constraint, each joint in its window of rates."""
        self.com.configure("com", "hard", 1.0)
        self.acc_max = float(settings.max_joint_acceleration_rad_s2)
        k = len(self.solved_index)
        A = np.zeros((2 * k, self.wrapper.model.nq))
        A[np.arange(k), 7 + self.solved_index] = 1.0
        A[k + np.arange(k), 7 + self.solved_index] = -1.0
        self._window = self.solver.add_joint_space_half_spaces_constraint(
            A, np.concatenate([self.upper[self.solved_index], -self.lower[self.solved_index]]))
        self._window.configure("rate window", "hard", 1.0)  # PlaCo's default for it is soft

    def window(self, q: np.ndarray, rate: np.ndarray, joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) the rates [rad/s] the ``joints`` may take over the next period from angles ``q`` and
        rates ``rate`` over the last one (all joints, (J,))."""
        return rate_window(q[joints], rate[joints], self.lower[joints], self.upper[joints], self.rate_max[joints],
                           self.acc_max, self.dt)

    def set_window(self, q: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> None:
        """Hold the IK's joints' next angles within ``q + Δt·[lo, hi]`` (``lo``, ``hi``: over ``solved_index``)."""
        j = self.solved_index
        up = q[j] + self.dt * hi + WINDOW_SLACK_RAD
        down = q[j] + self.dt * lo - WINDOW_SLACK_RAD
        self._window.b = np.concatenate([up, -down])

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
