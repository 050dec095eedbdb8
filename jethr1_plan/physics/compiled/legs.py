"""Both legs in closed form and the whole-body CoM, compiled (Kajita et al., *Introduction to Humanoid
Robotics*, §2.5): the one implementation of ``kinematics.closed_form.solve_postures`` and of every search's
kinematics. The numpy statements of the same formulas are the tests' oracle (``tests/oracles/leg.py``).

Everything robot-specific comes in as arrays built from the URDF by ``kinematics.closed_form``
(``closed_form_arrays``). Units: m, rad, kg.
"""

from __future__ import annotations

import math

import numpy as np

from jethr1_plan.physics.compiled.jit import kernel
from jethr1_plan.reasons import Reason

__all__ = ["body_com", "leg_ik", "postures"]

# the status codes as plain integers (compile-time constants in the kernels)
OK, UNREACHABLE, JOINT_LIMIT = int(Reason.OK), int(Reason.UNREACHABLE), int(Reason.JOINT_LIMIT)


@kernel(inline="always")
def _rot_zxyx(cz, sz, cx, sx, cy, sy, v0, v1, v2, cx2, sx2):
    """Rz·Rx·Ry·Rx2 applied to (v0, v1, v2), as tests/leg_oracle.py's rot_zxyx (angles as cosine, sine)."""
    x, y, z = v0, v1, v2
    y, z = cx2 * y - sx2 * z, sx2 * y + cx2 * z
    z, x = cy * z - sy * x, sy * z + cy * x
    y, z = cx * y - sx * z, sx * y + cx * z
    x, y = cz * x - sz * y, sz * x + cz * y
    return x, y, z


@kernel(inline="always")
def _cos_sin(y, x):
    """cos and sin of atan2(y, x) without the angle (1, 0 where x = y = 0, as atan2(0, 0) = 0)."""
    n = math.sqrt(x * x + y * y)
    if n == 0.0:
        return 1.0, 0.0
    return x / n, y / n


@kernel
def leg_ik(q, cs, k0, sgn, geom, px, py, pz, cty, sty, fx, fy, fz, cf, sf):
    """One flat foot's leg in closed form (Kajita et al., Introduction to Humanoid Robotics, §2.5): the
    trunk level at yaw (cos, sin) = (cty, sty) with its origin at (px, py, pz), the sole at
    (fx, fy, fz) turned by the foot yaw (cos, sin) = (cf, sf).

    Writes the six joints [rad] into q[k0:k0+6] and their cosines and sines into cs[k0:k0+6] (the
    CoM needs those, and they follow from the IK's triangle without calling cos and sin again).
    Returns whether the leg reaches.
    """
    w, a, b, ah = geom[0], geom[1], geom[2], geom[3]
    h0 = px - sty * (sgn * w) - fx  # hip − ankle in the world
    h1 = py + cty * (sgn * w) - fy
    r0, r1 = cf * h0 + sf * h1, -sf * h0 + cf * h1  # ... in the foot frame
    r2 = pz - (fz + ah)
    c = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
    cos_k = (a * a + b * b - c * c) / (2 * a * b)
    reach = cos_k >= -1.0 and cos_k <= 1.0 and c > 0
    cos_k = min(max(cos_k, -1.0), 1.0)
    knee = math.pi - math.acos(cos_k)
    c4, s4 = -cos_k, math.sqrt(1.0 - cos_k * cos_k)
    ankle_roll = math.atan2(r1, r2)
    c6, s6 = _cos_sin(r1, r2)
    sin_alpha = min(max(a * s4 / (c if c > 0 else 1.0), -1.0), 1.0)
    alpha = math.asin(sin_alpha)
    cos_alpha = math.sqrt(1.0 - sin_alpha * sin_alpha)
    g = (1.0 if r2 > 0 else (-1.0 if r2 < 0 else 0.0)) * math.sqrt(r1 * r1 + r2 * r2)
    beta = math.atan2(r0, g)
    cb_, sb_ = _cos_sin(r0, g)
    ankle_pitch = -beta - alpha
    c5, s5 = cb_ * cos_alpha - sb_ * sin_alpha, -(sb_ * cos_alpha + cb_ * sin_alpha)
    ck, sk = c4 * c5 - s4 * s5, s4 * c5 + c4 * s5  # knee + ankle pitch
    # hip: Rz(δ) Rx(−roll) Ry(−(knee + pitch)) = Rz(q1) Rx(q2) Ry(q3), δ = foot yaw − trunk yaw: the
    # five entries used
    sd, cd = sf * cty - cf * sty, cf * cty + sf * sty
    r01, r11, r21, r20, r22 = -sd * c6, cd * c6, -s6, c6 * sk, c6 * ck
    hip_yaw = math.atan2(-r01, r11)
    c1, s1 = _cos_sin(-r01, r11)
    t = -r01 * s1 + r11 * c1
    hip_roll = math.atan2(r21, t)
    c2, s2 = _cos_sin(r21, t)
    hip_pitch = math.atan2(-r20, r22)
    c3, s3 = _cos_sin(-r20, r22)
    q[k0], q[k0 + 1], q[k0 + 2] = hip_yaw, hip_roll, hip_pitch
    q[k0 + 3], q[k0 + 4], q[k0 + 5] = knee, ankle_pitch, ankle_roll
    cs[k0, 0], cs[k0 + 1, 0], cs[k0 + 2, 0], cs[k0 + 3, 0], cs[k0 + 4, 0], cs[k0 + 5, 0] = c1, c2, c3, c4, c5, c6
    cs[k0, 1], cs[k0 + 1, 1], cs[k0 + 2, 1], cs[k0 + 3, 1], cs[k0 + 4, 1], cs[k0 + 5, 1] = s1, s2, s3, s4, s5, s6
    return reach


