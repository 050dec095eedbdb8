"""The numpy closed-form leg IK and CoM, and a vectorised forward kinematics from the URDF: the
oracle the compiled ``physics.compiled.postures`` is held to (``kinematics.closed_form.solve_postures``).

Batch-last rotations (3, 3, N): numpy's einsum over that layout is several times faster than matmul
over (N, 3, 3) stacks of small matrices.
"""

from __future__ import annotations

import numpy as np

from jethr1_plan.kinematics.closed_form import LegGeometry, leg_mass_model, mass_model, mm_batch, rot_axis
from jethr1_plan.robot.model import RobotModel


def _mv(A: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Batch-last (3, 3, N) × a constant vector (3,) → (3, N)."""
    return np.einsum("ijn,j->in", A, v)


def leg_ik(geom: LegGeometry, side: str, trunk_xyz: np.ndarray, trunk_yaw: np.ndarray, foot_xyz: np.ndarray,
           foot_yaw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Joint angles (N, 6) [rad] of one leg for level trunk and flat foot poses; and reach (N,) bool.

    Args:
        trunk_xyz, foot_xyz: (N, 3) [m]; trunk_yaw, foot_yaw: (N,) [rad] or scalars.
    """
    sgn = 1.0 if side == "left" else -1.0
    trunk_xyz, foot_xyz = np.atleast_2d(trunk_xyz), np.atleast_2d(foot_xyz)
    n = max(len(trunk_xyz), len(foot_xyz))
    ty = np.broadcast_to(np.asarray(trunk_yaw, dtype=float), (n,))
    fy = np.broadcast_to(np.asarray(foot_yaw, dtype=float), (n,))
    hip = trunk_xyz + np.stack([-np.sin(ty), np.cos(ty), np.zeros(n)], axis=1) * (sgn * geom.hip_offset_m)
    ankle = foot_xyz + np.array([0.0, 0.0, geom.ankle_height_m])  # flat feet: the sole normal is z
    d = hip - ankle
    cf, sf = np.cos(fy), np.sin(fy)
    r = np.stack([cf * d[:, 0] + sf * d[:, 1], -sf * d[:, 0] + cf * d[:, 1], d[:, 2]], axis=1)  # foot frame
    a, b = geom.thigh_m, geom.shank_m
    c = np.sqrt(np.einsum("ni,ni->n", r, r))
    cos_k = (a * a + b * b - c * c) / (2 * a * b)
    reach = (cos_k >= -1.0) & (cos_k <= 1.0) & (c > 0)
    cos_k = np.clip(cos_k, -1.0, 1.0)
    knee = np.pi - np.arccos(cos_k)
    ankle_roll = np.arctan2(r[:, 1], r[:, 2])
    alpha = np.arcsin(np.clip(a * np.sin(np.pi - knee) / np.where(c > 0, c, 1.0), -1.0, 1.0))
    ankle_pitch = -np.arctan2(r[:, 0], np.sign(r[:, 2]) * np.hypot(r[:, 1], r[:, 2])) - alpha
    # hip: Rz(δ) Rx(A) Ry(B) = Rz(q1) Rx(q2) Ry(q3) with δ = fy − ty, A = −q6, B = −(q4 + q5);
    # the five entries used, written out elementwise
    sd, cd = np.sin(fy - ty), np.cos(fy - ty)
    sa, ca = np.sin(-ankle_roll), np.cos(-ankle_roll)
    sb, cb = np.sin(-(knee + ankle_pitch)), np.cos(-(knee + ankle_pitch))
    r01, r11, r21, r20, r22 = -sd * ca, cd * ca, sa, -ca * sb, ca * cb
    hip_yaw = np.arctan2(-r01, r11)
    hip_roll = np.arctan2(r21, -r01 * np.sin(hip_yaw) + r11 * np.cos(hip_yaw))
    hip_pitch = np.arctan2(-r20, r22)
    q = np.stack([hip_yaw, hip_roll, hip_pitch, knee, ankle_pitch, ankle_roll], axis=1)
    return q, reach


def link_poses(robot: RobotModel, trunk_xyz: np.ndarray, trunk_yaw: np.ndarray, q: np.ndarray
               ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """World (R (3, 3, N), p (3, N)) of every URDF link for trunk poses and joints ``q`` (N, 12)."""
    _, chain = mass_model(robot)
    q = np.atleast_2d(q)
    n = len(q)
    poses = {"trunk": (rot_axis((0, 0, 1), np.broadcast_to(np.asarray(trunk_yaw, dtype=float), (n,))),
                       np.broadcast_to(np.asarray(trunk_xyz, dtype=float), (n, 3)).T)}
    for j, k, R0, xyz in chain:
        R_parent, p_parent = poses[j.parent]
        p = p_parent + _mv(R_parent, xyz) if xyz.any() else p_parent
        R = R_parent if R0 is None else mm_batch(R_parent, np.broadcast_to(R0, (3, 3, n)))
        if k is not None:
            R = mm_batch(R, rot_axis(j.axis, q[:, k]))
        poses[j.child] = (R, p)
    return poses


def com_batch(robot: RobotModel, trunk_xyz: np.ndarray, trunk_yaw: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Whole-body CoM (N, 3) [m]: Σ m_i (R_i c_i + p_i) / M over the URDF's links."""
    links, _ = mass_model(robot)
    poses = link_poses(robot, trunk_xyz, trunk_yaw, q)
    total = 0.0
    moment = np.zeros((3, len(np.atleast_2d(q))))
    for name, (m, c) in links.items():
        R, p = poses[name]
        moment += m * p
        if c.any():
            moment += _mv(R, m * c)
        total += m
    return (moment / total).T


def _mul(a, b):
    """a·b where either may be the exact scalar 0.0 or 1.0 (then no array work is done)."""
    if isinstance(a, float):
        return 0.0 if a == 0.0 else (b if a == 1.0 else a * b)
    if isinstance(b, float):
        return 0.0 if b == 0.0 else (a if b == 1.0 else a * b)
    return a * b


def _add(a, b):
    if isinstance(a, float) and a == 0.0:
        return b
    if isinstance(b, float) and b == 0.0:
        return a
    return a + b


def _rot(c, s, u, w):
    """(c·u − s·w, s·u + c·w): a plane rotation, skipping the work on exact zeros."""
    return _add(_mul(c, u), -_mul(s, w)), _add(_mul(s, u), _mul(c, w))


def _rot_zxyx(cz, sz, cx, sx, cy, sy, v, cx2=None, sx2=None):
    """Rz·Rx·Ry (·Rx2) applied to a constant vector ``v`` (3,), elementwise over the angle arrays.

    Angles may be given as the floats 1.0/0.0 (cos/sin of zero): the zero terms of the usually
    sparse link vectors then cost nothing.
    """
    x, y, z = float(v[0]), float(v[1]), float(v[2])
    if cx2 is not None:  # innermost Rx2
        y, z = _rot(cx2, sx2, y, z)
    z, x = _rot(cy, sy, z, x)  # Ry: x' = c x + s z, z' = −s x + c z
    y, z = _rot(cx, sx, y, z)  # Rx
    x, y = _rot(cz, sz, x, y)  # Rz
    return x, y, z


def fast_com(robot: RobotModel, trunk_xyz: np.ndarray, trunk_yaw: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Whole-body CoM (N, 3) [m] for the closed-form leg structure, written out elementwise.

    Equal to :func:`com_batch` (tested to 1e-12 m) and several times faster: each link frame of a
    leg is Rz(yaw + q1)·Rx(q2)·Ry(q3 + …) applied to constant vectors read from the URDF.
    """
    (m_t, c_t), legs = leg_mass_model(robot)
    q = np.atleast_2d(q)
    n = len(q)
    yaw = np.broadcast_to(np.asarray(trunk_yaw, dtype=float), (n,))
    p = np.broadcast_to(np.asarray(trunk_xyz, dtype=float), (n, 3))
    cyaw, syaw = np.cos(yaw), np.sin(yaw)
    one, zero = 1.0, 0.0
    x, y, z = _rot_zxyx(cyaw, syaw, one, zero, one, zero, c_t)
    mx, my, mz = m_t * (p[:, 0] + x), m_t * (p[:, 1] + y), m_t * (p[:, 2] + z)
    total = m_t
    for k0, side in ((0, "left"), (6, "right")):
        leg = legs[side]
        q1, q2, q3, q4, q5, q6 = (q[:, k0 + i] for i in range(6))
        hx, hy, hz = _rot_zxyx(cyaw, syaw, one, zero, one, zero, leg["hip_xyz"])
        hip = (p[:, 0] + hx, p[:, 1] + hy, p[:, 2] + hz)
        psi = yaw + q1
        cz, sz = np.cos(psi), np.sin(psi)
        cx, sx = np.cos(q2), np.sin(q2)
        angles = [(one, zero), (one, zero), (np.cos(q3), np.sin(q3)), (np.cos(q3 + q4), np.sin(q3 + q4)),
                  (np.cos(q3 + q4 + q5), np.sin(q3 + q4 + q5))]
        rolls = [(one, zero), (cx, sx), (cx, sx), (cx, sx), (cx, sx)]
        kx, ky, kz = _rot_zxyx(cz, sz, cx, sx, *angles[2], leg["knee_xyz"])
        knee = (hip[0] + kx, hip[1] + ky, hip[2] + kz)
        ax_, ay_, az_ = _rot_zxyx(cz, sz, cx, sx, *angles[3], leg["ankle_xyz"])
        ankle = (knee[0] + ax_, knee[1] + ay_, knee[2] + az_)
        origins = [hip, hip, hip, knee, ankle]
        for (m, c), origin, (cr, sr), (cp, sp) in zip(leg["links"][:5], origins, rolls, angles, strict=True):
            vx, vy, vz = _rot_zxyx(cz, sz, cr, sr, cp, sp, c)
            mx, my, mz = mx + m * (origin[0] + vx), my + m * (origin[1] + vy), mz + m * (origin[2] + vz)
            total += m
        m, c = leg["links"][5]  # the foot link, turned by the ankle roll too
        vx, vy, vz = _rot_zxyx(cz, sz, cx, sx, *angles[4], c, np.cos(q6), np.sin(q6))
        mx, my, mz = mx + m * (ankle[0] + vx), my + m * (ankle[1] + vy), mz + m * (ankle[2] + vz)
        total += m
    return np.stack([mx, my, mz], axis=1) / total
