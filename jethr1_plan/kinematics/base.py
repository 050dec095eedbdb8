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

from jethr1_plan.geometry import other_side, pose_matrix
from jethr1_plan.robot.model import RobotModel

__all__ = ["PostureBatch", "PostureSolver", "Stance",]


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
        return other_side(self.support_side)

    @functools.cached_property
    def _foot_poses(self) -> dict[str, np.ndarray]:
        swing = other_side(self.support_side)
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
