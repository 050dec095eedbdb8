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

__all__ = ["body_com", "leg_angles", "leg_cs", "leg_ik", "postures", "yaw_cos_sin"]

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


@kernel(inline="always")
def leg_cs(cs, k0, sgn, geom, px, py, pz, cty, sty, fx, fy, fz, cf, sf):
    """One flat foot's leg in closed form (Kajita et al., Introduction to Humanoid Robotics, §2.5), without
    its angles: the trunk level at yaw (cos, sin) = (cty, sty) with its origin at (px, py, pz), the sole at
    (fx, fy, fz) turned by the foot yaw (cos, sin) = (cf, sf).

    Writes the six joints' cosines and sines into cs[k0:k0+6] (hip yaw, roll, pitch, knee, ankle pitch,
    roll; what the CoM needs: they follow from the IK's triangle without an inverse trigonometric call).
    Returns whether the leg reaches, and the twelve intermediates :func:`leg_angles` turns into the angles.
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
    c4, s4 = -cos_k, math.sqrt(1.0 - cos_k * cos_k)
    c6, s6 = _cos_sin(r1, r2)
    sin_alpha = min(max(a * s4 / (c if c > 0 else 1.0), -1.0), 1.0)
    cos_alpha = math.sqrt(1.0 - sin_alpha * sin_alpha)
    g = (1.0 if r2 > 0 else (-1.0 if r2 < 0 else 0.0)) * math.sqrt(r1 * r1 + r2 * r2)
    cb_, sb_ = _cos_sin(r0, g)
    c5, s5 = cb_ * cos_alpha - sb_ * sin_alpha, -(sb_ * cos_alpha + cb_ * sin_alpha)
    ck, sk = c4 * c5 - s4 * s5, s4 * c5 + c4 * s5  # knee + ankle pitch
    # hip: Rz(δ) Rx(−roll) Ry(−(knee + pitch)) = Rz(q1) Rx(q2) Ry(q3), δ = foot yaw − trunk yaw: the
    # five entries used
    sd, cd = sf * cty - cf * sty, cf * cty + sf * sty
    r01, r11, r21, r20, r22 = -sd * c6, cd * c6, -s6, c6 * sk, c6 * ck
    c1, s1 = _cos_sin(-r01, r11)
    t = -r01 * s1 + r11 * c1
    c2, s2 = _cos_sin(r21, t)
    c3, s3 = _cos_sin(-r20, r22)
    cs[k0, 0], cs[k0 + 1, 0], cs[k0 + 2, 0], cs[k0 + 3, 0], cs[k0 + 4, 0], cs[k0 + 5, 0] = c1, c2, c3, c4, c5, c6
    cs[k0, 1], cs[k0 + 1, 1], cs[k0 + 2, 1], cs[k0 + 3, 1], cs[k0 + 4, 1], cs[k0 + 5, 1] = s1, s2, s3, s4, s5, s6
    return reach, (cos_k, r1, r2, sin_alpha, r0, g, r01, r11, r21, t, r20, r22)


@kernel(inline="always")
def leg_angles(q, k0, iv):
    """The six joint angles [rad] into q[k0:k0+6] from :func:`leg_cs`'s intermediates ``iv``: knee
    π − acos, the ankle roll atan2(r1, r2), the ankle pitch −atan2(r0, g) − asin(sin α), the hip's
    yaw, roll and pitch from the rotation's entries. Each lies in (−π, π]; with the hip above the
    ankle (r2 > 0) the ankle pitch too."""
    cos_k, r1, r2, sin_alpha, r0, g, r01, r11, r21, t, r20, r22 = iv
    q[k0], q[k0 + 1], q[k0 + 2] = math.atan2(-r01, r11), math.atan2(r21, t), math.atan2(-r20, r22)
    q[k0 + 3] = math.pi - math.acos(cos_k)
    q[k0 + 4] = -math.atan2(r0, g) - math.asin(sin_alpha)
    q[k0 + 5] = math.atan2(r1, r2)


@kernel
def leg_ik(q, cs, k0, sgn, geom, px, py, pz, cty, sty, fx, fy, fz, cf, sf):
    """One flat foot's leg in closed form (:func:`leg_cs`): the six joints [rad] into q[k0:k0+6], their
    cosines and sines into cs[k0:k0+6]; returns whether the leg reaches."""
    reach, iv = leg_cs(cs, k0, sgn, geom, px, py, pz, cty, sty, fx, fy, fz, cf, sf)
    leg_angles(q, k0, iv)
    return reach


@kernel(inline="always")
def _rot_z(cz, sz, v0, v1, v2):
    """Rz applied to (v0, v1, v2): :func:`_rot_zxyx` with the other three turns zero (the same bits)."""
    return cz * v0 - sz * v1, sz * v0 + cz * v1, v2


@kernel(inline="always")
def _rot_zx(cz, sz, cx, sx, v0, v1, v2):
    """Rz·Rx applied to (v0, v1, v2)."""
    y, z = cx * v1 - sx * v2, sx * v1 + cx * v2
    return cz * v0 - sz * y, sz * v0 + cz * y, z


@kernel(inline="always")
def _rot_zxy(cz, sz, cx, sx, cy, sy, v0, v1, v2):
    """Rz·Rx·Ry applied to (v0, v1, v2)."""
    z, x = cy * v2 - sy * v0, sy * v2 + cy * v0
    y, z = cx * v1 - sx * z, sx * v1 + cx * z
    return cz * x - sz * y, sz * x + cz * y, z


@kernel(inline="always")
def body_com(cs, trunk, joints, links, px, py, pz, cyaw, syaw):
    """Whole-body CoM (tests/oracles/leg.py's fast_com) from the joints' cosines and sines ``cs`` (12, 2):
    trunk, then the left leg's six links, then the right's. Each link's rotation composes only the turns of
    the joints above it (trunk yaw, hip yaw, roll, pitch, knee, ankle pitch, roll).

    Each leg's moments are summed on their own and the two added (addition commutes): the CoM of a
    posture mirrored left to right is the exact mirror of the CoM, to the bit."""
    x, y, z = _rot_z(cyaw, syaw, trunk[1], trunk[2], trunk[3])
    m_t = trunk[0]
    lx, ly, lz, m_left = 0.0, 0.0, 0.0, 0.0
    for leg in range(2):
        k0 = 6 * leg
        c1, c2, c3, c4, c5, c6 = cs[k0, 0], cs[k0 + 1, 0], cs[k0 + 2, 0], cs[k0 + 3, 0], cs[k0 + 4, 0], cs[k0 + 5, 0]
        s1, s2, s3, s4, s5, s6 = cs[k0, 1], cs[k0 + 1, 1], cs[k0 + 2, 1], cs[k0 + 3, 1], cs[k0 + 4, 1], cs[k0 + 5, 1]
        jx = joints[leg]
        lk = links[leg]
        hx, hy, hz = _rot_z(cyaw, syaw, jx[0, 0], jx[0, 1], jx[0, 2])
        hip0, hip1, hip2 = px + hx, py + hy, pz + hz
        cz, sz = cyaw * c1 - syaw * s1, syaw * c1 + cyaw * s1  # yaw + q1
        c34, s34 = c3 * c4 - s3 * s4, s3 * c4 + c3 * s4
        c345, s345 = c34 * c5 - s34 * s5, s34 * c5 + c34 * s5
        kx, ky, kz = _rot_zxy(cz, sz, c2, s2, c3, s3, jx[1, 0], jx[1, 1], jx[1, 2])
        kn0, kn1, kn2 = hip0 + kx, hip1 + ky, hip2 + kz
        ax, ay, az = _rot_zxy(cz, sz, c2, s2, c34, s34, jx[2, 0], jx[2, 1], jx[2, 2])
        an0, an1, an2 = kn0 + ax, kn1 + ay, kn2 + az
        # hip yaw, hip roll, thigh (hip pitch), shank (knee), ankle pitch, foot (ankle roll) links
        m = lk[0, 0]
        vx, vy, vz = _rot_z(cz, sz, lk[0, 1], lk[0, 2], lk[0, 3])
        mx, my, mz, total = 0.0 + m * (hip0 + vx), 0.0 + m * (hip1 + vy), 0.0 + m * (hip2 + vz), 0.0 + m
        m = lk[1, 0]
        vx, vy, vz = _rot_zx(cz, sz, c2, s2, lk[1, 1], lk[1, 2], lk[1, 3])
        mx, my, mz, total = mx + m * (hip0 + vx), my + m * (hip1 + vy), mz + m * (hip2 + vz), total + m
        m = lk[2, 0]
        vx, vy, vz = _rot_zxy(cz, sz, c2, s2, c3, s3, lk[2, 1], lk[2, 2], lk[2, 3])
        mx, my, mz, total = mx + m * (hip0 + vx), my + m * (hip1 + vy), mz + m * (hip2 + vz), total + m
        m = lk[3, 0]
        vx, vy, vz = _rot_zxy(cz, sz, c2, s2, c34, s34, lk[3, 1], lk[3, 2], lk[3, 3])
        mx, my, mz, total = mx + m * (kn0 + vx), my + m * (kn1 + vy), mz + m * (kn2 + vz), total + m
        m = lk[4, 0]
        vx, vy, vz = _rot_zxy(cz, sz, c2, s2, c345, s345, lk[4, 1], lk[4, 2], lk[4, 3])
        mx, my, mz, total = mx + m * (an0 + vx), my + m * (an1 + vy), mz + m * (an2 + vz), total + m
        m = lk[5, 0]
        vx, vy, vz = _rot_zxyx(cz, sz, c2, s2, c345, s345, lk[5, 1], lk[5, 2], lk[5, 3], c6, s6)
        mx, my, mz, total = mx + m * (an0 + vx), my + m * (an1 + vy), mz + m * (an2 + vz), total + m
        if leg == 0:
            lx, ly, lz, m_left = mx, my, mz, total
    total = m_t + (m_left + total)
    return ((m_t * (px + x) + (lx + mx)) / total, (m_t * (py + y) + (ly + my)) / total,
            (m_t * (pz + z) + (lz + mz)) / total)


@kernel
def yaw_cos_sin(yaw):
    """cos and sin of every yaw (N,) [rad], as the kernels compute them (the same bits)."""
    c, s = np.empty(len(yaw)), np.empty(len(yaw))
    for j in range(len(yaw)):
        c[j], s[j] = math.cos(yaw[j]), math.sin(yaw[j])
    return c, s


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
