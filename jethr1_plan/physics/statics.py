"""Paper B's analyses on a planned trajectory: static joint torques, leg condition numbers (B-45),
energy (B-44) and yaw angular momentum (B-41).

* Static torques: with gravity, the fans' vertical thrust and the ground reaction, the equations of
  motion at rest read g(q) = Sᵀτ + J_cᵀ w_c + J_fᵀ w_f. The six floating-base rows A w_c = b fix the
  support wrench w_c (one foot: exactly), and the joint rows give τ. PlaCo (pinocchio) supplies g(q)
  and the Jacobians (world-aligned at each frame).
* Both feet down: A w = b has infinitely many solutions (the internal forces between the feet), and
  the one the servo commands are built on is the one the robot carries (``control.commands``: at the
  servos' stiffness the sag compensation realises it). It is the load transfer's split (:func:`load_split`):
  the weighted least-norm w = W Aᵀ (A W Aᵀ)⁻¹ b, W = diag(β_l I₆, β_r I₆), with each sole's weight
  β_s = d_o / (d_l + d_r) from the distances d_s ≥ 0 of the ZMP (of gravity and thrust) outside each
  sole's rectangle (o the other sole). While the ZMP lies in one sole that sole carries everything
  (the other's weight is 0): a transfer starts and ends exactly as the single support next to it, so the
  torques, and the commands, do not jump where a foot lands or lifts; between, the load moves over
  continuously with the ZMP (β_l = β_r = ½ is the plain least-norm split).
* κ(J) = σ_max / σ_min of each leg's 6 × 6 Jacobian of the sole relative to the trunk (B-45):
  large near the stretched-knee singularity where long steps live.
* E_con = Σ_i ∫ max(τ_i·q̇_i, 0) dt (B-44), with q̇ from central differences of the rows.
* Yaw angular momentum h = A_CMM,yaw · v (B-41): the yaw row of PlaCo's centroidal momentum matrix
  times the generalised velocity (base twist in the trunk frame, then joint rates).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from jethr1_plan.geometry import SIDES, polygon_margin, sole_polygon
from jethr1_plan.robot.model import RobotModel

__all__ = [
    "FORCE_DIRECTION",
    "KAPPA_WARNING",
    "analyse_rows",
    "condition_numbers",
    "energy_consumption",
    "generalized_velocities",
    "leg_condition_numbers",
    "leg_jacobian",
    "load_split",
    "static_torques",
]

KAPPA_WARNING = 100.0  # leg Jacobian condition number above which a row is flagged
FORCE_DIRECTION = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0])  # a vertical force, world-aligned


def static_torques(robot: RobotModel, wrapper, thrust_n: np.ndarray, supports: tuple[str, ...]
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Joint torques (J,) [N·m] and the support wrench(es) [N, N·m] holding the current posture.

    ``thrust_n`` (F,) [N] per fan of ``robot.fans``; ``supports`` the sides whose soles are on the
    ground. ``wrapper`` must have its kinematics updated at the posture.
    """
    g = wrapper.generalized_gravity()
    rhs = g.copy()
    for fan, f in zip(robot.fans, thrust_n, strict=True):
        if f:
            rhs -= wrapper.frame_jacobian(fan.frame, "local_world_aligned").T @ (f * FORCE_DIRECTION)
    Jc = np.vstack([wrapper.frame_jacobian(robot.legs[s].sole, "local_world_aligned") for s in supports])
    a = Jc[:, :6].T
    if len(supports) == 1:
        w, *_ = np.linalg.lstsq(a, rhs[:6], rcond=None)
    else:
        poses = [wrapper.get_T_world_frame(robot.legs[s].sole) for s in supports]
        beta = load_split(a, rhs[:6], [T[:3, 3] for T in poses], [float(np.arctan2(T[1, 0], T[0, 0])) for T in poses],
                          robot.sole_length_m, robot.sole_width_m)
        weight = np.repeat(beta, 6)
        w = weight * (a.T @ np.linalg.solve((a * weight) @ a.T, rhs[:6]))
    tau = rhs[6:] - Jc[:, 6:].T @ w
    return tau, w


def load_split(a: np.ndarray, b: np.ndarray, soles_xyz: list, soles_yaw: list, length_m: float,
               width_m: float) -> np.ndarray:
    """Each sole's weight β (2,) in the double-support split (module docstring): the ZMP of the support
    wrench (the single-support solution on the first sole, A₁ w₁ = b: its CoP p + (−m_y, m_x)/f_z, the
    resultant being vertical) and its distances d_s [m] beyond each sole rectangle at ``soles_xyz``,
    ``soles_yaw`` [rad]; β_s = d_o / (d_l + d_r), ½ each where both are 0."""
    w1 = np.linalg.solve(a[:, :6], b)
    fz = w1[2] if abs(w1[2]) > 1e-9 else 1e-9
    zmp = np.asarray(soles_xyz[0][:2]) + np.array([-w1[4], w1[3]]) / fz
    d = np.array([max(0.0, -float(polygon_margin(zmp, sole_polygon(p[:2], y, length_m, width_m))))
                  for p, y in zip(soles_xyz, soles_yaw, strict=True)])
    if d.sum() <= 0.0:
        return np.array([0.5, 0.5])
    return d[::-1] / d.sum()


