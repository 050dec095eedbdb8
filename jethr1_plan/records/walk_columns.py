"""The columns of a walk's ``trajectory.csv`` (``jethr1 walk``), stated once; the names a walk shares with a
plan (time, step, support, the trunk's pose, the CoM, the ZMP and its margin) are the plan's
(:mod:`.plan_columns`)."""

from __future__ import annotations

from jethr1_plan.geometry import SIDES
from jethr1_plan.records.plan_columns import (
    COM,
    PELVIS,
    PELVIS_QUAT,
    STEP,
    SUPPORT,
    TIME,
    ZMP,
    ZMP_MARGIN,
    cmd_column,
    joint_column,
    tau_column,
)
from jethr1_plan.robot.model import RobotModel

__all__ = ["COM_REF", "FIXED_HEAD", "FIXED_TAIL", "is_walk_column", "walk_columns"]

_XYZ = ("x", "y", "z")
COM_REF = ("com_ref_x_m", "com_ref_y_m")  # the LIPM's CoM [m]
#: the columns before the joints: time, step, support and the trunk's pose
FIXED_HEAD = (TIME, STEP, SUPPORT, *PELVIS, *PELVIS_QUAT)
#: the columns between the joints and their torques: the soles, CoM, ZMP, yaw, κ, knee bends and momenta
FIXED_TAIL = (*(f"{s}_foot_{a}_m" for s in SIDES for a in _XYZ), *COM, *COM_REF, *ZMP,
              "zmp_ref_x_m", "zmp_ref_y_m", "zmp_lipm_x_m", "zmp_lipm_y_m", ZMP_MARGIN, "friction_ratio",
              "yaw_ref_rad", "yaw_rad", "yaw_rate_rad_s", "kappa", *(f"kappa_leg_{s}" for s in SIDES),
              *(f"knee_bend_{s}_rad" for s in SIDES), "h_lower_nms", "h_upper_nms")


def walk_columns(robot: RobotModel) -> list[str]:
    """The header of a walk's ``trajectory.csv`` for ``robot``."""
    return [*FIXED_HEAD, *(joint_column(j) for j in robot.joint_names), *FIXED_TAIL,
            *(tau_column(j) for j in robot.joint_names), *(cmd_column(j) for j in robot.joint_names)]


def is_walk_column(name: str) -> bool:
    """A column some robot's walk has (joints by name)."""
    return name in FIXED_HEAD or name in FIXED_TAIL or (name.endswith(("_rad", "_tau_nm", "_cmd_rad"))
                                                        and len(name) > 7)
