"""The swings' pacing: the multibody ZMP of the rows' own motion (``physics.row_dynamics``), and a swing
re-timed (:func:`pace_swing`) where it comes within ``balance.sole_margin_m`` of the sole's edge."""

from __future__ import annotations

import numpy as np

from jethr1_plan.control.time_laws import paced_row_positions
from jethr1_plan.physics.row_dynamics import RowDynamics, row_dynamics
from jethr1_plan.planning.sequence import SequenceBuilder
from jethr1_plan.records.plan_rows import RowField, Rows
from jethr1_plan.robot.model import RobotModel

__all__ = ["GRIP_SAFETY", "PACE_ACCEL", "pace_swing", "rows_dynamics", "swing_dynamic_margin"]


def rows_dynamics(rows: Rows, robot: RobotModel, dt: float, start: int = 0, stop: int | None = None) -> RowDynamics:
    """The multibody ZMP rows ``start:stop`` need (``physics.row_dynamics``; the robot held still beyond
    them): Paper A's balance is quasistatic, and this is how far the rows' own motion moves the ZMP from it."""
    c = rows.columns
    p = np.asarray(c[RowField.P_BODY_M][start:stop], dtype=float)
    yaw = np.asarray(c[RowField.YAW_RAD][start:stop], dtype=float)
    base = np.zeros((len(p), 4, 4))
    base[:, 0, 0], base[:, 0, 1], base[:, 1, 0], base[:, 1, 1] = np.cos(yaw), -np.sin(yaw), np.sin(yaw), np.cos(yaw)
    base[:, 2, 2] = base[:, 3, 3] = 1.0
    base[:, :3, 3] = p
    thrust = rows.fan_array()[start:stop]
    return row_dynamics(robot, base, np.asarray(c[RowField.Q_RAD][start:stop], dtype=float), thrust,
                        np.asarray(c[RowField.SUPPORT][start:stop]), dt)


#: the trunk accelerations [m/s²] a paced swing is tried with, in order (:func:`pace_swing`)
PACE_ACCEL = (0.4, 0.2, 0.1, 0.05)
GRIP_SAFETY = 2.0  # the rows' motion may need at most μ / this of friction


def _note_pace(seq: SequenceBuilder, start: int, accel: float | None, least: float, held: bool) -> None:
    """summary.json's record of a paced swing (``dynamics.paced_swings``): its step, the trunk acceleration
    [m/s²] of its time law (None: the minimum-jerk law was kept, no pace doing better), the least multibody ZMP
    margin [m] of its rows, and whether that margin reaches ``balance.sole_margin_m``."""
    seq.rows.paced.append({"step": int(seq.rows.columns[RowField.STEP][start]), "trunk_accel_m_s2": accel,
                           "least_zmp_margin_m": least, "margin_held": held})


def swing_dynamic_margin(seq: SequenceBuilder, start: int) -> np.ndarray:
    """(rows,) the multibody ZMP's margin in the support [m] of the swing rows written from row ``start``
    on (the row before them in the stencil; the last held)."""
    return _swing_dynamics(seq, start)[0]


def _swing_dynamics(seq: SequenceBuilder, start: int) -> tuple[np.ndarray, np.ndarray]:
    """(margin [m], friction ratio [1]) per swing row written from row ``start`` on (as
    :func:`swing_dynamic_margin`)."""
    lo = max(start - 1, 0)
    dyn = rows_dynamics(seq.rows, seq.robot, seq.dt, lo)
    return dyn.margin[start - lo:], dyn.friction_ratio[start - lo:]


def _holds(seq: SequenceBuilder, start: int, margin_m: float) -> tuple[bool, float]:
    """Whether the swing rows from ``start`` keep the multibody ZMP ``margin_m`` inside the support and need
    at most μ / :data:`GRIP_SAFETY` of friction; and their least margin [m]."""
    margin, friction = _swing_dynamics(seq, start)
    least = float(np.min(margin))
    grip = float(np.max(friction[:-1], initial=0.0))  # (the last row's stencil holds: the transfer judges it)
    return least >= margin_m and grip <= seq.robot.sole_friction / GRIP_SAFETY, least


def pace_swing(seq: SequenceBuilder, snap: tuple, build, p_samples: np.ndarray, duration_s: float,
               margin_m: float, strict: bool = True) -> float | None:
    """Re-time a swing whose rows' own motion moves the multibody ZMP to within ``margin_m`` [m] of the
    support sole's edge (or beyond), or needs more than μ / :data:`GRIP_SAFETY` of the soles' friction.
    ``build(positions)`` writes the swing (``positions`` None: the minimum-jerk law) after ``snap``; it is
    rebuilt paced (:func:`paced_row_positions` of ``p_samples`` (N, 3) over ``duration_s``) for each trunk
    acceleration of :data:`PACE_ACCEL` in turn, and the first whose rows all hold quasistatically, with the
    multibody ZMP ``margin_m`` inside and the friction within its bound, is kept. Where none is, the swing
    of the largest multibody margin is kept and, if ``strict``, its rows that leave the margin are marked
    infeasible (the friction is judged with every row, ``plan.add_analysis``). A swing looked at again is
    noted in ``seq.rows.paced`` (:func:`_note_pace`).
    Returns the kept swing's least multibody margin [m] (None: the swing was infeasible already, or needed no
    pacing)."""
    start, before = snap[0], snap[3]
    if seq.first_infeasible is not before:
        return None
    held, least = _holds(seq, start, margin_m)
    if held:
        return None
    best: tuple[float, np.ndarray | None, float | None] = (least, None, None)
    rate = 1.0 / seq.dt
    for accel in PACE_ACCEL:
        seq.restore(snap)
        positions = paced_row_positions(p_samples, duration_s, rate, accel)
        build(positions)
        if seq.first_infeasible is not before:
            continue
        held, least = _holds(seq, start, margin_m)
        if held:
            _note_pace(seq, start, accel, least, True)
            return least
        if least > best[0]:
            best = (least, positions, accel)
    seq.restore(snap)
    build(best[1])
    margins = swing_dynamic_margin(seq, start)
    _note_pace(seq, start, best[2], float(np.min(margins)), False)
    if not strict:
        return float(np.min(margins))
    c = seq.rows.columns
    for i in np.flatnonzero(margins < margin_m).tolist():
        r = start + i
        reason = (f"the rows' motion moves the ZMP to {1000 * margins[i]:.1f} mm from the sole's edge (multibody "
                  f"ZMP by central differences; {1000 * margin_m:g} mm wanted, the quasistatic ZMP "
                  f"{1000 * float(c[RowField.ZMP_MARGIN_M][r]):.1f} mm inside), paced or not")
        c[RowField.FEASIBLE][r] = False
        c[RowField.REASON][r] = c[RowField.REASON][r] or reason
        seq.mark(int(c[RowField.STEP][r]), "swing", int(c[RowField.SAMPLE][r]), reason, list(c[RowField.P_BODY_M][r]))
    return float(np.min(margins))
