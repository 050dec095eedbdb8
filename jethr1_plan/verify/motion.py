"""The motion written rows imply and the wrench the ground must give for it, as ``verify`` recomputes them
(docs/physics.md, "The rows' own motion"; docs/walking.md), not from the planner's code
(``physics/row_dynamics.py``):

* each row's generalised velocity and acceleration from its neighbours alone, by second central
  differences; the trunk's step from row k − 1 to row k is the logarithm on SE(3) of their relative
  pose, taken here from the relative quaternion in closed form (the planner uses
  ``geometry.pose_difference``); beyond both ends the robot holds its posture;
* the wrench the world supplies: the floating base's six rows of M(q)·a + h(q, v) (PlaCo, in the
  trunk's frame about its origin) moved to the world; the fans' written thrust pushes up at each fan.
"""

from __future__ import annotations

import numpy as np

from jethr1_plan.geometry import pose_from_quaternion

__all__ = ["base_wrench", "row_motion", "twist", "twists", "vertical_ground_force"]


def twist(quat0: np.ndarray, p0: np.ndarray, quat1: np.ndarray, p1: np.ndarray) -> np.ndarray:
    """(6,) the twist (linear, angular; in the first pose's frame) from pose (p0, quat0) to (p1, quat1)
    in unit time: the logarithm on SE(3), from the relative quaternion (x, y, z, w)."""
    x0, y0, z0, w0 = quat0
    x1, y1, z1, w1 = quat1
    # q0* ⊗ q1
    rel = np.array([w0 * x1 - x0 * w1 - y0 * z1 + z0 * y1, w0 * y1 + x0 * z1 - y0 * w1 - z0 * x1,
                    w0 * z1 - x0 * y1 + y0 * x1 - z0 * w1, w0 * w1 + x0 * x1 + y0 * y1 + z0 * z1])
    if rel[3] < 0:
        rel = -rel
    s = float(np.linalg.norm(rel[:3]))
    theta = 2.0 * np.arctan2(s, rel[3])
    omega = rel[:3] * (theta / s if s > 1e-12 else 2.0)
    local = pose_from_quaternion(np.zeros(3), quat0)[:3, :3].T @ (np.asarray(p1) - p0)
    half = theta / 2.0
    c = 1.0 / 12.0 if theta < 1e-4 else (1.0 - half / np.tan(half)) / theta**2
    lin = local - 0.5 * np.cross(omega, local) + c * np.cross(omega, np.cross(omega, local))
    return np.concatenate([lin, omega])


def twists(quat0: np.ndarray, p0: np.ndarray, quat1: np.ndarray, p1: np.ndarray) -> np.ndarray:
    """(N, 6) :func:`twist` of N pose pairs at once: quat0, quat1 (N, 4) unit quaternions (x, y, z, w), p0, p1
    (N, 3) [m]; the same formula, each row's value that of :func:`twist` to round-off."""
    x0, y0, z0, w0 = np.asarray(quat0, dtype=float).T
    x1, y1, z1, w1 = np.asarray(quat1, dtype=float).T
    # q0* ⊗ q1, the shorter way round (w ≥ 0)
    rel = np.stack([w0 * x1 - x0 * w1 - y0 * z1 + z0 * y1, w0 * y1 + x0 * z1 - y0 * w1 - z0 * x1,
                    w0 * z1 - x0 * y1 + y0 * x1 - z0 * w1, w0 * w1 + x0 * x1 + y0 * y1 + z0 * z1], axis=1)
    rel = np.where(rel[:, 3:] < 0, -rel, rel)
    s = np.sqrt(np.einsum("ni,ni->n", rel[:, :3], rel[:, :3]))
    theta = 2.0 * np.arctan2(s, rel[:, 3])
    omega = rel[:, :3] * np.where(s > 1e-12, theta / np.where(s > 1e-12, s, 1.0), 2.0)[:, None]
    # the first pose's rotation (geometry.pose_from_quaternion's) transposed, applied to p1 − p0
    R = np.empty((len(x0), 3, 3))
    R[:, 0, 0], R[:, 0, 1], R[:, 0, 2] = 1 - 2 * (y0 * y0 + z0 * z0), 2 * (x0 * y0 - z0 * w0), 2 * (x0 * z0 + y0 * w0)
    R[:, 1, 0], R[:, 1, 1], R[:, 1, 2] = 2 * (x0 * y0 + z0 * w0), 1 - 2 * (x0 * x0 + z0 * z0), 2 * (y0 * z0 - x0 * w0)
    R[:, 2, 0], R[:, 2, 1], R[:, 2, 2] = 2 * (x0 * z0 - y0 * w0), 2 * (y0 * z0 + x0 * w0), 1 - 2 * (x0 * x0 + y0 * y0)
    local = np.einsum("nji,nj->ni", R, np.asarray(p1, dtype=float) - np.asarray(p0, dtype=float))
    small = theta < 1e-4
    half = np.where(small, 1.0, theta / 2.0)  # (a stand-in where the series is used)
    c = np.where(small, 1.0 / 12.0, (1.0 - half / np.tan(half)) / np.where(small, 1.0, theta) ** 2)
    lin = local - 0.5 * np.cross(omega, local) + c[:, None] * np.cross(omega, np.cross(omega, local))
    return np.concatenate([lin, omega], axis=1)


