"""The columns of a plan, stated once: names (units as suffixes) and order.

``trajectory.csv`` and ``trajectory.mcap`` carry exactly these columns, and every reader of a plan
(``verify``, ``simulate``, the route, the viewers' export) reads them back into the same *table*: a
dict from column name to a (rows,) array (floats, NaN where a cell is empty; text columns as object
arrays; ``feasible`` as bool).

Per row: ``time_s`` [s], ``step``, ``phase`` (swing/transfer), ``sample``, ``support``
(left/right/both), ``feasible``; the trunk pose ``pelvis_{x,y,z}_m`` and quaternion
``pelvis_q{x,y,z,w}``; the joints ``<joint>_rad`` in URDF order; the swing sole's sample
``swing_{x,y,z}_m`` (empty in transfers); per fan ``thrust_<fan>_n``; ``com_{x,y,z}_m``,
``zmp_{x,y}_m``; the thrust window ``thrust_window_{lo,hi}_n`` (empty where none balances),
``zmp_margin_m`` and ``tolerance_share`` (the largest share of the plan's tolerance under which the
row's posture and thrust keep the ZMP in the support, at most 1; empty under the minimal policy);
Paper B's ``<joint>_tau_nm``, ``kappa_{left,right}``, ``yaw_momentum_nms``; the commands
``<joint>_cmd_rad`` and ``thrust_cmd_<fan>_n``; ``reason`` (empty on feasible rows).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from jethr1_plan.robot.model import RobotModel

__all__ = [
    "BOOL_COLUMNS",
    "COM",
    "FEASIBLE",
    "FIXED_COLUMNS",
    "INT_COLUMNS",
    "KAPPA",
    "PELVIS",
    "PELVIS_QUAT",
    "PHASE",
    "REASON",
    "SAMPLE",
    "SHARED_WORDS",
    "STEP",
    "SUPPORT",
    "SWING",
    "TEXT_COLUMNS",
    "TIME",
    "TOLERANCE_SHARE",
    "WINDOW",
    "YAW_MOMENTUM",
    "ZMP",
    "ZMP_MARGIN",
    "cmd_column",
    "columns",
    "fan_matrix",
    "is_plan_column",
    "joint_column",
    "joint_matrix",
    "plan_columns",
    "stack",
    "tau_column",
    "thrust_cmd_column",
    "thrust_column",
]

TIME, STEP, PHASE, SAMPLE, SUPPORT, FEASIBLE, REASON = "time_s", "step", "phase", "sample", "support", "feasible", \
    "reason"
PELVIS = ("pelvis_x_m", "pelvis_y_m", "pelvis_z_m")  # the trunk's position [m]
PELVIS_QUAT = ("pelvis_qx", "pelvis_qy", "pelvis_qz", "pelvis_qw")  # the trunk's orientation (x, y, z, w)
SWING = ("swing_x_m", "swing_y_m", "swing_z_m")  # the swing sole's sample [m] (empty in transfers)
COM = ("com_x_m", "com_y_m", "com_z_m")  # the centre of mass [m]
ZMP = ("zmp_x_m", "zmp_y_m")  # the ZMP [m]
WINDOW = ("thrust_window_lo_n", "thrust_window_hi_n")  # the thrust window [N]
ZMP_MARGIN = "zmp_margin_m"  # the ZMP's distance inside the support [m]
TOLERANCE_SHARE = "tolerance_share"  # the row's share of the plan's tolerance (NaN: the minimal policy)
KAPPA = ("kappa_left", "kappa_right")  # Paper B's κ of each leg
YAW_MOMENTUM = "yaw_momentum_nms"  # the yaw momentum [N·m·s]

#: the columns whose names are also ordinary words of other records (summary.json's ``first_infeasible`` and
#: ``*_at`` records, the walk's columns, the messages' fields): ``tools/check_vocabulary.py`` counts the
#: literals of every other column name
SHARED_WORDS = (TIME, STEP, PHASE, SAMPLE, SUPPORT, FEASIBLE, REASON)

TEXT_COLUMNS = (PHASE, SUPPORT, REASON)
BOOL_COLUMNS = (FEASIBLE,)
INT_COLUMNS = (STEP, SAMPLE)


def joint_column(joint: str) -> str:
    """The angle of ``joint`` [rad]."""
    return f"{joint}_rad"


def tau_column(joint: str) -> str:
    """The static torque of ``joint`` [N·m]."""
    return f"{joint}_tau_nm"


def cmd_column(joint: str) -> str:
    """The servo command of ``joint`` [rad]."""
    return f"{joint}_cmd_rad"


def thrust_column(fan: str) -> str:
    """The thrust of ``fan`` [N]."""
    return f"thrust_{fan}_n"


def thrust_cmd_column(fan: str) -> str:
    """The thrust command of ``fan`` [N]."""
    return f"thrust_cmd_{fan}_n"


def plan_columns(joints: Sequence[str], fans: Sequence[str]) -> list[str]:
    """The header of a plan whose robot has these joints (URDF names, in order) and fans (by name)."""
    return [TIME, STEP, PHASE, SAMPLE, SUPPORT, FEASIBLE, *PELVIS, *PELVIS_QUAT,
            *(joint_column(j) for j in joints),
            *SWING, *(thrust_column(f) for f in fans), *COM, *ZMP, *WINDOW, ZMP_MARGIN, TOLERANCE_SHARE,
            *(tau_column(j) for j in joints), *KAPPA, YAW_MOMENTUM,
            *(cmd_column(j) for j in joints), *(thrust_cmd_column(f) for f in fans), REASON]


def columns(robot: RobotModel) -> list[str]:
    """The header of a plan of ``robot``."""
    return plan_columns(robot.joint_names, [f.name for f in robot.fans])


#: the columns every plan has, whatever its robot
FIXED_COLUMNS = frozenset(plan_columns((), ()))


def is_plan_column(name: str) -> bool:
    """A column some robot's plan has (joints and fans by name)."""
    return name in FIXED_COLUMNS or (name.endswith(("_rad", "_tau_nm")) and len(name) > 7) or (
        name.startswith("thrust_") and name.endswith("_n") and len(name) > 9)


def stack(table: dict[str, np.ndarray], names: Sequence[str]) -> np.ndarray:
    """(rows, len(names)) floats of the named columns."""
    return np.column_stack([np.asarray(table[k], dtype=float) for k in names]).reshape(-1, len(names))


def joint_matrix(table: dict[str, np.ndarray], robot: RobotModel, suffix: str = "_rad") -> np.ndarray:
    """(rows, J) of the per-joint columns ``<joint><suffix>`` (``_rad``, ``_tau_nm``, ``_cmd_rad``)."""
    return stack(table, [f"{j}{suffix}" for j in robot.joint_names])


def fan_matrix(table: dict[str, np.ndarray], robot: RobotModel, prefix: str = "thrust_") -> np.ndarray:
    """(rows, F) of the per-fan columns ``<prefix><fan>_n`` (``thrust_``, ``thrust_cmd_``)."""
    return stack(table, [f"{prefix}{f.name}_n" for f in robot.fans])
