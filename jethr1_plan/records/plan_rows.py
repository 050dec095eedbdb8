"""The plan's rows at the output rate, as the planner builds them: one value per row of each of a
fixed set of fields (:class:`RowField`, units in their names), appended a row at a time
(:meth:`Rows.append`: every field named, no other), then Paper B's per-row analysis added once
(:meth:`Rows.set_analysis`). ``files.plan_table`` turns them into the plan's columns."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np

from jethr1_plan.records.plan_columns import (
    FEASIBLE,
    PHASE,
    REASON,
    SAMPLE,
    STEP,
    SUPPORT,
    TIME,
    TOLERANCE_SHARE,
    YAW_MOMENTUM,
    ZMP_MARGIN,
)

__all__ = ["ANALYSIS_FIELDS", "ROW_FIELDS", "RowField", "Rows"]


class RowField(StrEnum):
    """The fields of a planned row (per-row arrays: (3,) positions [m], (J,) joints, (F,) fans)."""

    TIME_S = TIME  # [s]
    STEP = STEP
    PHASE = PHASE  # swing / transfer
    SAMPLE = SAMPLE  # the swing sample, or the transfer row's index
    SUPPORT = SUPPORT  # left / right / both
    FEASIBLE = FEASIBLE
    GROUND_Z_M = "ground_z_m"  # the support's height (the lower sole in transfers) [m]
    P_BODY_M = "p_body_m"  # (3,) P_body [m]
    YAW_RAD = "yaw_rad"  # the trunk's yaw [rad]
    Q_RAD = "q_rad"  # (J,) joint angles [rad]
    SWING_M = "swing_m"  # (3,) the swing sole [m] (NaN in transfers)
    COM_M = "com_m"  # (3,) the centre of mass [m]
    ZMP_M = "zmp_m"  # (2,) the ZMP [m]
    WINDOW_N = "window_n"  # (lo, hi) the thrust window [N] (NaN: none)
    ZMP_MARGIN_M = ZMP_MARGIN  # [m]
    TOLERANCE_SHARE = TOLERANCE_SHARE  # NaN under the minimal policy
    THRUST_N = "thrust_n"  # (F,) per fan [N]
    REASON = REASON  # "" on feasible rows
    TAU_NM = "tau_nm"  # (J,) static joint torques [N·m] (analysis)
    KAPPA = "kappa"  # (2,) κ of the left and right leg (analysis)
    YAW_MOMENTUM_NMS = YAW_MOMENTUM  # [N·m·s] (analysis)
    Q_CMD_RAD = "q_cmd_rad"  # (J,) servo commands [rad] (analysis)
    THRUST_CMD_N = "thrust_cmd_n"  # (F,) fan commands [N] (analysis)


#: the fields every row is appended with
ROW_FIELDS = tuple(RowField)[:18]
#: the fields Paper B's analysis adds to the whole sequence at once
ANALYSIS_FIELDS = tuple(RowField)[18:]


@dataclass
class Rows:
    """The output rows (one list per field). Lengths grow as rows are appended; :meth:`truncate` drops the
    rows after a point (a phase built again)."""

    fans: tuple[str, ...] = ()  # the robot's fans, in order (the (F,) fields)
    columns: dict[RowField, list] = field(default_factory=lambda: {k: [] for k in ROW_FIELDS})
    analysis: dict = field(default_factory=dict)  # whole-trajectory figures (energy, torque ratios, dynamics)
    paced: list[dict] = field(default_factory=list)  # the swings re-timed by ``sequence.pace_swing``, in order
    timed: list[dict] = field(default_factory=list)  # the phases timed fastest (``planning.fast_timing``), in order

    def append(self, *, time_s: float, step: int, phase: str, sample: int, support: str, feasible: bool,
               ground_z_m: float, p_body_m: np.ndarray, yaw_rad: float, q_rad: np.ndarray, swing_m: np.ndarray,
               com_m: np.ndarray, zmp_m: np.ndarray, window_n: tuple[float, float], zmp_margin_m: float,
               tolerance_share: float, thrust_n: np.ndarray, reason: str) -> None:
        """One row, every field given."""
        values = (time_s, step, phase, sample, support, feasible, ground_z_m, p_body_m, yaw_rad, q_rad, swing_m,
                  com_m, zmp_m, window_n, zmp_margin_m, tolerance_share, thrust_n, reason)
        for k, v in zip(ROW_FIELDS, values, strict=True):
            self.columns[k].append(v)

    def set_analysis(self, tau_nm: np.ndarray, kappa: np.ndarray, yaw_momentum_nms: np.ndarray,
                     q_cmd_rad: np.ndarray, thrust_cmd_n: np.ndarray) -> None:
        """Paper B's per-row figures and the commands, (rows, ...) each."""
        for k, v in zip(ANALYSIS_FIELDS, (tau_nm, kappa, yaw_momentum_nms, q_cmd_rad, thrust_cmd_n), strict=True):
            self.columns[k] = list(v)

    @property
    def analysed(self) -> bool:
        """Whether :meth:`set_analysis` has added its fields."""
        return RowField.TAU_NM in self.columns

    def truncate(self, n: int) -> None:
        """Keep the first ``n`` rows."""
        for col in self.columns.values():
            del col[n:]

    def __len__(self) -> int:
        return len(self.columns[RowField.TIME_S])

    def array(self, key: RowField) -> np.ndarray:
        """The field as an array ((rows,) or (rows, ...))."""
        return np.asarray(self.columns[key])

    def fan_array(self, key: RowField = RowField.THRUST_N) -> np.ndarray:
        """(rows, F) a per-fan field [N] (``THRUST_N`` or ``THRUST_CMD_N``)."""
        return np.asarray(self.columns[key], dtype=float).reshape(len(self), len(self.fans))

    def fan(self, name: str, key: RowField = RowField.THRUST_N) -> np.ndarray:
        """(rows,) one fan's thrust (or command) [N]."""
        return self.fan_array(key)[:, self.fans.index(name)]