def row_motion(pos: np.ndarray, quat: np.ndarray, q: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(v, a) (N, 6 + J) at each row from its neighbours alone: with D_k the twist from row k − 1 to row
    k (the trunk's in its own frame at row k − 1, :func:`twists`; the joints' differences), the step back
    from row i is −D_i, so v_i = (D_i+1 + D_i)/2Δt and a_i = (D_i+1 − D_i)/Δt²; the robot holds its posture
    beyond both ends.

    Args:
        pos: (N, 3) the trunk's positions [m]; quat: (N, 4) its unit quaternions (x, y, z, w); q: (N, J)
            the joints [rad]; dt: the rows' period [s].
    """
    n, nj = q.shape
    D = np.zeros((n + 1, 6 + nj))  # D[k]: from row k − 1 to row k (zero beyond the ends)
    if n > 1:
        D[1:n, :6] = twists(quat[:-1], pos[:-1], quat[1:], pos[1:])
        D[1:n, 6:] = q[1:] - q[:-1]
    return (D[1:] + D[:-1]) / (2.0 * dt), (D[1:] - D[:-1]) / dt**2


def base_wrench(T_base: np.ndarray, generalised: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(force [N], moment about the world's origin [N·m]) in the world that the first six generalised forces
    (force then moment, in the trunk's frame about its origin) stand for."""
    R, p = T_base[:3, :3], T_base[:3, 3]
    force = R @ generalised[:3]
    return force, R @ generalised[3:6] + np.cross(p, force)


def vertical_ground_force(robot, pos: np.ndarray, quat: np.ndarray, q: np.ndarray, thrust_n: np.ndarray,
                          dt: float) -> np.ndarray:
    """(N,) the vertical force [N] the ground must give for the written rows' motion: the world's vertical
    force on the robot less the fans' thrust (each pushes straight up).

    Args:
        robot: the robot model; pos, quat, q, dt: as :func:`row_motion`; thrust_n: (N, F) [N].
    """
    v, acc = row_motion(pos, quat, q, dt)
    w = robot.wrapper()
    generalised = np.empty((len(q), 3))  # the first three generalised forces: the force in the trunk's frame
    for i in range(len(q)):
        w.state.q[:3] = pos[i]
        w.state.q[3:7] = quat[i]
        w.state.q[7:] = q[i]
        w.state.qd = v[i]
        w.state.qdd = acc[i]
        w.update_kinematics()
        generalised[i] = (w.mass_matrix() @ acc[i] + w.non_linear_effects())[:3]
    # the world's vertical force: the last row of each trunk's rotation (geometry.pose_from_quaternion's) times it
    x, y, z, qw = np.asarray(quat, dtype=float).T
    up = np.stack([2 * (x * z - y * qw), 2 * (y * z + x * qw), 1 - 2 * (x * x + y * y)], axis=1)
    return np.einsum("ni,ni->n", up, generalised) - np.sum(thrust_n, axis=1)
