"""What a plan reports: summary.json (docs/contract.md), its robustness and smoothness figures, the
infeasible message."""

from __future__ import annotations

from pathlib import Path

from jethr1_plan.arithmetic import signature

import numpy as np

from jethr1_plan import __version__
from jethr1_plan.physics.balance import Tolerance
from jethr1_plan.physics.row_dynamics import RowDynamics
from jethr1_plan.physics.statics import KAPPA_WARNING
from jethr1_plan.planning.results import PlanResult
from jethr1_plan.records.plan_columns import TOLERANCE_SHARE
from jethr1_plan.records.plan_rows import RowField, Rows

__all__ = ["FULL_SHARE", "finite_or_none", "plan_summary", "robustness_summary", "share_summary",
           "smoothness"]


def smoothness(p_body: np.ndarray, thrust_n: np.ndarray) -> dict:
    """Σ‖ΔP_body‖² [m²], the largest ‖ΔP_body‖ [m] and the largest thrust jump [N] over consecutive samples
    (pairs of samples that both balance)."""
    d = np.diff(p_body, axis=0)
    step = np.linalg.norm(d, axis=1) if len(d) else np.zeros(1)
    thrust = np.asarray(thrust_n, dtype=float)
    pairs = np.isfinite(thrust[1:]) & np.isfinite(thrust[:-1])  # infeasible samples have no thrust
    jumps = np.abs(thrust[1:][pairs] - thrust[:-1][pairs])
    return {"smoothness_m2": float(np.sum(d * d)), "max_step_m": float(step.max()),
            "max_thrust_jump_n": float(jumps.max()) if len(jumps) else 0.0}


