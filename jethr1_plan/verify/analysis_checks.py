"""The checks of a plan's analysis columns: the static torques under the written thrust and their servo limits,
κ, and the servo and fan commands restated from the written rows; one small function each (:mod:`.checks`).
"""

from __future__ import annotations

import numpy as np

from jethr1_plan.records.plan_columns import KAPPA
from jethr1_plan.verify.checks import Finding, RowCheck, registrar, rows
from jethr1_plan.verify.commands import PLAN_SAG_FILTER_S, PLAN_SAG_STIFFNESS_SCALE, fan_commands, servo_commands
from jethr1_plan.verify.plan_rows import RowData

__all__ = ["CHECKS"]

TOL_TAU = 1e-6  # torque tolerance [N·m] (forward kinematics from the written joints, exact to rounding)

CHECKS: list[RowCheck] = []  # in the order they run
check = registrar(CHECKS)


@check("torque column wrong", "the written static torques are the posture's under the written thrust",
       needs=(KAPPA[0],))
def _torque_column(x: RowData) -> list[Finding]:
    if not x.statics:
        return []
    tau_w = np.stack([x.c[f"{j}_tau_nm"] for j in x.robot.joint_names], axis=1).astype(float)
    tau = x.fk["tau"]
    ok = np.isfinite(tau).all(axis=1)
    err = np.abs(tau_w - tau)
    out = []
    for i in np.flatnonzero(ok & ~np.all(err <= TOL_TAU * np.maximum(1.0, np.abs(tau)), axis=1)):
        j = int(np.argmax(err[i]))
        out.append((int(i), f"{x.robot.joint_names[j]}_tau_nm {tau_w[i, j]:.4f}, recomputed {tau[i, j]:.4f} N·m"))
    return out


@check("torque over its servo limit", "every static torque within its servos' limit (unless told not to)",
       needs=(KAPPA[0],))
def _torque_limit(x: RowData) -> list[Finding]:
    if not (x.statics and x.torque_limits):
        return []
    tau_w = np.stack([x.c[f"{j}_tau_nm"] for j in x.robot.joint_names], axis=1).astype(float)
    tau = x.fk["tau"]
    ok = np.isfinite(tau).all(axis=1)
    used = np.where(ok[:, None], tau, tau_w)
    ratio = np.abs(used) / x.robot.servo_limit_nm
    out = []
    for i in np.flatnonzero(ratio.max(axis=1) > 1.0):
        j = int(np.argmax(ratio[i]))
        out.append((int(i), f"{x.robot.joint_names[j]} needs {abs(used[i, j]):.2f} N·m, its servos give "
                    f"{x.robot.servo_limit_nm[j]:.2f} N·m"))
    return out


@check("kappa column wrong", "the written κ of each leg is the posture's", needs=(KAPPA[0],))
def _kappa_column(x: RowData) -> list[Finding]:
    if not x.statics:
        return []
    kappa_w = np.stack([x.c[KAPPA[0]], x.c[KAPPA[1]]], axis=1).astype(float)
    kappa = x.fk["kappa"]
    bad = np.isfinite(kappa).all(axis=1) & ~np.all(np.abs(kappa_w - kappa) <= 1e-6 * np.maximum(1.0, kappa), axis=1)
    return rows(bad, lambda i: f"written {np.round(kappa_w[i], 4).tolist()}, recomputed "
                f"{np.round(kappa[i], 4).tolist()}")


def _command_rate(x: RowData) -> float | None:
    """The rows' rate from their times (None where the time check has said why it is not one)."""
    dt = np.diff(x.c["time_s"].astype(float))
    if x.n < 2 or not (np.all(dt > 0) and np.all(np.isfinite(dt))) or not x.statics:
        return None
    return 1.0 / float(np.median(dt))


@check("servo command column wrong", "the servo commands are the rows plus the sag under their torques "
       "(``verify.commands``)", needs=(KAPPA[0],))
def _servo_commands(x: RowData) -> list[Finding]:
    rate = _command_rate(x)
    if rate is None or f"{x.robot.joint_names[0]}_cmd_rad" not in x.c:
        return []
    r = x.robot
    tau = np.stack([x.c[f"{j}_tau_nm"] for j in r.joint_names], axis=1).astype(float)
    q_cmd = servo_commands(x.q, tau, PLAN_SAG_STIFFNESS_SCALE * r.servo_stiffness_nm_per_rad, rate, PLAN_SAG_FILTER_S)
    written = np.stack([x.c[f"{j}_cmd_rad"] for j in r.joint_names], axis=1).astype(float)
    out = []
    for i in np.flatnonzero(~np.all(np.abs(written - q_cmd) <= 1e-9, axis=1)):
        j = int(np.argmax(np.abs(written[i] - q_cmd[i])))
        out.append((int(i), f"{r.joint_names[j]}_cmd_rad {written[i, j]:.6f}, recomputed {q_cmd[i, j]:.6f}"))
    return out


@check("fan command column wrong", "the fan commands are the thrust led by the fans' lag (``verify.commands``)",
       needs=(KAPPA[0],))
def _fan_commands(x: RowData) -> list[Finding]:
    rate = _command_rate(x)
    if rate is None or f"{x.robot.joint_names[0]}_cmd_rad" not in x.c:
        return []
    fans = x.fans
    f_cmd = fan_commands(x.thrust, rate, np.array([f.lag_s for f in fans]), np.array([f.thrust_max_n for f in fans]))
    written = np.column_stack([x.c[f"thrust_cmd_{f.name}_n"] for f in fans]).astype(float)
    return rows(~np.all(np.abs(written - f_cmd) <= 1e-9, axis=1), lambda i: f"written "
                f"{np.round(written[i], 4).tolist()} N, recomputed {np.round(f_cmd[i], 4).tolist()} N")
