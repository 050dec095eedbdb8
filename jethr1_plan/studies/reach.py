"""Paper B's kinematic step-length analysis (B-1)..(B-5), and the numerical reach of a robot model.

Formulas (Park & Park 2022, II):

* (B-1) standing, pelvis fixed, both legs straight:   l = 2·√(l_leg² − z0²)
* (B-2) hip advance by a pelvic rotation θ:            Δd_hip = l_pel·sin θ
* (B-3) kinematic limit, hip line on the ankle line:   l = √((l_(B-1) + l_pel)² − w_step²)
* (B-4) static walking, pelvis over the support foot: l = √(l_leg² − z0²)
* (B-5) the same with pelvic rotation:                 l = √(l_leg² − z0²) + ½·l_pel·sin θ

For Dyros-Jet (l_leg 0.75, z0 0.68, l_pel 0.21, w_step 0.243 m, θ = 45°), (B-4) gives 0.316 m and
(B-5) 0.390 m. The paper states 0.42 m (+35 %): that needs Δd = 0.104 m, which neither ½·l_pel·sin θ
(0.074 m) nor (B-2)'s l_pel·sin θ (0.148 m) gives. We implement the equations as written and
report the discrepancy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "DYROS_JET",
    "PAPER_B_STATED_ROTATING_M",
    "ReachFigures",
    "discrepancy_note",
    "numerical_reach",
    "step_lengths",
]

PAPER_B_STATED_ROTATING_M = 0.42
DYROS_JET = {"l_leg": 0.75, "z0": 0.68, "l_pel": 0.21, "w_step": 0.243, "theta_pel_deg": 45.0}


@dataclass(frozen=True)
class ReachFigures:
    """Inputs [m, deg] of Paper B's formulas."""

    l_leg: float
    z0: float
    l_pel: float
    w_step: float
    theta_pel_deg: float


def step_lengths(f: ReachFigures) -> dict:
    """(B-1)..(B-5) [m]."""
    if not 0 < f.z0 <= f.l_leg:
        raise ValueError("need 0 < z0 <= l_leg")
    th = math.radians(f.theta_pel_deg)
    half = math.sqrt(f.l_leg ** 2 - f.z0 ** 2)
    standing = 2 * half
    limit_sq = (standing + f.l_pel) ** 2 - f.w_step ** 2
    d_hc = 0.5 * f.l_pel * math.sin(th)
    return {
        "standing_fixed_m": standing,  # (B-1)
        "delta_d_hip_m": f.l_pel * math.sin(th),  # (B-2)
        "kinematic_limit_m": math.sqrt(limit_sq) if limit_sq > 0 else 0.0,  # (B-3)
        "fixed_m": half,  # (B-4)
        "delta_d_hc_m": d_hc,
        "rotating_m": half + d_hc,  # (B-5)
        "gain_pct": 100 * d_hc / half if half > 0 else None,
    }


def discrepancy_note(figures: dict, stated_m: float = PAPER_B_STATED_ROTATING_M) -> str:
    """How (B-5) compares with the 0.42 m Paper B states for Dyros-Jet."""
    needed = stated_m - figures["fixed_m"]
    return (f"(B-5) gives {figures['rotating_m']:.3f} m; Paper B states {stated_m:.2f} m, which would need "
            f"a hip advance of {needed:.3f} m: ½·l_pel·sin θ gives {figures['delta_d_hc_m']:.3f} m and (B-2)'s "
            f"l_pel·sin θ {figures['delta_d_hip_m']:.3f} m (that would give "
            f"{figures['fixed_m'] + figures['delta_d_hip_m']:.3f} m). The equations are implemented as written.")


def numerical_reach(robot_name: str, z0: float, w_step: float, trunk_yaw_rad: float, resolution_m: float = 0.002
                    ) -> dict:
    """The longest forward step [m] (sole centre to sole centre along x, the feet ``w_step`` apart in y,
    both flat on z = 0) that the legs reach within their joint limits with the hip joints at height
    ``z0`` over the soles and the trunk yawed by ``trunk_yaw_rad``, the pelvis free in x and y.

    Searched with the closed-form kinematics on a grid of pelvis positions (``resolution_m``), then the
    winning posture is solved again by PlaCo's IK from a bent-knee seed (``placo_converged``).
    """
    from jethr1_plan.kinematics import Stance
    from jethr1_plan.kinematics.closed_form import solve_postures
    from jethr1_plan.kinematics.placo import PlacoPostureSolver
    from jethr1_plan.reasons import Reason
    from jethr1_plan.robot.load import load_robot

    robot = load_robot(robot_name)
    support = np.array([0.0, -w_step / 2, 0.0])
    L = robot.thigh_m + robot.shank_m + robot.ankle_height_m
    xs = np.arange(-0.1 * L, 2.2 * L, resolution_m)
    ys = np.arange(-w_step / 2 - 0.6 * L, w_step / 2 + 0.6 * L, resolution_m * 5)

    def best_for(step: float):
        swing = np.array([step, w_step / 2, 0.0])
        P = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)
        P = np.column_stack([P, np.full(len(P), z0)])
        feet = {"right": (support, 0.0), "left": (swing, 0.0)}
        _, _, status = solve_postures(robot, P, trunk_yaw_rad, feet)
        ok = np.flatnonzero(status == Reason.OK)
        return (P[ok[len(ok) // 2]], swing) if len(ok) else None

    lo, hi = 0.0, 2.5 * L
    if best_for(lo) is None:
        return {"step_m": None, "placo_converged": False}
    while hi - lo > resolution_m:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if best_for(mid) is not None else (lo, mid)
    p, swing = best_for(lo)
    solver = PlacoPostureSolver(robot)
    batch = solver.solve_batch(Stance("right", support, 0.0, swing, 0.0, trunk_yaw_rad), p[None])
    return {"step_m": float(lo), "pelvis_m": p.tolist(), "trunk_yaw_rad": float(trunk_yaw_rad),
            "placo_converged": bool(batch.status[0] == Reason.OK)}