def finite_or_none(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def _where(rows: Rows, i: int) -> dict:
    c = rows.columns
    return {"row": int(i), "time_s": round(float(c[RowField.TIME_S][i]), 9), "step": int(c[RowField.STEP][i]),
            "phase": c[RowField.PHASE][i], "sample": int(c[RowField.SAMPLE][i])}


def robustness_summary(rows: Rows) -> dict:
    """The least ZMP margin [m] and the narrowest thrust window [N] over the rows, and where they occur.

    The narrowest window is taken over the rows whose fan carries thrust (elsewhere the window is
    that of a fan not in use)."""
    margin = rows.array(RowField.ZMP_MARGIN_M).astype(float)
    window = np.array(rows.columns[RowField.WINDOW_N], dtype=float)
    loaded = rows.fan_array().sum(axis=1) > 0
    if not np.isfinite(margin).any():  # no row has a posture (an unreachable step written anyway)
        return {"least_zmp_margin_m": None}
    i = int(np.nanargmin(margin))
    out = {"least_zmp_margin_m": float(margin[i]), "least_zmp_margin_at": _where(rows, i)}
    width = np.where(loaded & np.isfinite(window[:, 0]), window[:, 1] - window[:, 0], np.inf)
    if np.isfinite(width).any():
        j = int(np.argmin(width))
        out |= {"narrowest_window_n": [float(window[j, 0]), float(window[j, 1])],
                "narrowest_window_width_n": float(width[j]), "narrowest_window_at": _where(rows, j)}
    return out


#: a row share at least this is the whole tolerance: a row whose thrust sits exactly on its window's end
#: under the whole tolerance bisects to 1 − 1e-13 (``physics.share.row_shares``, to 1e-12)
FULL_SHARE = 1.0 - 1e-9


def share_summary(rows: Rows, tol: Tolerance) -> dict | None:
    """The least tolerance share over the rows (``tolerance_share``), where it occurs, the tolerance it
    means (the plan's tolerance × the share), and how many rows hold less than all of it (below
    ``FULL_SHARE``); None where
    the rows carry no share (the minimal policy)."""
    share = rows.array(RowField.TOLERANCE_SHARE).astype(float)
    if not np.isfinite(share).any():
        return None
    i = int(np.nanargmin(share))
    least = float(share[i])
    if least >= FULL_SHARE:  # the whole tolerance, as the rows' check counts it
        least = 1.0
    t = tol.scaled(least)
    return {"least": least, "least_at": _where(rows, i),
            "tolerance": {"thrust_error": t.thrust, "mass_error": t.mass, "com_error_m": t.com_m},
            "rows_below_full": int(np.sum(share < FULL_SHARE))}


def dynamics_summary(rows: Rows, dyn: RowDynamics) -> dict:
    """summary.json's ``dynamics``: where the multibody ZMP of the rows' own motion (second central
    differences, ``physics.row_dynamics``) comes nearest the support polygon's edge, or leaves it; the
    quasistatic ZMP's margin at that row beside it, the rows (first and last excepted) outside, and the swings
    re-timed to keep it inside (``pacing.pace_swing``)."""
    row, least = dyn.least()
    inner = dyn.margin[1:-1]
    return {"least_zmp_margin_m": finite_or_none(least), "least_zmp_margin_at": _where(rows, row),
            "rows_needing_pull": int(np.sum(dyn.vertical_force_n[1:-1] <= 0.0)),
            "quasistatic_zmp_margin_m": finite_or_none(float(rows.columns[RowField.ZMP_MARGIN_M][row])),
            "rows_outside_support": int(np.sum(inner < 0.0)),
            "max_shift_from_quasistatic_m": finite_or_none(float(np.nanmax(np.linalg.norm(
                dyn.zmp[1:-1] - rows.array(RowField.ZMP_M)[1:-1].astype(float), axis=1), initial=0.0))),
            "least_vertical_force_n": float(np.min(dyn.vertical_force_n[1:-1], initial=np.inf)),
            **_grip(dyn),
            "paced_swings": [dict(p) for p in rows.paced]}


def _grip(dyn: RowDynamics) -> dict:
    """What the soles' friction must hold over the inner rows: the peak friction ratio and the peak yaw moment
    about the ZMP, and that moment over the twist capacity of the sole (``physics.row_dynamics``)."""
    if dyn.yaw_moment_nm is None or len(dyn.margin) < 3 or dyn.capacity_nm is None:
        return {}
    inner = slice(1, -1)
    twist = np.abs(dyn.yaw_moment_nm[inner])
    ratio = np.where(dyn.capacity_nm[inner] > 0, twist / np.maximum(dyn.capacity_nm[inner], 1e-12), np.inf)
    return {"peak_friction_ratio": finite_or_none(float(np.nanmax(dyn.friction_ratio[inner], initial=0.0))),
            "peak_yaw_moment_nm": finite_or_none(float(np.nanmax(twist, initial=0.0))),
            "peak_yaw_moment_to_capacity": finite_or_none(float(np.nanmax(ratio, initial=0.0)))}


def _step_summary(st) -> dict:
    """summary.json's record of one optimised step."""
    thrust = st.thrust_n
    fin = thrust[np.isfinite(thrust)]
    return {
        "index": st.index, "swing": st.swing, "support": st.support, "samples": len(st.samples),
        "peak_thrust_n": float(fin.max()) if len(fin) else None,
        "mean_thrust_n": float(fin.mean()) if len(fin) else None,
        **smoothness(st.p_body, thrust),
        "evaluations": int(sum(s.evaluations for s in st.samples)),
        "restarts": sum(s.phase == "restart" for s in st.samples),
        "least_share": float(min(s.share for s in st.samples)) if st.samples else None,
        "samples_below_full_share": sum(s.share < 1.0 for s in st.samples),
        "feasible": all(s.feasible for s in st.samples),
    }


def plan_summary(result: PlanResult) -> dict:
    """summary.json (docs/contract.md): figures over the optimised swing samples, per step and in total."""
    sc = result.scenario
    per_step = [_step_summary(st) for st in result.steps]
    fins = [t[np.isfinite(t)] for t in (st.thrust_n for st in result.steps)]
    thr = np.concatenate(fins) if fins else np.zeros(0)
    out = {
        "scenario": sc.name,
        "scenario_file": str(Path(sc.source).resolve()) if sc.text else sc.source,
        "scenario_yaml": sc.text,  # the scenario as read: verify finds it even where the file has moved
        "robot": result.robot.name,
        "robot_yaml": str(result.robot.yaml_path),
        "optimiser": result.method,
        "seed": result.seed,
        "version": __version__,
        "arithmetic": signature(),  # the kernels that computed it: the bytes are the same wherever this is
        "feasible": result.feasible,
        "first_infeasible": None if result.first_infeasible is None else result.first_infeasible.to_dict(),
        "sample_count": int(sum(len(st.samples) for st in result.steps)),
        "row_count": len(result.rows) if result.rows is not None else 0,
        "peak_thrust_n": float(thr.max()) if len(thr) else None,
        "mean_thrust_n": float(thr.mean()) if len(thr) else None,
        "thrust_max_n": sc.balance.thrust_max_n,
        "balance": {"policy": sc.balance.policy, "sole_margin_m": sc.balance.sole_margin_m,
                    "tolerance": {"thrust_error": sc.balance.tolerance.thrust, "mass_error": sc.balance.tolerance.mass,
                                  "com_error_m": sc.balance.tolerance.com_m},
                    "min_share": sc.balance.min_share if sc.balance.policy == "robust" else None},
        "smoothness_m2": float(sum(s["smoothness_m2"] for s in per_step)),
        "max_step_m": max((s["max_step_m"] for s in per_step), default=0.0),
        "max_thrust_jump_n": max((s["max_thrust_jump_n"] for s in per_step), default=0.0),
        "evaluations": int(result.evaluations),
        "wall_s": float(result.wall_s),
        "steps": per_step,
        "terrain": {"cartons": [{"top_centre_m": list(c.top_centre_m), "size_m": list(c.size_m)}
                                for c in sc.cartons]},
    }
    if result.rows is not None and len(result.rows):
        out |= _rows_summary(result, result.rows)
    return out


def _rows_summary(result: PlanResult, rows: Rows) -> dict:
    """summary.json's figures over the output rows: the trajectory, robustness, controller, torques, κ, yaw
    momentum, dynamics, timing and yaw."""
    sc = result.scenario
    out: dict = {}
    fans = [f.name for f in result.robot.fans]
    per_fan = {f: rows.fan(f) for f in fans}
    out["trajectory"] = {"rows": len(rows), "rate_hz": sc.timing.rate_hz,
                         "duration_s": len(rows) / sc.timing.rate_hz,
                         "peak_thrust_n": float(max(v.max() for v in per_fan.values())),
                         "peak_thrust_per_fan_n": {f: float(v.max()) for f, v in per_fan.items()}}
    robustness = robustness_summary(rows)
    shares = share_summary(rows, sc.balance.tolerance)
    if shares is not None:
        robustness[TOLERANCE_SHARE] = shares  # (the section named as the column it summarises)
    out["robustness"] = robustness
    from jethr1_plan.control.feedback import controller_summary

    tol = sc.balance.tolerance
    out["controller"] = controller_summary(result.robot, tol.thrust, tol.mass, sc.balance.thrust_max_n)
    if rows.analysed:
        out |= _analysis_summary(result, rows)
    if "dynamics" in rows.analysis:
        out["dynamics"] = dynamics_summary(rows, rows.analysis["dynamics"])
    if sc.timing.fastest:
        out["timing"] = timing_summary(sc, rows)
    dt = 1.0 / sc.timing.rate_hz
    yaw = np.unwrap(rows.array(RowField.YAW_RAD).astype(float))
    rate = np.gradient(yaw, dt)
    out["yaw"] = {"mode": sc.yaw_mode, "peak_rate_rad_s": float(np.abs(rate).max()),
                  "peak_accel_rad_s2": float(np.abs(np.gradient(rate, dt)).max())}
    return out


def _analysis_summary(result: PlanResult, rows: Rows) -> dict:
    """summary.json's ``torques``, ``energy_j``, ``kappa`` and ``yaw_momentum_peak_nms``."""
    tau, kappa = np.abs(rows.array(RowField.TAU_NM)), rows.array(RowField.KAPPA)
    ratio = rows.analysis["ratio"]
    out: dict = {"torques": {
        "max_abs_nm": dict(zip(result.robot.joint_names, tau.max(axis=0).tolist(), strict=True)),
        "max_ratio_to_servo_limit": float(ratio.max()),
        "rows_over_servo_limit": int(np.sum(ratio.max(axis=1) > 1.0)),
    }}
    out["energy_j"] = float(rows.analysis["energy_j"])
    kappa = np.where(np.isfinite(kappa), kappa, np.nan)  # rows without a posture have none
    out["kappa"] = {"max_left": finite_or_none(np.nanmax(kappa[:, 0], initial=0.0)),
                    "max_right": finite_or_none(np.nanmax(kappa[:, 1], initial=0.0)),
                    "warning_threshold": KAPPA_WARNING,
                    "rows_above_threshold": int(np.sum(kappa.max(axis=1) > KAPPA_WARNING))}
    out["yaw_momentum_peak_nms"] = float(np.abs(rows.array(RowField.YAW_MOMENTUM_NMS)).max())
    return out


def timing_summary(sc, rows) -> dict:
    """summary.json's ``timing`` of a plan timed fastest: the limits it was timed under and, per phase, its
    duration, the fixed timing's, the speed-up and the constraints that bind along its path (fractions of
    its time)."""
    tm = sc.timing
    fixed = len(sc.steps) * (tm.swing_s + tm.transfer_s) + tm.transfer_s
    total = (len(rows) - 1) / tm.rate_hz
    return {"mode": tm.mode, "dynamic_share": tm.dynamic_share, "safety_factor": tm.safety_factor,
            "spin_down_n": tm.spin_down_n, "min_swing_s": tm.min_swing_s, "min_transfer_s": tm.min_transfer_s,
            "max_swing_s": tm.max_swing_s, "max_transfer_s": tm.max_transfer_s,
            "fixed_swing_s": tm.swing_s, "fixed_transfer_s": tm.transfer_s,
            "total_s": total, "fixed_total_s": fixed, "speed_up": fixed / total if total > 0 else None,
            "phases": [dict(p) for p in rows.timed]}
