"""Kinematics: P_body and the body yaw to joint angles, CoM and a status, by PlaCo or in closed form.

One interface (:mod:`~jethr1_plan.kinematics.base`), two implementations: :mod:`.placo` (PlaCo's IK,
the default) and :mod:`.closed_form` (the legs in closed form, compiled; same postures to 1e-9 m).
"""

from __future__ import annotations

from jethr1_plan.geometry import pose_from_quaternion, pose_matrix
from jethr1_plan.kinematics.base import PostureBatch, PostureSolver, Stance
from jethr1_plan.robot.model import RobotModel

__all__ = ["KINEMATICS", "PostureBatch", "PostureSolver", "Stance", "make_posture_solver", "pose_from_quaternion",
           "pose_matrix"]

#: the solvers by the name ``--kinematics`` takes
KINEMATICS = ("placo", "analytic")


def make_posture_solver(model: RobotModel, kinematics: str = "placo") -> PostureSolver:
    """A posture solver: ``placo`` (PlaCo's KinematicsSolver) or ``analytic`` (closed form)."""
    if kinematics == "analytic":
        from jethr1_plan.kinematics.closed_form import ClosedFormPostureSolver

        return ClosedFormPostureSolver(model)
    if kinematics == "placo":
        from jethr1_plan.kinematics.placo import PlacoPostureSolver

        return PlacoPostureSolver(model)
    raise ValueError(f"unknown kinematics {kinematics!r}")
