"""The motion written rows imply, by the strictest stencil, and the ground's wrench it needs.

* **Motion**: at row i the generalised velocity and acceleration are second central differences of
  the rows, with d± the difference from row i to row i ± 1 (the trunk's on SE(3), in its own frame:
  ``geometry.pose_difference``; the joints' plain):  v_i = (d⁺ − d⁻)/2Δt, a_i = (d⁺ + d⁻)/Δt².
  No averaging and no wider stencil: a one-row spike stays a one-row spike. Beyond each end the
  robot holds its posture.
* **The ground's wrench**: the floating base's six rows of the inverse dynamics M(q)·a + h(q, v) are
  the wrench the world must supply (in the trunk's frame about its origin); in the world frame about
  the world's origin they are (f, n). The fans supply part of it: each fan k pushes F_k upward
  (Paper A, III-A) at its thrust point p_k, so the ground supplies f − Σ F_k·e_z and
  n − Σ p_k × F_k·e_z.
* **The multibody ZMP**: (−n_y/f_z, n_x/f_z) of the ground's share, the point the soles' pressure
  must be centred on for the rows to be executed as written; with v = a = 0 it is the quasistatic
  ZMP of (A-1, A-2). Its signed distance to the support polygon is the dynamic margin.
* **What the soles' friction must hold**: the ground's horizontal force over its vertical one (the
  friction ratio, against the soles' μ), and its moment about the vertical through the ZMP,
  M_z = n_z − (z_x·f_y − z_y·f_x): the twist the soles must resist without turning. A sole pressed
  evenly over a disc of radius ρ around the ZMP resists up to (2/3)·μ·f_z·ρ (the friction of each
  ring, μ·p·r, integrated over the disc): with ρ the ZMP's margin inside the support, that is
  :func:`twist_capacity`, a lower bound on what a sole whose pressure is centred there holds.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from jethr1_plan.geometry import SIDES, convex_hull, polygon_margin, pose_difference, sole_polygon

if TYPE_CHECKING:
    from jethr1_plan.robot.model import RobotModel

__all__ = ["RowDynamics", "ground_wrench", "row_derivatives", "row_dynamics", "twist_capacity"]


def twist_capacity(mu: float, vertical_force_n: np.ndarray, margin_m: np.ndarray) -> np.ndarray:
    """(2/3)·μ·f_z·ρ [N·m]: the yaw moment a sole pressed evenly over the disc of radius ρ (``margin_m``,
    the ZMP's margin inside the support) around the ZMP resists by friction μ (the module docstring);
    0 where ρ ≤ 0 or f_z ≤ 0."""
    return (2.0 / 3.0) * mu * np.maximum(vertical_force_n, 0.0) * np.maximum(margin_m, 0.0)


def row_derivatives(base: np.ndarray, q: np.ndarray, dt: float, ends: str = "hold") -> tuple[np.ndarray, np.ndarray]:
    """(v, a) (N, 6 + J): the generalised velocity and acceleration at each row by second central
    differences of the rows (``base`` (N, 4, 4) the trunk's poses, ``q`` (N, J) [rad], ``dt`` [s]), the
    trunk's part in its own frame (pinocchio's free flyer).

    ``ends`` says what the first and last rows see: ``"hold"``, the robot holding its posture beyond
    them (a plan starts and ends at rest); ``"rows"``, the rows alone (N ≥ 3): with d₁ and d₂ the
    differences from the end row to the next two rows inwards, v = ±(4·d₁ − d₂)/2Δt (+ at the first
    row, − at the last) and a = (d₂ − 2·d₁)/Δt², the one-sided stencils of the same order (a walk stops
    where its rows stop, not at rest)."""
    n = len(q)
    nxt = np.concatenate([np.arange(1, n), [n - 1]])
    prv = np.concatenate([[0], np.arange(n - 1)])
    d_plus = np.concatenate([pose_difference(base, base[nxt]), q[nxt] - q], axis=1)
    d_minus = np.concatenate([pose_difference(base, base[prv]), q[prv] - q], axis=1)
    v, a = (d_plus - d_minus) / (2.0 * dt), (d_plus + d_minus) / dt**2
    if ends == "rows" and n >= 3:
        for row, inward, sign in ((0, (1, 2), 1.0), (n - 1, (n - 2, n - 3), -1.0)):
            d1, d2 = (np.concatenate([pose_difference(base[row:row + 1], base[k:k + 1])[0], q[k] - q[row]])
                      for k in inward)
            v[row] = sign * (4.0 * d1 - d2) / (2.0 * dt)
            a[row] = (d2 - 2.0 * d1) / dt**2
    elif ends not in ("hold", "rows"):
        raise ValueError(f"ends: {ends!r}")
    return v, a


def ground_wrench(T_base: np.ndarray, base_rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(force [N], moment about the world origin [N·m]) the world exerts on the robot, in the world,
    from the floating base's six rows of the inverse dynamics (force then moment, in the trunk's frame
    about its origin)."""
    R, p = T_base[:3, :3], T_base[:3, 3]
    f = R @ base_rows[:3]
    p_x_f = np.array([p[1] * f[2] - p[2] * f[1], p[2] * f[0] - p[0] * f[2], p[0] * f[1] - p[1] * f[0]])
    return f, R @ base_rows[3:6] + p_x_f


@dataclass(frozen=True)
class RowDynamics:
    """Per row (N,): the multibody ZMP of the ground's share [m] (N, 2), its margin in the support
    polygon [m] (positive inside), the ground's vertical force [N], friction ratio |f_xy|/f_z and yaw
    moment about the ZMP [N·m].
    The first and last rows see beyond the rows (the robot held at rest there)."""

    zmp: np.ndarray
    margin: np.ndarray
    vertical_force_n: np.ndarray
    friction_ratio: np.ndarray
    yaw_moment_nm: np.ndarray | None = None  # the ground's moment about the vertical through the ZMP [N·m]
    capacity_nm: np.ndarray | None = None  # the soles' twist capacity there, :func:`twist_capacity` [N·m]

    def least(self) -> tuple[int, float]:
        """(row, margin [m]) of the least dynamic margin over the inner rows (N > 2), else over all."""
        inner = self.margin[1:-1] if len(self.margin) > 2 else self.margin
        k = int(np.argmin(inner))
        return (k + 1 if len(self.margin) > 2 else k), float(inner[k])


def row_dynamics(robot: RobotModel, base: np.ndarray, q: np.ndarray, thrust_n: np.ndarray, support: np.ndarray,
                 dt: float) -> RowDynamics:
    """The ground's share of the wrench the rows need (module docstring), row by row.

    Args:
        base: (N, 4, 4) the trunk's poses; q: (N, J) the joints [rad]; thrust_n: (N, F) each fan's
            thrust in ``robot.fans`` order [N]; support: (N,) "left", "right" or "both"; dt: the rows'
            period [s].
    """
    v, a = row_derivatives(base, q, dt)
    w = robot.wrapper()
    soles = {s: robot.legs[s].sole for s in SIDES}
    fan_frames = [f.frame for f in robot.fans]
    n = len(q)
    zmp, margin = np.zeros((n, 2)), np.zeros(n)
    fz, friction, twist = np.zeros(n), np.zeros(n), np.zeros(n)
    hulls: dict[bytes, np.ndarray] = {}
    for i in range(n):
        w.set_T_world_fbase(base[i])
        w.state.q[7:] = q[i]
        w.state.qd = v[i]
        w.state.qdd = a[i]
        w.update_kinematics()
        f, moment = ground_wrench(base[i], (w.mass_matrix() @ a[i] + w.non_linear_effects())[:6])
        for k, frame in enumerate(fan_frames):
            p = w.get_T_world_frame(frame)[:3, 3]
            lift = float(thrust_n[i, k])
            f[2] -= lift
            moment[0] -= p[1] * lift
            moment[1] += p[0] * lift
        zmp[i] = (-moment[1] / f[2], moment[0] / f[2]) if f[2] > 0 else (np.nan, np.nan)
        fz[i] = f[2]
        friction[i] = np.hypot(f[0], f[1]) / f[2] if f[2] > 0 else np.inf
        twist[i] = moment[2] - (zmp[i, 0] * f[1] - zmp[i, 1] * f[0]) if f[2] > 0 else np.nan
        down = SIDES if support[i] not in SIDES else (str(support[i]),)
        placed = [w.get_T_world_frame(soles[s]) for s in down]
        key = np.round([(T[0, 3], T[1, 3], T[0, 0], T[1, 0]) for T in placed], 9).tobytes()
        poly = hulls.get(key)
        if poly is None:  # the soles stand still through a phase: their polygon is built once
            polys = [sole_polygon(T[:2, 3], float(np.arctan2(T[1, 0], T[0, 0])), robot.sole_length_m,
                                  robot.sole_width_m) for T in placed]
            poly = hulls[key] = polys[0] if len(polys) == 1 else convex_hull(np.vstack(polys))
        margin[i] = float(polygon_margin(zmp[i], poly)) if f[2] > 0 else -np.inf
    return RowDynamics(zmp, margin, fz, friction, twist, twist_capacity(robot.sole_friction, fz, margin))
