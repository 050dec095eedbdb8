"""The kinematics family's interface: a stance, a batch of postures, and the solver protocol.

Preconditions 1 and 2 of Paper A fix the trunk level (roll = pitch = 0, yaw given) and both soles
flat, so a posture is determined by P_body ∈ R³. A :class:`PostureSolver` turns candidate P_body
under a :class:`Stance` into joint angles, the whole-body CoM and a status per candidate (a
:class:`~jethr1_plan.reasons.Reason`: OK, UNREACHABLE, JOINT_LIMIT or NOT_CONVERGED).

Implementations: :class:`~jethr1_plan.kinematics.placo.PlacoPostureSolver` (PlaCo's IK, the
default) and :class:`~jethr1_plan.kinematics.closed_form.ClosedFormPostureSolver` (closed form,
same postures to 1e-9 m); :func:`~jethr1_plan.kinematics.make_posture_solver` picks one by name.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from jethr1_plan.robot.model import RobotModel

__all__ = ["PostureBatch", "PostureSolver", "Stance", "pose_from_quaternion", "pose_matrix",
           "quaternion_from_matrix"]


def pose_matrix(xyz: np.ndarray, yaw_rad: float) -> np.ndarray:
    """4×4 homogeneous transform of a level frame at ``xyz`` [m] turned by ``yaw_rad`` about z."""
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    T = np.eye(4)
    T[0, 0], T[0, 1], T[1, 0], T[1, 1] = c, -s, s, c
    T[:3, 3] = xyz
    return T


def pose_from_quaternion(xyz, quat_xyzw) -> np.ndarray:
    """4×4 homogeneous transform from a position [m] and a unit quaternion (x, y, z, w)."""
    qx, qy, qz, qw = quat_xyzw
    T = np.eye(4)
    T[:3, :3] = [[1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
                 [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
                 [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)]]
    T[:3, 3] = xyz
    return T


def quaternion_from_matrix(R: np.ndarray) -> np.ndarray:
    """(x, y, z, w) of a rotation matrix (the inverse of :func:`pose_from_quaternion`'s rotation; w ≥ 0)."""
    w = np.sqrt(max(0.0, 1.0 + R[0, 0] + R[1, 1] + R[2, 2])) / 2.0
    x = np.copysign(np.sqrt(max(0.0, 1.0 + R[0, 0] - R[1, 1] - R[2, 2])) / 2.0, R[2, 1] - R[1, 2])
    y = np.copysign(np.sqrt(max(0.0, 1.0 - R[0, 0] + R[1, 1] - R[2, 2])) / 2.0, R[0, 2] - R[2, 0])
    z = np.copysign(np.sqrt(max(0.0, 1.0 - R[0, 0] - R[1, 1] + R[2, 2])) / 2.0, R[1, 0] - R[0, 1])
    return np.array([x, y, z, w])


@dataclass(frozen=True)
class Stance:
    """What a swing sample fixes: both sole poses and the body yaw (SI units)."""

    support_side: str  # 'left' or 'right'
    support_xyz: np.ndarray  # (3,) support sole centre [m]
    support_yaw: float  # [rad]
    swing_xyz: np.ndarray  # (3,) swing sole centre [m]
    swing_yaw: float  # [rad] (Precondition 2: 0, "forward")
    body_yaw: float  # trunk yaw [rad]

    @property
    def swing_side(self) -> str:
        return "left" if self.support_side == "right" else "right"

    @functools.cached_property
    def _foot_poses(self) -> dict[str, np.ndarray]:
        swing = "left" if self.support_side == "right" else "right"
        return {self.support_side: pose_matrix(self.support_xyz, self.support_yaw),
                swing: pose_matrix(self.swing_xyz, self.swing_yaw)}

    def foot_pose(self, side: str) -> np.ndarray:
        """4×4 pose of the ``side`` sole (computed once per stance; do not modify)."""
        return self._foot_poses[side]


@dataclass
class PostureBatch:
    """Postures for N candidate P_body: joints (N, 12) [rad], CoM (N, 3) [m], status (N,), residual [m]."""

    q: np.ndarray
    com: np.ndarray
    status: np.ndarray
    residual_m: np.ndarray
    iterations: np.ndarray | None = None  # (N,) IK iterations spent on each candidate (0: not run)


class PostureSolver(Protocol):
    """What every posture solver offers."""

    model: RobotModel
    evaluations: int  # candidates solved so far
    replay_log: list | None  # PlaCo only: IK runs recorded for the benchmark

    def solve_batch(self, stance: Stance, p_body: np.ndarray, warm: np.ndarray | None = None) -> PostureBatch:
        """Postures for candidates ``p_body`` (N, 3) [m] under ``stance``."""
        ...
