"""``trajectory.csv``: one header row, one row per output sample, units in column names (CONTRACT.md)."""

from __future__ import annotations

import io
import math

import numpy as np

from jethr1_plan.planning.sequence import Rows
from jethr1_plan.robot.model import RobotModel

__all__ = [
    "CSV_FORMAT_VERSION",
    "FIXED_COLUMNS",
    "MAX_CSV_BYTES",
    "TEXT_COLUMNS",
    "columns",
    "number_text",
    "read_csv_table",
    "read_trajectory_csv",
    "trajectory_csv",
    "yaw_quaternion",
]

CSV_FORMAT_VERSION = 1


def yaw_quaternion(yaw_rad: float) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) of a rotation by ``yaw_rad`` about z."""
    return 0.0, 0.0, math.sin(yaw_rad / 2), math.cos(yaw_rad / 2)


def columns(robot: RobotModel) -> list[str]:
    """The CSV header of a plan of ``robot``, in order: joints by their URDF names, fans by their names."""
    joints = robot.joint_names
    fans = [f.name for f in robot.fans]
    return ["time_s", "step", "phase", "sample", "support", "feasible",
            "pelvis_x_m", "pelvis_y_m", "pelvis_z_m", "pelvis_qx", "pelvis_qy", "pelvis_qz", "pelvis_qw",
            *(f"{j}_rad" for j in joints),
            "swing_x_m", "swing_y_m", "swing_z_m", *(f"thrust_{f}_n" for f in fans),
            "com_x_m", "com_y_m", "com_z_m", "zmp_x_m", "zmp_y_m",
            "thrust_window_lo_n", "thrust_window_hi_n", "zmp_margin_m",
            *(f"{j}_tau_nm" for j in joints), "kappa_left", "kappa_right", "yaw_momentum_nms",
            *(f"{j}_cmd_rad" for j in joints), *(f"thrust_cmd_{f}_n" for f in fans), "reason"]


#: the columns every plan has, whatever its robot
FIXED_COLUMNS = frozenset(("time_s", "step", "phase", "sample", "support", "feasible", "pelvis_x_m", "pelvis_y_m",
                           "pelvis_z_m", "pelvis_qx", "pelvis_qy", "pelvis_qz", "pelvis_qw", "swing_x_m", "swing_y_m",
                           "swing_z_m", "com_x_m", "com_y_m", "com_z_m", "zmp_x_m", "zmp_y_m", "thrust_window_lo_n",
                           "thrust_window_hi_n", "zmp_margin_m", "kappa_left", "kappa_right", "yaw_momentum_nms",
                           "reason"))


def _known(name: str) -> bool:
    """A column some robot's plan has (joints and fans by name)."""
    return name in FIXED_COLUMNS or (name.endswith(("_rad", "_tau_nm")) and len(name) > 7) or (
        name.startswith("thrust_") and name.endswith("_n") and len(name) > 9)


def number_text(x: float) -> str:
    """Shortest round-tripping text of a float; empty for NaN (no value, e.g. no swing foot)."""
    x = float(x)
    if math.isnan(x):
        return ""
    return repr(x) if x != 0 else "0.0"


def trajectory_csv(robot: RobotModel, rows: Rows) -> str:
    """The CSV text of ``rows`` (a plan of ``robot``)."""
    out = io.StringIO()
    out.write(",".join(columns(robot)) + "\n")
    c = rows.columns
    num = number_text
    fans = [f.name for f in robot.fans]
    for i in range(len(rows)):
        qx, qy, qz, qw = yaw_quaternion(c["yaw"][i])
        vals = [num(round(c["time_s"][i], 9)), str(c["step"][i]), c["phase"][i], str(c["sample"][i]), c["support"][i],
                "true" if c["feasible"][i] else "false", *map(num, c["p_body"][i]), *map(num, (qx, qy, qz, qw)),
                *map(num, np.asarray(c["q"][i])), *map(num, c["swing"][i]), *(num(c[f"thrust_{f}"][i]) for f in fans),
                *map(num, c["com"][i]), *map(num, c["zmp"][i]),
                *map(num, c["window"][i]), num(c["zmp_margin"][i]),
                *map(num, c["tau"][i]), num(c["kappa"][i][0]), num(c["kappa"][i][1]), num(c["yaw_momentum"][i]),
                *map(num, c["q_cmd"][i]), *(num(c[f"thrust_cmd_{f}"][i]) for f in fans),
                c["reason"][i]]
        out.write(",".join(vals) + "\n")
    return out.getvalue()


TEXT_COLUMNS = ("phase", "support", "reason")
MAX_CSV_BYTES = 200_000_000  # a trajectory is ~1 MB per 1,000 rows; anything larger is not one


def read_trajectory_csv(text: str, source: str = "trajectory.csv", robot: RobotModel | None = None
                        ) -> dict[str, np.ndarray]:
    """Parse a plan's trajectory CSV into columns (numbers as float arrays, NaN where empty).

    With ``robot``, every column must be one of that robot's plans; without, of any robot's.

    Raises:
        InputError: see :func:`read_csv_table`.
    """
    known = set(columns(robot)) if robot is not None else None
    return read_csv_table(text, source, (lambda h: h in known) if known is not None else _known, TEXT_COLUMNS,
                          ("feasible",))


def read_csv_table(text: str, source: str, known, text_columns: tuple[str, ...] = (),
                   bool_columns: tuple[str, ...] = ()) -> dict[str, np.ndarray]:
    """Columns of a CSV text whose header names are all ``known`` (a predicate): text columns as
    object arrays, true/false columns as bool, the others as floats (NaN where empty).

    Raises:
        InputError: a header that is not this format's, a row with the wrong number of cells (a file
            cut mid-line), a number that does not parse, a boolean that is not true/false.
    """
    from jethr1_plan.errors import InputError

    if len(text) > MAX_CSV_BYTES:
        raise InputError(source, "", f"{len(text)} characters: larger than any trajectory ({MAX_CSV_BYTES})")
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    if not lines:
        raise InputError(source, "header", "empty file")
    header = lines[0].split(",")
    unknown = [h for h in header if not known(h)]
    if unknown:
        raise InputError(source, "header", f"unknown column {_short(unknown[0])!r}")
    if len(set(header)) != len(header):
        raise InputError(source, "header", "a column appears twice")
    cells = []
    for n, line in enumerate(lines[1:], start=1):
        row = line.split(",")
        if len(row) != len(header):
            raise InputError(source, f"row {n}", f"{len(row)} cells, the header has {len(header)} (a cut or "
                             "edited line?)")
        cells.append(row)
    out: dict[str, np.ndarray] = {}
    for k, name in enumerate(header):
        col = [r[k] for r in cells]
        if name in text_columns:
            out[name] = np.array(col, dtype=object)
        elif name in bool_columns:
            bad = next((i for i, v in enumerate(col) if v not in ("true", "false")), None)
            if bad is not None:
                raise InputError(source, f"row {bad + 1} {name}", f"{_short(col[bad])!r} is not true or false")
            out[name] = np.array([v == "true" for v in col], dtype=bool)
        else:
            values = np.empty(len(col))
            for i, v in enumerate(col):
                try:
                    values[i] = float(v) if v != "" else np.nan
                except ValueError:
                    raise InputError(source, f"row {i + 1} {name}", f"{_short(v)!r} is not a number") from None
            out[name] = values
    return out


def _short(text: str, limit: int = 40) -> str:
    """At most ``limit`` characters of ``text`` (error messages never print a long value)."""
    return text if len(text) <= limit else text[:limit] + "..."
