"""The rows' dynamics along a fixed path, as constraints linear in s̈ and ṡ² (time-optimal timing).

Along a path q(s) of the floating base and the joints (s the path parameter), the generalised
velocity and acceleration are v = q'·ṡ and a = q'·s̈ + q''·ṡ², so the inverse dynamics is

    M(q)·a + h(q, v) = M q'·s̈ + (M q'' + h(q, q') − g(q))·ṡ² + g(q)          (h(q, q'·ṡ) − g quadratic in ṡ)

and its six floating-base rows, the wrench W the world must supply (force f, moment n about the world
origin), are W = A(s)·s̈ + B(s)·ṡ² + C(s) with C the quasistatic wrench of gravity. The fans supply a
vertical thrust F_i(s) at p_i(s) (fixed along the path: the plan's thrust), the ground the rest.

* **Robust dynamic ZMP** (the support polygon's edges n_k·z ≤ b_k): the ground's ZMP lies inside edge
  k exactly when D_k(W) ≤ Σ_i F_i·a_ik, with D_k(W) = n_ky·n_x − n_kx·n_y − b_k·f_z (quasistatically
  M·g·d_k) and a_ik = n_k·p_i − b_k. Under thrust errors ±X, a mass error ±Y scaling every link (W
  scales with it) and a CoM error of ε (the world's moment gains δ × f, at worst ε·f_z on edge k):

      (1 ± Y)·(D_k(W) + ε·f_z(W)) − Σ_i F_i·(a_ik − X·|a_ik|) ≤ 0                     (both signs)

  linear in (s̈, ṡ²); at rest it is the robust window of docs/robust_planning.md.
* **Friction** of the ground's share f_g = (1 + m)·f − Σ F_i(1 + e)·e_z, as a pyramid inside the cone:
  (1 + Y)(±f_x ± f_y) − μ·((1 − Y)·f_z − (1 + X)·Σ F_i) ≤ 0, and a ground that pushes,
  (1 + X)·Σ F_i − (1 − Y)·f_z ≤ 0; on one sole also its **torsion**: the yaw moment about the sole's
  centre c, n_z − c_x·f_y + c_y·f_x (the fans add none), within μ·r_t·f_g,z (r_t :data:`TORSION_RADIUS_M`).
* **Joint torques**: the joint rows of the inverse dynamics less the fans' and the support's share
  (one sole: exact; both: the least-norm split: a bound on the motion's extra torque, not the static load
  transfer of ``statics``), linear in the same way: ±τ_j ≤ τ_max,j.
* **Velocity bounds** (on ṡ, so on ṡ² = x): joints |q'_j|·ṡ ≤ q̇_max,j; a fan of lag τ follows a thrust
  F(s) when its lead command F + τ·F'·ṡ stays within [−ΔF, F_max]: rising ṡ ≤ (F_max − F)/(τ·F'),
  falling ṡ ≤ (F + ΔF)/(τ·|F'|) (ΔF the spin-down allowance: the fan may stay that far above the plan
  while it spins down, a first-order lag never reaching zero in finite time).

Pure functions over arrays but for the PlaCo wrapper that gives M, h and the Jacobians (as
``row_dynamics``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from jethr1_plan.geometry import halfplanes
from jethr1_plan.physics.row_dynamics import ground_wrench
from jethr1_plan.physics.statics import FORCE_DIRECTION

if TYPE_CHECKING:
    from jethr1_plan.robot.model import RobotModel

__all__ = ["TORSION_RADIUS_M", "Limits", "PathConstraints", "joint_velocity_limits", "path_constraints", "wrench_terms"]


TORSION_RADIUS_M = 0.02  # a sole's friction resists a yaw moment of μ·f_z times this [m] (a 0.16 x 0.09 m sole
# under uniform pressure: 0.037 m; under the pressure of a ZMP near an edge, less)


@dataclass(frozen=True)
class Limits:
    """What the timing must respect, SI. ``share`` (G,): the tolerance share each path point must still hold
    dynamically; ``tolerance`` (X, Y, ε) the plan's whole tolerance; ``safety`` scales the joint velocity and
    torque limits and the friction coefficient, and divides the fans' lag (safety 0.8: a lag 25 % longer)."""

    tolerance: tuple[float, float, float]
    share: np.ndarray
    safety: float = 1.0
    friction: float = 0.8
    spin_down_n: float = 0.5  # ΔF [N]


