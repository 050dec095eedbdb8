"""The columns of a plan, stated once: names (units as suffixes), order, and where each comes from
in the planner's rows (:class:`~jethr1_plan.planning.sequence.Rows`).

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

from jethr1_plan.geometry import yaw_quaternion
from jethr1_plan.planning.sequence import Rows
from jethr1_plan.robot.model import RobotModel

__all__ = [
    "BOOL_COLUMNS",
    "FIXED_COLUMNS",
    "INT_COLUMNS",
    "TEXT_COLUMNS",
    "columns",
    "fan_matrix",
    "is_plan_column",
    "joint_matrix",
    "plan_columns",
    "plan_table",
    "stack",
]

TEXT_COLUMNS = ("phase", "support", "reason")
BOOL_COLUMNS = ("feasible",)
INT_COLUMNS = ("step", "sample")


def plan_columns(joints: Sequence[str], fans: Sequence[str]) -> list[str]:
    """The header of a plan whose robot has these joints (URDF names, in order) and fans (by name)."""
    return ["time_s", "step", "phase", "sample", "support", "feasible",
            "pelvis_x_m", "pelvis_y_m", "pelvis_z_m", "pelvis_qx", "pelvis_qy", "pelvis_qz", "pelvis_qw",
            *(f"{j}_rad" for j in joints),
            "swing_x_m", "swing_y_m", "swing_z_m", *(f"thrust_{f}_n" for f in fans),
            "com_x_m", "com_y_m", "com_z_m", "zmp_x_m", "zmp_y_m",
            "thrust_window_lo_n", "thrust_window_hi_n", "zmp_margin_m", "tolerance_share",
            *(f"{j}_tau_nm" for j in joints), "kappa_left", "kappa_right", "yaw_momentum_nms",
            *(f"{j}_cmd_rad" for j in joints), *(f"thrust_cmd_{f}_n" for f in fans), "reason"]


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


def plan_table(robot: RobotModel, rows: Rows) -> dict[str, np.ndarray]:
    """The planner's ``rows`` as the plan's columns (the table every file of a plan carries)."""
    c = rows.columns
    n = len(rows)
    joints = robot.joint_names
    out: dict[str, np.ndarray] = {
        "time_s": np.asarray(c["time_s"], dtype=float),
        "step": np.asarray(c["step"], dtype=int),
        "phase": np.asarray(c["phase"], dtype=object),
        "sample": np.asarray(c["sample"], dtype=int),
        "support": np.asarray(c["support"], dtype=object),
        "feasible": np.asarray(c["feasible"], dtype=bool),
        "reason": np.asarray(c["reason"], dtype=object),
    }

    def put(names: Sequence[str], key: str) -> None:
        values = np.asarray(c[key], dtype=float).reshape(n, len(names))
        for k, name in enumerate(names):
            out[name] = values[:, k]

    put(("pelvis_x_m", "pelvis_y_m", "pelvis_z_m"), "p_body")
    quat = np.array([yaw_quaternion(y) for y in c["yaw"]], dtype=float).reshape(n, 4)
    for k, a in enumerate("xyzw"):
        out[f"pelvis_q{a}"] = quat[:, k]
    put([f"{j}_rad" for j in joints], "q")
    put(("swing_x_m", "swing_y_m", "swing_z_m"), "swing")
    for f in robot.fans:
        out[f"thrust_{f.name}_n"] = np.asarray(c[f"thrust_{f.name}"], dtype=float)
    put(("com_x_m", "com_y_m", "com_z_m"), "com")
    put(("zmp_x_m", "zmp_y_m"), "zmp")
    put(("thrust_window_lo_n", "thrust_window_hi_n"), "window")
    out["zmp_margin_m"] = np.asarray(c["zmp_margin"], dtype=float)
    out["tolerance_share"] = np.asarray(c["tolerance_share"], dtype=float)
    put([f"{j}_tau_nm" for j in joints], "tau")
    put(("kappa_left", "kappa_right"), "kappa")
    out["yaw_momentum_nms"] = np.asarray(c["yaw_momentum"], dtype=float)
    put([f"{j}_cmd_rad" for j in joints], "q_cmd")
    for f in robot.fans:
        out[f"thrust_cmd_{f.name}_n"] = np.asarray(c[f"thrust_cmd_{f.name}"], dtype=float)
    return {k: out[k] for k in columns(robot)}
