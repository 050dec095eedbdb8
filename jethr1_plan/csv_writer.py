"""``trajectory.csv``: one header row, one row per output sample, units in column names (CONTRACT.md)."""

from __future__ import annotations

import io
import math

import numpy as np

from .robot_model import JOINT_NAMES
from .sequence import Rows

CSV_FORMAT_VERSION = 1


def yaw_quaternion(yaw_rad: float) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) of a rotation by ``yaw_rad`` about z."""
    return 0.0, 0.0, math.sin(yaw_rad / 2), math.cos(yaw_rad / 2)


def columns() -> list[str]:
    """The CSV header, in order."""
    return ["time_s", "step", "phase", "sample", "support", "feasible",
            "pelvis_x_m", "pelvis_y_m", "pelvis_z_m", "pelvis_qx", "pelvis_qy", "pelvis_qz", "pelvis_qw",
            *(f"{j}_rad" for j in JOINT_NAMES),
            "swing_x_m", "swing_y_m", "swing_z_m", "thrust_left_n", "thrust_right_n",
            "com_x_m", "com_y_m", "com_z_m", "zmp_x_m", "zmp_y_m",
            "thrust_window_lo_n", "thrust_window_hi_n", "zmp_margin_m",
            *(f"{j}_tau_nm" for j in JOINT_NAMES), "kappa_left", "kappa_right", "yaw_momentum_nms",
            *(f"{j}_cmd_rad" for j in JOINT_NAMES), "thrust_cmd_left_n", "thrust_cmd_right_n", "reason"]


def _num(x: float) -> str:
    """Shortest round-tripping text of a float; empty for NaN (no value, e.g. no swing foot)."""
    x = float(x)
    if math.isnan(x):
        return ""
    return repr(x) if x != 0 else "0.0"


def trajectory_csv(rows: Rows) -> str:
    """The CSV text of ``rows``."""
    out = io.StringIO()
    out.write(",".join(columns()) + "\n")
    c = rows.columns
    for i in range(len(rows)):
        qx, qy, qz, qw = yaw_quaternion(c["yaw"][i])
        vals = [_num(round(c["time_s"][i], 9)), str(c["step"][i]), c["phase"][i], str(c["sample"][i]), c["support"][i],
                "true" if c["feasible"][i] else "false", *map(_num, c["p_body"][i]), *map(_num, (qx, qy, qz, qw)),
                *map(_num, np.asarray(c["q"][i])), *map(_num, c["swing"][i]), _num(c["thrust_left"][i]),
                _num(c["thrust_right"][i]), *map(_num, c["com"][i]), *map(_num, c["zmp"][i]),
                *map(_num, c["window"][i]), _num(c["zmp_margin"][i]),
                *map(_num, c["tau"][i]), _num(c["kappa"][i][0]), _num(c["kappa"][i][1]), _num(c["yaw_momentum"][i]),
                *map(_num, c["q_cmd"][i]), _num(c["thrust_cmd_left"][i]), _num(c["thrust_cmd_right"][i]),
                c["reason"][i]]
        out.write(",".join(vals) + "\n")
    return out.getvalue()


def read_trajectory_csv(text: str) -> dict[str, np.ndarray]:
    """Parse a trajectory CSV into columns (numbers as float arrays, NaN where empty)."""
    lines = text.strip("\n").split("\n")
    header = lines[0].split(",")
    cells = [ln.split(",") for ln in lines[1:]]
    out: dict[str, np.ndarray] = {}
    for k, name in enumerate(header):
        col = [r[k] for r in cells]
        if name in ("phase", "support", "reason"):
            out[name] = np.array(col, dtype=object)
        elif name == "feasible":
            out[name] = np.array([v == "true" for v in col])
        else:
            out[name] = np.array([float(v) if v != "" else np.nan for v in col])
    return out
