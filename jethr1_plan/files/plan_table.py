"""The columns of a plan (named in :mod:`jethr1_plan.records.plan_columns`) and the planner's rows
(:class:`~jethr1_plan.records.plan_rows.Rows`) as those columns: the *table* every file of a plan
carries, a dict from column name to a (rows,) array (floats, NaN where a cell is empty; text columns
as object arrays; ``feasible`` as bool)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from jethr1_plan.geometry import yaw_quaternion
from jethr1_plan.records.plan_columns import (
    BOOL_COLUMNS,
    COM,
    FEASIBLE,
    FIXED_COLUMNS,
    INT_COLUMNS,
    KAPPA,
    PELVIS,
    PELVIS_QUAT,
    PHASE,
    REASON,
    SAMPLE,
    STEP,
    SUPPORT,
    SWING,
    TEXT_COLUMNS,
    TIME,
    TOLERANCE_SHARE,
    WINDOW,
    YAW_MOMENTUM,
    ZMP,
    ZMP_MARGIN,
    cmd_column,
    columns,
    fan_matrix,
    is_plan_column,
    joint_column,
    joint_matrix,
    plan_columns,
    stack,
    tau_column,
    thrust_cmd_column,
    thrust_column,
)
from jethr1_plan.records.plan_rows import RowField, Rows
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


def plan_table(robot: RobotModel, rows: Rows) -> dict[str, np.ndarray]:
    """The planner's ``rows`` as the plan's columns (the table every file of a plan carries)."""
    c = rows.columns
    n = len(rows)
    joints = robot.joint_names
    out: dict[str, np.ndarray] = {
        TIME: np.asarray(c[RowField.TIME_S], dtype=float),
        STEP: np.asarray(c[RowField.STEP], dtype=int),
        PHASE: np.asarray(c[RowField.PHASE], dtype=object),
        SAMPLE: np.asarray(c[RowField.SAMPLE], dtype=int),
        SUPPORT: np.asarray(c[RowField.SUPPORT], dtype=object),
        FEASIBLE: np.asarray(c[RowField.FEASIBLE], dtype=bool),
        REASON: np.asarray(c[RowField.REASON], dtype=object),
    }

    def put(names: Sequence[str], key: RowField) -> None:
        values = np.asarray(c[key], dtype=float).reshape(n, len(names))
        for k, name in enumerate(names):
            out[name] = values[:, k]

    put(PELVIS, RowField.P_BODY_M)
    quat = np.array([yaw_quaternion(y) for y in c[RowField.YAW_RAD]], dtype=float).reshape(n, 4)
    for k, name in enumerate(PELVIS_QUAT):
        out[name] = quat[:, k]
    put([joint_column(j) for j in joints], RowField.Q_RAD)
    put(SWING, RowField.SWING_M)
    put([thrust_column(f.name) for f in robot.fans], RowField.THRUST_N)
    put(COM, RowField.COM_M)
    put(ZMP, RowField.ZMP_M)
    put(WINDOW, RowField.WINDOW_N)
    out[ZMP_MARGIN] = np.asarray(c[RowField.ZMP_MARGIN_M], dtype=float)
    out[TOLERANCE_SHARE] = np.asarray(c[RowField.TOLERANCE_SHARE], dtype=float)
    put([tau_column(j) for j in joints], RowField.TAU_NM)
    put(KAPPA, RowField.KAPPA)
    out[YAW_MOMENTUM] = np.asarray(c[RowField.YAW_MOMENTUM_NMS], dtype=float)
    put([cmd_column(j) for j in joints], RowField.Q_CMD_RAD)
    put([thrust_cmd_column(f.name) for f in robot.fans], RowField.THRUST_CMD_N)
    return {k: out[k] for k in columns(robot)}