def leg_condition_numbers(robot: RobotModel, wrapper) -> dict[str, float]:
    """κ of each leg: σ_max/σ_min of d(sole twist relative to the trunk)/d(leg joints) (6 × 6)."""
    kappa = condition_numbers(np.stack([leg_jacobian(robot, wrapper, side) for side in SIDES]))
    return {side: float(k) for side, k in zip(SIDES, kappa, strict=True)}


def leg_jacobian(robot: RobotModel, wrapper, side: str) -> np.ndarray:
    """(6, 6) d(sole twist, world-aligned)/d(the ``side`` leg's joints) at the wrapper's posture."""
    leg = robot.legs[side]
    return wrapper.frame_jacobian(leg.sole, "local_world_aligned")[:, 6 + np.asarray(leg.index)]


def condition_numbers(J: np.ndarray) -> np.ndarray:
    """(...,) σ_max/σ_min of each matrix of ``J`` (..., m, k) (B-45): inf where σ_min is 0."""
    s = np.linalg.svd(J, compute_uv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(s[..., -1] > 0, s[..., 0] / s[..., -1], np.inf)


def energy_consumption(tau: np.ndarray, q: np.ndarray, dt: float) -> float:
    """E_con [J] of (B-44): Σ_i ∫ max(τ_i·q̇_i, 0) dt, q̇ by central differences (one-sided at the
    ends), the integral by the trapezoidal rule."""
    qdot = np.gradient(q, dt, axis=0)
    power = np.maximum(tau * qdot, 0.0).sum(axis=1)
    return float(0.5 * dt * np.sum(power[1:] + power[:-1]))


def generalized_velocities(p: np.ndarray, yaw: np.ndarray, q: np.ndarray, dt: float) -> np.ndarray:
    """(N, 18): trunk linear velocity in the trunk frame, trunk angular velocity (about z), joint rates."""
    pdot = np.gradient(p, dt, axis=0)
    yawdot = np.gradient(np.unwrap(yaw), dt)
    c, s = np.cos(yaw), np.sin(yaw)
    v_local = np.stack([c * pdot[:, 0] + s * pdot[:, 1], -s * pdot[:, 0] + c * pdot[:, 1], pdot[:, 2]], axis=1)
    return np.column_stack([v_local, np.zeros((len(p), 2)), yawdot, np.gradient(q, dt, axis=0)])


def analyse_rows(robot: RobotModel, p: np.ndarray, yaw: np.ndarray, q: np.ndarray, thrust: np.ndarray,
                 support: np.ndarray, dt: float) -> dict[str, Any]:
    """Torques (N, J), κ per leg (N, 2) and yaw momentum (N,) for every output row: P_body ``p`` (N, 3) [m],
    the body yaw (N,) [rad], the joints ``q`` (N, J) [rad], the thrust per fan (N, F) [N] and the support
    (N,) (left / right / both), rows ``dt`` [s] apart."""
    wrapper = robot.wrapper()
    n = len(p)
    v = generalized_velocities(p, yaw, q, dt)
    tau = np.zeros((n, len(robot.joint_names)))
    legs = np.zeros((n, len(SIDES), 6, 6))  # each leg's Jacobian (leg_jacobian), for κ of every row at once
    h_yaw = np.zeros(n)
    for i in range(n):
        T = np.eye(4)
        T[:2, :2] = [[np.cos(yaw[i]), -np.sin(yaw[i])], [np.sin(yaw[i]), np.cos(yaw[i])]]
        T[:3, 3] = p[i]
        wrapper.set_T_world_fbase(T)
        wrapper.state.q[7:] = q[i]
        wrapper.update_kinematics()
        supports = SIDES if support[i] == "both" else (support[i],)
        tau[i], _ = static_torques(robot, wrapper, thrust[i], supports)
        for k, side in enumerate(SIDES):
            legs[i, k] = leg_jacobian(robot, wrapper, side)
        h_yaw[i] = float(wrapper.centroidal_map()[5] @ v[i])
    return {"tau": tau, "kappa": condition_numbers(legs), "yaw_momentum": h_yaw,
            "energy_j": energy_consumption(tau, q, dt)}