@kernel
def body_com(cs, trunk, joints, links, px, py, pz, cyaw, syaw):
    """Whole-body CoM (tests/leg_oracle.py's fast_com) from the joints' cosines and sines ``cs`` (12, 2):
    trunk, then the left leg's six links, then the right's."""
    x, y, z = _rot_zxyx(cyaw, syaw, 1.0, 0.0, 1.0, 0.0, trunk[1], trunk[2], trunk[3], 1.0, 0.0)
    m_t = trunk[0]
    mx, my, mz = m_t * (px + x), m_t * (py + y), m_t * (pz + z)
    total = m_t
    for leg in range(2):
        k0 = 6 * leg
        c1, c2, c3, c4, c5, c6 = cs[k0, 0], cs[k0 + 1, 0], cs[k0 + 2, 0], cs[k0 + 3, 0], cs[k0 + 4, 0], cs[k0 + 5, 0]
        s1, s2, s3, s4, s5, s6 = cs[k0, 1], cs[k0 + 1, 1], cs[k0 + 2, 1], cs[k0 + 3, 1], cs[k0 + 4, 1], cs[k0 + 5, 1]
        jx = joints[leg]
        hx, hy, hz = _rot_zxyx(cyaw, syaw, 1.0, 0.0, 1.0, 0.0, jx[0, 0], jx[0, 1], jx[0, 2], 1.0, 0.0)
        hip0, hip1, hip2 = px + hx, py + hy, pz + hz
        cz, sz = cyaw * c1 - syaw * s1, syaw * c1 + cyaw * s1  # yaw + q1
        c34, s34 = c3 * c4 - s3 * s4, s3 * c4 + c3 * s4
        c345, s345 = c34 * c5 - s34 * s5, s34 * c5 + c34 * s5
        kx, ky, kz = _rot_zxyx(cz, sz, c2, s2, c3, s3, jx[1, 0], jx[1, 1], jx[1, 2], 1.0, 0.0)
        kn0, kn1, kn2 = hip0 + kx, hip1 + ky, hip2 + kz
        ax, ay, az = _rot_zxyx(cz, sz, c2, s2, c34, s34, jx[2, 0], jx[2, 1], jx[2, 2], 1.0, 0.0)
        an0, an1, an2 = kn0 + ax, kn1 + ay, kn2 + az
        for i in range(6):
            m = links[leg, i, 0]
            cr, sr, cp, sp, cr2, sr2 = c2, s2, 1.0, 0.0, 1.0, 0.0
            o0, o1, o2 = hip0, hip1, hip2
            if i == 0:
                cr, sr = 1.0, 0.0
            elif i == 2:
                cp, sp = c3, s3
            elif i == 3:
                cp, sp = c34, s34
                o0, o1, o2 = kn0, kn1, kn2
            elif i >= 4:
                cp, sp = c345, s345
                o0, o1, o2 = an0, an1, an2
                if i == 5:
                    cr2, sr2 = c6, s6
            vx, vy, vz = _rot_zxyx(cz, sz, cr, sr, cp, sp, links[leg, i, 1], links[leg, i, 2], links[leg, i, 3],
                                   cr2, sr2)
            mx, my, mz = mx + m * (o0 + vx), my + m * (o1 + vy), mz + m * (o2 + vz)
            total += m
    return mx / total, my / total, mz / total


@kernel
def postures(P, yaw, feet, feet_yaw, geom, trunk, joints, links, limits):
    """Both legs in closed form and the whole-body CoM for trunk positions P (N, 3) [m] at yaws (N,) [rad],
    the soles at feet (N, 2, 3) [m] (left, right) turned by feet_yaw (N, 2) [rad]: joints (N, 12) [rad],
    CoM (N, 3) [m], status (N,) (kinematics.OK, UNREACHABLE or JOINT_LIMIT)."""
    n = len(P)
    q_out, com_out = np.empty((n, 12)), np.empty((n, 3))
    status = np.empty(n, dtype=np.int8)
    q = np.empty(12)
    cs = np.empty((12, 2))
    for j in range(n):
        px, py, pz = P[j, 0], P[j, 1], P[j, 2]
        cty, sty = math.cos(yaw[j]), math.sin(yaw[j])
        reach = True
        for leg in range(2):
            sgn = 1.0 if leg == 0 else -1.0
            fyaw = feet_yaw[j, leg]
            reach &= leg_ik(q, cs, 6 * leg, sgn, geom, px, py, pz, cty, sty, feet[j, leg, 0], feet[j, leg, 1],
                             feet[j, leg, 2], math.cos(fyaw), math.sin(fyaw))
        within = True
        for k in range(12):
            within &= (q[k] >= limits[0, k]) and (q[k] <= limits[1, k])
            q_out[j, k] = q[k]
        status[j] = UNREACHABLE if not reach else (OK if within else JOINT_LIMIT)
        com_out[j, 0], com_out[j, 1], com_out[j, 2] = body_com(cs, trunk, joints, links, px, py, pz, cty, sty)
    return q_out, com_out, status
