"""``trajectory.csv``: a plan's columns (:mod:`.plan_table`), one header row and one row per output
sample, written and read here."""

from __future__ import annotations

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.files.plan_table import (
    BOOL_COLUMNS,
    INT_COLUMNS,
    TEXT_COLUMNS,
    columns,
    is_plan_column,
    plan_table,
)
from jethr1_plan.io.csv_table import csv_text, number_text, numbers_text, read_csv_table
from jethr1_plan.records.plan_rows import Rows
from jethr1_plan.robot.model import RobotModel

__all__ = ["CSV_FORMAT_VERSION", "read_trajectory_csv", "table_csv", "trajectory_csv"]

CSV_FORMAT_VERSION = 1


def table_csv(table: dict[str, np.ndarray], header: list[str]) -> str:
    """The CSV text of a plan's ``table`` with the columns of ``header``."""
    cells: list[list[str]] = []
    for name in header:
        col = table[name]
        if name in TEXT_COLUMNS:
            cells.append([str(v) for v in col])
        elif name in BOOL_COLUMNS:
            cells.append(["true" if v else "false" for v in col])
        elif name in INT_COLUMNS:
            cells.append([str(int(v)) for v in col])
        elif name == "time_s":  # times to 1e-9 s: the rows' clock, not its rounding
            cells.append([number_text(round(float(v), 9)) for v in col])
        else:
            cells.append(numbers_text(col.tolist()))
    return csv_text(header, zip(*cells, strict=True))


def trajectory_csv(robot: RobotModel, rows: Rows) -> str:
    """The CSV text of ``rows`` (a plan of ``robot``)."""
    return table_csv(plan_table(robot, rows), columns(robot))


def read_trajectory_csv(text: str, source: str = "trajectory.csv", robot: RobotModel | None = None,
                        complete: bool = False) -> dict[str, np.ndarray]:
    """A plan's trajectory CSV as its table (numbers as float arrays, NaN where empty).

    With ``robot``, every column must be one of that robot's plans (and with ``complete``, every one
    of them present); without, of any robot's.

    Raises:
        InputError: see :func:`~jethr1_plan.io.csv_table.read_csv_table`; a missing column.
    """
    known = set(columns(robot)) if robot is not None else None
    table = read_csv_table(text, source, (lambda h: h in known) if known is not None else is_plan_column,
                           TEXT_COLUMNS, BOOL_COLUMNS)
    if complete and robot is not None:
        missing = [k for k in columns(robot) if k not in table]
        if missing:
            raise InputError(source, "header", f"missing column {missing[0]!r}" + (
                f" and {len(missing) - 1} more" if len(missing) > 1 else ""))
    return table