@dataclass(frozen=True)
class PathConstraints:
    """At each of G path points: rows a·s̈ + b·ṡ² + c ≤ 0 (G, m) named ``names`` (m,), and the largest ṡ²
    ``x_max`` (G,) of the velocity bounds with the name of the binding one (G,)."""

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    names: tuple[str, ...]
    x_max: np.ndarray
    x_name: np.ndarray


def joint_velocity_limits(wrapper) -> np.ndarray:
    """(J,) the URDF's joint velocity limits [rad/s] (inf where none is given)."""
    lim = np.asarray(wrapper.model.velocityLimit, dtype=float)[6:].copy()
    lim[~(lim > 0) | (lim > 1e30)] = np.inf
    return lim


def wrench_terms(robot: RobotModel, wrapper, base: np.ndarray, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                 supports: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """At one posture: (A, B, C) the world wrenches (6,) (f, n about the origin) of the floating base's rows
    of M·v·s̈, M·a + h(q, v) − g and g, and (3, J) the joint torques of each (the support's least-norm
    share removed, no thrust). With (v, a) = (q', q'') these are the coefficients of s̈, ṡ² and 1."""
    wrapper.set_T_world_fbase(base)
    wrapper.state.q[7:] = q
    wrapper.state.qd = np.zeros(len(v))
    wrapper.state.qdd = np.zeros(len(v))
    wrapper.update_kinematics()
    g = wrapper.non_linear_effects().copy()
    M = wrapper.mass_matrix()
    wrapper.state.qd = v
    wrapper.update_kinematics()
    hv = wrapper.non_linear_effects().copy()
    wrapper.state.qd = np.zeros(len(v))
    wrapper.update_kinematics()
    rows = np.stack([M @ v, M @ a + hv - g, g])  # (3, 6 + J)
    Jc = np.vstack([wrapper.frame_jacobian(robot.legs[s].sole, "local_world_aligned") for s in supports])
    split = np.linalg.pinv(Jc[:, :6].T)
    tau = rows[:, 6:] - (Jc[:, 6:].T @ (split @ rows[:, :6].T)).T
    wrench = np.array([np.concatenate(ground_wrench(base, r[:6])) for r in rows])
    return wrench[0], wrench[1], wrench[2], tau


def _fan_torques(robot: RobotModel, wrapper, supports: tuple[str, ...], thrust: np.ndarray) -> np.ndarray:
    """(J,) the joint torques the fans' thrust takes off (their share through the support removed)."""
    rhs = np.zeros(6 + len(robot.joint_names))
    for fan, f in zip(robot.fans, thrust, strict=True):
        if f:
            rhs -= wrapper.frame_jacobian(fan.frame, "local_world_aligned").T @ (f * FORCE_DIRECTION)
    Jc = np.vstack([wrapper.frame_jacobian(robot.legs[s].sole, "local_world_aligned") for s in supports])
    w, *_ = np.linalg.lstsq(Jc[:, :6].T, rhs[:6], rcond=None)
    return rhs[6:] - Jc[:, 6:].T @ w


def _edge_rows(wrench: np.ndarray, normals: np.ndarray, offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(D_k (K,), f_z) of a world wrench (f, n): D_k = n_ky·n_x − n_kx·n_y − b_k·f_z."""
    f, n = wrench[:3], wrench[3:]
    return normals[:, 1] * n[0] - normals[:, 0] * n[1] - offsets * f[2], f[2]


def path_constraints(robot: RobotModel, base: np.ndarray, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray,
                     thrust: np.ndarray, dthrust: np.ndarray, supports: tuple[str, ...], polygon: np.ndarray,
                     limits: Limits) -> PathConstraints:
    """The constraints of the module docstring at G points of a path (s the path parameter).

    Args:
        base: (G, 4, 4) the trunk's poses; q: (G, J) the joints [rad]; dq, ddq: (G, 6 + J) q' and q'' (the
            trunk's part in its own frame, as ``row_dynamics.row_derivatives``); thrust, dthrust: (G, F) each
            fan's thrust F [N] and F' [N per unit of s]; supports: the soles on the ground; polygon: (K, 2)
            the support polygon (margin included).
    """
    w = robot.wrapper()
    normals, offsets = halfplanes(polygon)
    X, Y, eps = limits.tolerance
    vmax = joint_velocity_limits(w) * limits.safety
    tmax = robot.servo_limit_nm * limits.safety
    mu = limits.friction * limits.safety
    lag = np.array([f.lag_s for f in robot.fans]) / limits.safety
    fmax = np.array([f.thrust_max_n for f in robot.fans])
    names = ([f"ZMP edge {k} mass {sgn}" for k in range(len(offsets)) for sgn in "+-"]
             + [f"friction {sx}x {sy}y" for sx in "+-" for sy in "+-"] + ["torsion +", "torsion -", "ground pulls"]
             + [f"torque {j} {sgn}" for j in robot.joint_names for sgn in "+-"])
    G, m = len(q), len(names)
    a_out, b_out, c_out = np.zeros((G, m)), np.zeros((G, m)), np.zeros((G, m))
    x_max, x_name = np.full(G, np.inf), np.full(G, "", dtype=object)
    for i in range(G):
        A, B, C, tau = wrench_terms(robot, w, base[i], q[i], dq[i], ddq[i], supports)
        share = float(limits.share[i])
        x, y, e = X * share, Y * share, eps * share
        fans_xy = np.array([w.get_T_world_frame(f.frame)[:2, 3] for f in robot.fans]).reshape(-1, 2)
        centre = w.get_T_world_frame(robot.legs[supports[0]].sole)[:2, 3]
        lever = fans_xy @ normals.T - offsets  # (F, K) a_ik
        held = thrust[i] @ (lever - x * np.abs(lever))  # (K,) Σ F_i (a_ik − X|a_ik|)
        cols = []
        for k_term, W in enumerate((A, B, C)):
            D, fz = _edge_rows(W, normals, offsets)
            zmp = np.stack([(1 + y) * (D + e * fz), (1 - y) * (D + e * fz)], axis=1).reshape(-1)
            total = float(thrust[i].sum()) if k_term == 2 else 0.0
            if k_term == 2:
                zmp = zmp - np.repeat(held, 2)
            fx, fy = W[0], W[1]
            ground_z = (1 - y) * fz - (1 + x) * total
            fric = [(1 + y) * (sx * fx + sy * fy) - mu * ground_z for sx in (1, -1) for sy in (1, -1)]
            # the yaw moment about the (single) support sole's centre, within what its friction resists
            twist = W[5] - centre[0] * W[1] + centre[1] * W[0]
            fric += ([(1 + y) * twist - mu * TORSION_RADIUS_M * ground_z, -(1 + y) * twist - mu * TORSION_RADIUS_M
                      * ground_z] if len(supports) == 1 else [-ground_z, -ground_z])
            t = tau[k_term]
            cols.append(np.concatenate([zmp, fric, [-ground_z], np.stack([t, -t], axis=1).reshape(-1)]))
        fan_tau = _fan_torques(robot, w, supports, thrust[i])
        torque_c = np.stack([tau[2] + fan_tau - tmax, -(tau[2] + fan_tau) - tmax], axis=1).reshape(-1)
        cols[2][-len(torque_c):] = torque_c
        a_out[i], b_out[i], c_out[i] = cols
        # velocity bounds on ṡ² (ṡ ≥ 0)
        qd = np.abs(dq[i, 6:])
        with np.errstate(divide="ignore"):
            joint = np.where(qd > 0, (vmax / qd) ** 2, np.inf)
            rise = np.where(dthrust[i] > 0, (np.maximum(fmax - thrust[i], 0.0) / (lag * dthrust[i])) ** 2, np.inf)
            fall = np.where(dthrust[i] < 0, ((thrust[i] + limits.spin_down_n) / (lag * -dthrust[i])) ** 2, np.inf)
        bounds = np.concatenate([joint, rise, fall])
        k = int(np.argmin(bounds))
        x_max[i] = bounds[k]
        nj = len(robot.joint_names)
        nf = len(robot.fans)
        x_name[i] = (f"joint velocity {robot.joint_names[k]}" if k < nj else
                     f"thrust rate {robot.fans[(k - nj) % nf].name} fan "
                     + ("rising" if k < nj + nf else "falling"))
    return PathConstraints(a_out, b_out, c_out, tuple(names), x_max, x_name)
