"""The per-candidate physics, compiled (numba): the one implementation every caller uses.

* both legs' closed-form IK and the whole-body CoM (:func:`postures`; ``kinematics.closed_form.solve_postures``);
* the thrust window of (A-1, A-2) under any tolerance (:func:`windows`; ``balance.thrust_window``);
* the edge angle of (A-10) (:func:`edge_errors`; ``balance.edge_angle_error``);
* the legs' reach balls and joint limits (:func:`into_reach`, :func:`into_leg`), and the balance-space
  objective fusing all of them in
  one loop per candidate (:func:`balance_objective`; :func:`objective_into` and :func:`into_reach_one`
  are the same for callers compiled themselves, ``search``'s compass);
* one swing sample's smooth constraints and exact least thrust (:func:`sample_terms`), what SLSQP
  (``optimisers.sqp``) evaluates thousands of times per path.

In numpy the objective is ~1,300 array operations per batch, each a pass over memory; here one loop
whose per-candidate arithmetic stays in registers (about 10x faster). The numpy statements of the
same formulas are the tests' oracles (``tests/leg_oracle.py``, ``tests/oracle.py``); the tests hold
the two to rounding. Everything robot-specific comes in as arrays built from the URDF model by
``kinematics.closed_form`` (``closed_form_arrays``, ``kernel_params``).

Units: m, rad, kg, N.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from jethr1_plan.reasons import Reason

__all__ = ["balance_objective", "edge_errors", "into_reach", "into_reach_one", "objective_into", "objective_scratch",
           "postures", "sample_terms", "windows"]

# the reason codes as plain integers (compile-time constants in the kernels)
OK, UNREACHABLE, JOINT_LIMIT = int(Reason.OK), int(Reason.UNREACHABLE), int(Reason.JOINT_LIMIT)
NO_BALANCE, THRUST_MAX, EDGE_ANGLE = int(Reason.NO_BALANCE), int(Reason.THRUST_MAX), int(Reason.EDGE_ANGLE)


@numba.njit(cache=True, inline="always")
def _rot_zxyx(cz, sz, cx, sx, cy, sy, v0, v1, v2, cx2, sx2):
    """Rz·Rx·Ry·Rx2 applied to (v0, v1, v2), as tests/leg_oracle.py's rot_zxyx (angles as cosine, sine)."""
    x, y, z = v0, v1, v2
    y, z = cx2 * y - sx2 * z, sx2 * y + cx2 * z
    z, x = cy * z - sy * x, sy * z + cy * x
    y, z = cx * y - sx * z, sx * y + cx * z
    x, y = cz * x - sz * y, sz * x + cz * y
    return x, y, z


@numba.njit(cache=True, inline="always")
def _cos_sin(y, x):
    """cos and sin of atan2(y, x) without the angle (1, 0 where x = y = 0, as atan2(0, 0) = 0)."""
    n = math.sqrt(x * x + y * y)
    if n == 0.0:
        return 1.0, 0.0
    return x / n, y / n


@numba.njit(cache=True)
def _leg_ik(q, cs, k0, sgn, geom, px, py, pz, cty, sty, fx, fy, fz, cf, sf):
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


@numba.njit(cache=True)
def _com(cs, trunk, joints, links, px, py, pz, cyaw, syaw):
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


@numba.njit(cache=True, inline="always")
def _edge_need(cx, cy, nx, ny, off, weight, tol_mass, tol_com):
    """The right-hand side of one edge's row: M·g·((d + ε) + Y·|d + ε|), d the CoM's distance beyond
    the edge [N·m]."""
    d = cx * nx + cy * ny - off + tol_com
    return weight * (d + tol_mass * abs(d))


@numba.njit(cache=True, inline="always")
def _fan_lift(fx, fy, nx, ny, off, tol_thrust):
    """One fan's coefficient in one edge's row: a − X·|a|, a the fan's distance beyond the edge [m]."""
    a = fx * nx + fy * ny - off
    return a - tol_thrust * abs(a)


@numba.njit(cache=True, inline="always")
def _cap(weight, tol_thrust, tol_mass):
    """The largest total thrust the ZMP formula admits: F(1 + X) < M·g(1 − Y) [N]."""
    return weight * (1.0 - tol_mass) / (1.0 + tol_thrust) * (1.0 - 1e-9)


@numba.njit(cache=True, inline="always")
def _bound(lo, hi, blocked, coef, rhs):
    """One edge's row T·coef ≥ rhs applied to the window [lo, hi]: a lower bound (coef > 0), an upper
    bound (coef < 0), or, where no thrust moves the ZMP across the edge (coef = 0), blocked if the
    CoM lies beyond it."""
    if coef > 0:
        lo = max(lo, rhs / coef)
    elif coef < 0:
        hi = min(hi, rhs / coef)
    elif rhs > 0:
        blocked = True
    return lo, hi, blocked


@numba.njit(cache=True, inline="always")
def _window(cx, cy, fx, fy, normals, offsets, weight, tol_thrust, tol_mass, tol_com):
    """(lo, hi, blocked) of balance.thrust_window for one CoM and one fan: per edge k,
    F·(a_k − X|a_k|) ≥ M·g·((d_k + ε) + Y|d_k + ε|), d_k and a_k the CoM's and the fan's distances beyond
    edge k; ``blocked`` where an edge no thrust moves the ZMP across lies on the wrong side."""
    lo, hi = 0.0, _cap(weight, tol_thrust, tol_mass)
    blocked = False
    for k in range(len(offsets)):
        rhs = _edge_need(cx, cy, normals[k, 0], normals[k, 1], offsets[k], weight, tol_mass, tol_com)
        coef = _fan_lift(fx, fy, normals[k, 0], normals[k, 1], offsets[k], tol_thrust)
        lo, hi, blocked = _bound(lo, hi, blocked, coef, rhs)
    return lo, hi, blocked


@numba.njit(cache=True)
def _thrust_lo(cx, cy, fx, fy, normals, offsets, weight, tol_thrust, tol_mass, tol_com):
    """The window's lower end for one CoM (inf where the window is empty). With the tolerance zero this
    is the minimal thrust H(P_body) of (A-5)."""
    lo, hi, blocked = _window(cx, cy, fx, fy, normals, offsets, weight, tol_thrust, tol_mass, tol_com)
    return lo if (lo <= hi and not blocked) else np.inf


@numba.njit(cache=True)
def windows(com, fan, normals, offsets, weight, tol_thrust, tol_mass, tol_com):
    """balance.window_bounds over rows: com, fan (N, 2) [m] → lo, hi (N,) [N], blocked (N,)."""
    n = len(com)
    lo, hi, blocked = np.empty(n), np.empty(n), np.empty(n, dtype=np.bool_)
    for j in range(n):
        lo[j], hi[j], blocked[j] = _window(com[j, 0], com[j, 1], fan[j, 0], fan[j, 1], normals, offsets, weight,
                                           tol_thrust, tol_mass, tol_com)
    return lo, hi, blocked


@numba.njit(cache=True)
def _window_mix(cx, cy, fxs, fys, share, normals, offsets, weight, tol_thrust, tol_mass, tol_com):
    """(lo, hi, blocked) of the total thrust T of several fans carrying the fixed shares ``share``
    (F,) (summing to 1) of it: per edge k, T·Σ_i share_i·(a_ik − X|a_ik|) ≥ M·g·((d_k + ε) + Y|d_k + ε|).
    With one fan (share 1) it is :func:`_window`."""
    lo, hi = 0.0, _cap(weight, tol_thrust, tol_mass)
    blocked = False
    for k in range(len(offsets)):
        rhs = _edge_need(cx, cy, normals[k, 0], normals[k, 1], offsets[k], weight, tol_mass, tol_com)
        coef = 0.0
        for i in range(len(fxs)):
            coef += share[i] * _fan_lift(fxs[i], fys[i], normals[k, 0], normals[k, 1], offsets[k], tol_thrust)
        lo, hi, blocked = _bound(lo, hi, blocked, coef, rhs)
    return lo, hi, blocked


@numba.njit(cache=True)
def _solve_small(A, b, x):
    """Solve the n × n system A x = b in place by Gaussian elimination with partial pivoting; False
    where A is singular (a pivot below 1e-12 of the largest entry)."""
    n = len(b)
    scale = 0.0
    for i in range(n):
        for j in range(n):
            scale = max(scale, abs(A[i, j]))
    if scale == 0.0:
        return False
    for c in range(n):
        p = c
        for r in range(c + 1, n):
            if abs(A[r, c]) > abs(A[p, c]):
                p = r
        if abs(A[p, c]) <= 1e-12 * scale:
            return False
        if p != c:
            for j in range(n):
                A[c, j], A[p, j] = A[p, j], A[c, j]
            b[c], b[p] = b[p], b[c]
        for r in range(c + 1, n):
            f = A[r, c] / A[c, c]
            for j in range(c, n):
                A[r, j] -= f * A[c, j]
            b[r] -= f * b[c]
    for c in range(n - 1, -1, -1):
        acc = b[c]
        for j in range(c + 1, n):
            acc -= A[c, j] * x[j]
        x[c] = acc / A[c, c]
    return True


@numba.njit(cache=True)
def least_total(cx, cy, fxs, fys, fmax, normals, offsets, weight, tol_thrust, tol_mass, tol_com, bounded, out):
    """The least total thrust of F fans that balances one CoM: a linear programme,

        min Σ_i F_i  s.t.  Σ_i F_i·(a_ik − X|a_ik|) ≥ M·g·((d_k + ε) + Y|d_k + ε|) for every edge k,
                           Σ_i F_i·(1 + X) ≤ M·g·(1 − Y),  F_i ≥ 0  (and F_i ≤ fmax_i if ``bounded``),

    solved by enumerating its vertices (F of the constraints active; F is small: the fans of a swing
    foot and the trunk). Writes the thrusts into ``out`` (F,) [N]; returns the total [N], inf where
    no thrust balances (``out`` then NaN). The tests hold it to SciPy's HiGHS."""
    nf, nk = len(fxs), len(offsets)
    rows = nk + 1 + nf + (nf if bounded else 0)
    G = np.zeros((rows, nf))
    h = np.zeros(rows)
    for k in range(nk):
        h[k] = _edge_need(cx, cy, normals[k, 0], normals[k, 1], offsets[k], weight, tol_mass, tol_com)
        for i in range(nf):
            G[k, i] = _fan_lift(fxs[i], fys[i], normals[k, 0], normals[k, 1], offsets[k], tol_thrust)
    for i in range(nf):
        G[nk, i] = -(1.0 + tol_thrust)
        G[nk + 1 + i, i] = 1.0
        if bounded:
            G[nk + 1 + nf + i, i] = -1.0
            h[nk + 1 + nf + i] = -fmax[i]
    h[nk] = -weight * (1.0 - tol_mass) * (1.0 - 1e-9)
    best = np.inf
    for i in range(nf):
        out[i] = np.nan
    idx = np.arange(nf)
    A = np.empty((nf, nf))
    b = np.empty(nf)
    x = np.empty(nf)
    while True:
        for r in range(nf):
            for c in range(nf):
                A[r, c] = G[idx[r], c]
            b[r] = h[idx[r]]
        if _solve_small(A, b, x):
            total = 0.0
            ok = True
            for r in range(rows):
                lhs = 0.0
                for c in range(nf):
                    lhs += G[r, c] * x[c]
                if lhs < h[r] - 1e-9 * (1.0 + abs(h[r])):
                    ok = False
                    break
            if ok:
                for c in range(nf):
                    total += max(x[c], 0.0)
                if total < best:
                    best = total
                    for c in range(nf):
                        out[c] = max(x[c], 0.0)
        # the next combination of nf rows out of ``rows``, in lexicographic order
        r = nf - 1
        while r >= 0 and idx[r] == rows - nf + r:
            r -= 1
        if r < 0:
            break
        idx[r] += 1
        for c in range(r + 1, nf):
            idx[c] = idx[c - 1] + 1
    return best


@numba.njit(cache=True)
def least_totals(com, fans, fmax, normals, offsets, weight, tol_thrust, tol_mass, tol_com, bounded):
    """:func:`least_total` over rows: com (N, 2), fans (N, F, 2) [m] → totals (N,) [N], thrusts (N, F) [N]."""
    n, nf = fans.shape[0], fans.shape[1]
    totals = np.empty(n)
    split = np.empty((n, nf))
    for j in range(n):
        totals[j] = least_total(com[j, 0], com[j, 1], fans[j, :, 0].copy(), fans[j, :, 1].copy(), fmax, normals,
                                offsets, weight, tol_thrust, tol_mass, tol_com, bounded, split[j])
    return totals, split


@numba.njit(cache=True)
def mixed_windows(com, fans, share, normals, offsets, weight, tol_thrust, tol_mass, tol_com):
    """:func:`_window_mix` over rows: com (N, 2), fans (N, F, 2) [m], share (N, F) → lo, hi (N,) [N], blocked (N,)."""
    n = len(com)
    lo, hi, blocked = np.empty(n), np.empty(n), np.empty(n, dtype=np.bool_)
    for j in range(n):
        lo[j], hi[j], blocked[j] = _window_mix(com[j, 0], com[j, 1], fans[j, :, 0].copy(), fans[j, :, 1].copy(),
                                               share[j], normals, offsets, weight, tol_thrust, tol_mass, tol_com)
    return lo, hi, blocked


@numba.njit(cache=True, inline="always")
def _edge_error(ox, oy, cx, cy, ax, ay):
    """|θ_ZC − θ_CA| of (A-10) wrapped to [0, π] [rad]: the unsigned angle between origin→CoM and
    CoM→ankle, atan2(|u×v|, u·v); 0 where either is shorter than 1e-9 m (undefined)."""
    zc0, zc1 = cx - ox, cy - oy
    ca0, ca1 = ax - cx, ay - cy
    if math.sqrt(zc0 * zc0 + zc1 * zc1) < 1e-9 or math.sqrt(ca0 * ca0 + ca1 * ca1) < 1e-9:
        return 0.0
    return math.atan2(abs(zc0 * ca1 - zc1 * ca0), zc0 * ca0 + zc1 * ca1)


@numba.njit(cache=True)
def edge_errors(origin, com, ankle):
    """balance.edge_angle_error over rows: origin, com, ankle (N, 2) [m] → (N,) [rad]."""
    n = len(com)
    out = np.empty(n)
    for j in range(n):
        out[j] = _edge_error(origin[j, 0], origin[j, 1], com[j, 0], com[j, 1], ankle[j, 0], ankle[j, 1])
    return out


@numba.njit(cache=True)
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
            reach &= _leg_ik(q, cs, 6 * leg, sgn, geom, px, py, pz, cty, sty, feet[j, leg, 0], feet[j, leg, 1],
                             feet[j, leg, 2], math.cos(fyaw), math.sin(fyaw))
        within = True
        for k in range(12):
            within &= (q[k] >= limits[0, k]) and (q[k] <= limits[1, k])
            q_out[j, k] = q[k]
        status[j] = UNREACHABLE if not reach else (OK if within else JOINT_LIMIT)
        com_out[j, 0], com_out[j, 1], com_out[j, 2] = _com(cs, trunk, joints, links, px, py, pz, cty, sty)
    return q_out, com_out, status


@numba.njit(cache=True)
def sample_terms(P, yaw, feet, feet_yaw, geom, trunk, joints, links, limits, mask, margins, origin, ankle, rho, fan,
                 normals, offsets, weight, tol_thrust, tol_mass, tol_com):
    """One swing sample's terms for trunk positions P (M, 3) [m] (``optimisers.sqp.AnalyticSample``):
    the CoM (M, 3) [m]; the P-only constraints (M, 3 + mask.sum()), ≥ 0 when held: ρ − (A-10) error
    − margins[0] [rad], each leg's L² − ‖hip − ankle‖² − margins[1] [m²] (left, right), then the rows
    q − lower, upper − q of the 24 (legs' joints by role) selected by ``mask``, less margins[2] [rad]
    (1.0 where a leg does not reach: the stretched leg's joints have no gradient there); and the
    window's lower end of the one fan at ``fan`` (2,) [m] (inf where it is empty) [N].

    yaw [rad]: the trunk's; feet (2, 3) [m], feet_yaw (2,) [rad]: the soles (left, right); origin,
    ankle (2,) [m]: (A-10)'s Z and the swing ankle on the ground; normals, offsets: the support polygon.
    """
    n = len(P)
    ncons = 3
    for r in range(24):
        ncons += 1 if mask[r] else 0
    com_out, cons, thrust = np.empty((n, 3)), np.empty((n, ncons)), np.empty(n)
    q = np.empty(12)
    cs = np.empty((12, 2))
    cty, sty = math.cos(yaw), math.sin(yaw)
    w, reach_sq, ah = geom[0], (geom[1] + geom[2]) ** 2, geom[3]
    for j in range(n):
        px, py, pz = P[j, 0], P[j, 1], P[j, 2]
        reach = True
        for leg in range(2):
            sgn = 1.0 if leg == 0 else -1.0
            reach &= _leg_ik(q, cs, 6 * leg, sgn, geom, px, py, pz, cty, sty, feet[leg, 0], feet[leg, 1],
                             feet[leg, 2], math.cos(feet_yaw[leg]), math.sin(feet_yaw[leg]))
            d0 = px - sty * (sgn * w) - feet[leg, 0]
            d1 = py + cty * (sgn * w) - feet[leg, 1]
            d2 = pz - (feet[leg, 2] + ah)
            cons[j, 1 + leg] = reach_sq - (d0 * d0 + d1 * d1 + d2 * d2) - margins[1]
        cx, cy, cz = _com(cs, trunk, joints, links, px, py, pz, cty, sty)
        com_out[j, 0], com_out[j, 1], com_out[j, 2] = cx, cy, cz
        cons[j, 0] = rho - _edge_error(origin[0], origin[1], cx, cy, ankle[0], ankle[1]) - margins[0]
        col = 3
        for r in range(24):
            if mask[r]:
                k = r % 12
                v = q[k] - limits[0, k] if r < 12 else limits[1, k] - q[k]
                cons[j, col] = v - margins[2] if reach else 1.0
                col += 1
        thrust[j] = _thrust_lo(cx, cy, fan[0], fan[1], normals, offsets, weight, tol_thrust, tol_mass, tol_com)
    return com_out, cons, thrust


@numba.njit(cache=True, inline="always")
def objective_into(P, idx, swing, yaw, fan, geom, trunk, joints, links, limits, normals, offsets, support, scalars,
                   fans, obj, thrust_out, reason, q, cs, fxs, fys, fmax, split):
    """:func:`balance_objective` into ``obj``, ``thrust_out``, ``reason`` (each (M,), given); the rest is
    scratch from :func:`objective_scratch`."""
    n = len(idx)
    sup_sgn, rho, thrust_max, weight, edge_pen = scalars[0], scalars[1], scalars[2], scalars[3], scalars[4]
    tol_thrust, tol_mass, tol_com = scalars[5], scalars[6], scalars[7]
    w, L, ah = geom[0], geom[1] + geom[2], geom[3]
    nf = len(fans)
    one = nf == 1 and fans[0, 0] == 0.0
    for j in range(n):
        c = idx[j]
        px, py, pz = P[j, 0], P[j, 1], P[j, 2]
        ty = yaw[c]
        cty, sty = math.cos(ty), math.sin(ty)
        sx, sy, sz = swing[c, 0], swing[c, 1], swing[c, 2]
        reach = True
        for leg in range(2):  # left, right
            sgn = 1.0 if leg == 0 else -1.0
            if sgn == sup_sgn:
                fx, fy, fz = support[0], support[1], support[2]
            else:
                fx, fy, fz = sx, sy, sz
            reach &= _leg_ik(q, cs, 6 * leg, sgn, geom, px, py, pz, cty, sty, fx, fy, fz, 1.0, 0.0)
        within = True
        limit_excess = 0.0
        for k in range(12):
            limit_excess += max(limits[0, k] - q[k], 0.0) + max(q[k] - limits[1, k], 0.0)
            within &= (q[k] >= limits[0, k]) and (q[k] <= limits[1, k])
        thrust_out[j] = np.inf
        if not reach:
            # reach excess: distance to the farther of the two reach-ball centres, beyond thigh + shank
            ox, oy = sty * (sup_sgn * w), -cty * (sup_sgn * w)
            ds = math.sqrt((px - (support[0] + ox)) ** 2 + (py - (support[1] + oy)) ** 2
                           + (pz - (support[2] + ah)) ** 2)
            ds_w = math.sqrt((px - (sx - ox)) ** 2 + (py - (sy - oy)) ** 2 + (pz - (sz + ah)) ** 2)
            obj[j] = 4000 + 1e4 * max(max(ds, ds_w) - L, 0.0)
            reason[j] = UNREACHABLE
            continue
        if not within:
            obj[j] = 3000 + 1e3 * limit_excess
            reason[j] = JOINT_LIMIT
            continue
        cx, cy, _ = _com(cs, trunk, joints, links, px, py, pz, cty, sty)
        if one:
            f = _thrust_lo(cx, cy, fan[c, 0], fan[c, 1], normals, offsets, weight, tol_thrust, tol_mass, tol_com)
            above = f > thrust_max
        else:
            for i in range(nf):
                ox, oy = fans[i, 1], fans[i, 2]
                if fans[i, 0] == 0.0:
                    fxs[i], fys[i] = sx + ox, sy + oy
                else:
                    fxs[i], fys[i] = px + cty * ox - sty * oy, py + sty * ox + cty * oy
            f_free = least_total(cx, cy, fxs, fys, fmax, normals, offsets, weight, tol_thrust, tol_mass, tol_com,
                                 False, split)
            f = least_total(cx, cy, fxs, fys, fmax, normals, offsets, weight, tol_thrust, tol_mass, tol_com, True,
                            split)
            above = math.isfinite(f_free) and not math.isfinite(f)
            if above:
                f = f_free
        if not math.isfinite(f):
            obj[j] = 2000 + 1e3 * math.sqrt((cx - support[0]) ** 2 + (cy - support[1]) ** 2)
            reason[j] = NO_BALANCE
            continue
        edge = max(_edge_error(support[0], support[1], cx, cy, sx, sy) - rho, 0.0)
        obj[j] = f + edge_pen * math.degrees(edge)
        reason[j] = EDGE_ANGLE if edge > 0 else (THRUST_MAX if above else OK)
        if reason[j] != EDGE_ANGLE:
            thrust_out[j] = f


@numba.njit(cache=True)
def balance_objective(P, idx, swing, yaw, fan, geom, trunk, joints, links, limits, normals, offsets, support,
                      scalars, fans):
    """Objective, thrust [N] and reason code of candidates P (M, 3) [m] for cells ``idx`` (M,).

    As ``search.Evaluator``: an unreachable posture scores 4000 + 1e4·(reach excess [m]), one
    beyond the joint limits 3000 + 1e3·(excess [rad]), one no thrust balances 2000 + 1e3·(CoM to the
    support centre [m]); otherwise F* + (edge penalty)·(A-10 excess [deg]). The thrust is inf unless
    the posture is a member or only above the fan's maximum.

    ``fans`` (F, 4): per fan that may thrust, [on the trunk (1) or the swing sole (0), offset x, offset y
    [m], maximum [N]]. One fan on the swing sole is Paper A's case: its ground point is ``fan[c]`` and
    its least thrust is the window's lower end; otherwise the least total of :func:`least_total`.
    """
    n = len(idx)
    obj, thrust_out, reason = np.empty(n), np.empty(n), np.empty(n, dtype=np.int8)
    q, cs, fxs, fys, fmax, split = objective_scratch(fans, scalars[2])
    objective_into(P, idx, swing, yaw, fan, geom, trunk, joints, links, limits, normals, offsets, support, scalars,
                   fans, obj, thrust_out, reason, q, cs, fxs, fys, fmax, split)
    return obj, thrust_out, reason


@numba.njit(cache=True)
def objective_scratch(fans, thrust_max):
    """Scratch arrays of :func:`objective_into`: joints, their cosines and sines, and per fan its ground
    point, its limit [N] (filled) and its share."""
    nf = len(fans)
    fmax = np.empty(nf)
    for i in range(nf):
        fmax[i] = min(fans[i, 3], thrust_max)
    return np.empty(12), np.empty((12, 2)), np.empty(nf), np.empty(nf), fmax, np.empty(nf)


@numba.njit(cache=True, inline="always")
def _onto_ball(p0, p1, p2, c0, c1, c2, d, radius, o0, o1, o2):
    """P at distance ``d`` from centre c moved onto c's ball of ``radius``; and whether it lands
    within ``radius`` of the other centre o."""
    s = radius / d
    q0, q1, q2 = c0 + (p0 - c0) * s, c1 + (p1 - c1) * s, c2 + (p2 - c2) * s
    return (q0 - o0) ** 2 + (q1 - o1) ** 2 + (q2 - o2) ** 2 <= radius * radius, q0, q1, q2


@numba.njit(cache=True, inline="always")
def _onto_circle(p0, p1, p2, a0, a1, a2, ra, b0, b1, b2, rb):
    """The nearest point to P of the circle where the spheres (centre a, radius ``ra``) and (b, ``rb``)
    meet; P where they do not meet or P lies on their axis."""
    e0, e1, e2 = b0 - a0, b1 - a1, b2 - a2
    h = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    if h == 0.0 or h > ra + rb or h < abs(ra - rb):
        return p0, p1, p2
    e0, e1, e2 = e0 / h, e1 / h, e2 / h
    t0 = (h * h + ra * ra - rb * rb) / (2 * h)  # the circle's centre, from a along the axis
    m0, m1, m2 = a0 + t0 * e0, a1 + t0 * e1, a2 + t0 * e2
    rc = math.sqrt(max(ra * ra - t0 * t0, 0.0))
    t = (p0 - m0) * e0 + (p1 - m1) * e1 + (p2 - m2) * e2
    u0, u1, u2 = p0 - m0 - t * e0, p1 - m1 - t * e1, p2 - m2 - t * e2
    nu = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
    if nu == 0.0:
        return p0, p1, p2
    s = rc / nu
    return m0 + u0 * s, m1 + u1 * s, m2 + u2 * s


@numba.njit(cache=True, inline="always")
def _balls_one(p0, p1, p2, a0, a1, a2, b0, b1, b2, radius):
    """P moved onto the nearest point of the intersection of the balls of ``radius`` around a and b."""
    da = math.sqrt((p0 - a0) ** 2 + (p1 - a1) ** 2 + (p2 - a2) ** 2)
    db = math.sqrt((p0 - b0) ** 2 + (p1 - b1) ** 2 + (p2 - b2) ** 2)
    if da <= radius and db <= radius:
        return p0, p1, p2
    if da > radius:  # onto the swing ball; done if that lands inside the support ball
        inside, q0, q1, q2 = _onto_ball(p0, p1, p2, a0, a1, a2, da, radius, b0, b1, b2)
        if inside:
            return q0, q1, q2
    if db > radius:  # onto the support ball; done if that lands inside the swing ball
        inside, q0, q1, q2 = _onto_ball(p0, p1, p2, b0, b1, b2, db, radius, a0, a1, a2)
        if inside:
            return q0, q1, q2
    # onto the circle where the two spheres meet (a hair inside both)
    return _onto_circle(p0, p1, p2, a0, a1, a2, radius * (1.0 - 1e-12), b0, b1, b2, radius * (1.0 - 1e-12))


@numba.njit(cache=True, inline="always")
def pitch_bounds(c, shape, level, row):
    """The least and greatest pitch β [rad] of the hip–ankle line (its angle from the vertical towards
    the foot's +x) that keep the ankle and hip pitch within their limits, the hip at distance ``c`` [m]
    from the ankle (see :func:`into_leg`)."""
    a, b = shape[level, row, 6], shape[level, row, 7]
    cos_k = min(max((a * a + b * b - c * c) / (2 * a * b), -1.0), 1.0)
    knee = math.pi - math.acos(cos_k)
    alpha = math.asin(min(max(a * math.sqrt(1.0 - cos_k * cos_k) / c, -1.0), 1.0))
    lo = max(-shape[level, row, 9] - alpha, shape[level, row, 10] + knee - alpha)
    hi = min(-shape[level, row, 8] - alpha, shape[level, row, 11] + knee - alpha)
    return lo, hi


@numba.njit(cache=True, inline="always")
def _into_wedge(p1, p2, c1, c2, slo, clo, shi, chi):
    """(y, z) of P turned into the roll wedge of a leg whose reach centre is c: the angle atan2(y − c1,
    z − c2) of the hip about the foot's x axis kept within [lo, hi] (given by sine and cosine): the
    nearest point of the wedge, a convex cone about the line through c along x."""
    v1, v2 = p1 - c1, p2 - c2
    if v1 * chi - v2 * shi > 0.0:  # beyond hi: onto its ray (or the edge line)
        t = max(v1 * shi + v2 * chi, 0.0)
        return False, c1 + t * shi, c2 + t * chi
    if v1 * clo - v2 * slo < 0.0:  # beyond lo
        t = max(v1 * slo + v2 * clo, 0.0)
        return False, c1 + t * slo, c2 + t * clo
    return True, p1, p2


@numba.njit(cache=True, inline="always")
def _into_pitch(p0, p1, p2, o0, o1, o2, sh, level, row):
    """P turned about o (its distance and roll kept) so that the pitch β lies within pitch_bounds."""
    if sh[level, row, 12] == -np.inf:  # no pitch limits
        return True, p0, p1, p2
    r0, r1, r2 = p0 - o0, p1 - o1, p2 - o2
    g = math.sqrt(r1 * r1 + r2 * r2)
    if r2 > 0.0 and r0 >= sh[level, row, 12] * g and r0 <= sh[level, row, 13] * g:  # within every c's pitch range
        return True, p0, p1, p2
    c = math.sqrt(g * g + r0 * r0)
    if g == 0.0 or c < sh[level, row, 4] * (1 - 1e-9) or c > sh[level, row, 5] * (1 + 1e-9):
        return False, p0, p1, p2
    beta = math.atan2(r0, g if r2 >= 0.0 else -g)
    lo, hi = pitch_bounds(c, sh, level, row)
    if beta >= lo and beta <= hi:
        return True, p0, p1, p2
    if lo > hi:
        return False, p0, p1, p2
    beta = min(max(beta, lo), hi)
    s = c * math.cos(beta) / g
    return False, o0 + c * math.sin(beta), o1 + r1 * s, o2 + r2 * s


@numba.njit(cache=True, inline="always")
def into_leg(p0, p1, p2, o0, o1, o2, n0, n1, n2, radius, sh, level, row):
    """P moved into the hip positions from which one leg reaches within its joint limits (the trunk
    level, the sole flat and facing +x), o the centre of its reach ball, n the other leg's (whose ball of
    ``radius`` P should stay in); returns (whether P was inside, P).

    Seen from o, the hip at r = P − o has distance c = |r|, roll φ = atan2(r_y, r_z) about the foot's x
    axis and pitch β = atan2(r_x, √(r_y² + r_z²)). With the trunk level and the sole flat the knee depends
    on c alone, the ankle roll is φ and the hip roll −φ, and the ankle and hip pitch bound β within a
    range that depends on c (``_leg_ik``): the set is a box in (c, φ, β). A point outside is moved onto
    the wedge of φ (the nearest point), then out onto the sphere of the least c (onto its circle with the
    other ball where that leaves it), then turned to the nearest β:
    continuous, so the searches can slide along a joint limit rather than stall against its penalty.

    ``sh[level, row]`` (14,): sin and cos of the least and greatest φ; the least and greatest c [m];
    thigh, shank [m]; the ankle pitch's and the hip pitch's limits [rad]; tan of a pitch range inside
    every c's (the fast path; −inf, inf: β free); all pulled in by 1e-9 so a moved point's joints land
    inside their limits despite rounding. The trunk's yaw does not enter: it sets the hip yaw alone.
    """
    inside, p1, p2 = _into_wedge(p1, p2, o1, o2, sh[level, row, 0], sh[level, row, 1], sh[level, row, 2],
                                 sh[level, row, 3])
    rmin = sh[level, row, 4]
    d2 = (p0 - o0) ** 2 + (p1 - o1) ** 2 + (p2 - o2) ** 2
    if d2 < rmin * rmin and d2 > 0.0:  # the knee beyond its bend: out onto the inner sphere
        s = rmin / math.sqrt(d2)
        p0, p1, p2, inside = o0 + (p0 - o0) * s, o1 + (p1 - o1) * s, o2 + (p2 - o2) * s, False
        if (p0 - n0) ** 2 + (p1 - n1) ** 2 + (p2 - n2) ** 2 > radius * radius:
            p0, p1, p2 = _onto_circle(p0, p1, p2, o0, o1, o2, rmin, n0, n1, n2, radius * (1.0 - 1e-12))
    ok, p0, p1, p2 = _into_pitch(p0, p1, p2, o0, o1, o2, sh, level, row)
    inside &= ok
    return inside, p0, p1, p2


@numba.njit(cache=True, inline="always")
def _inside_fast(r0, r1, r2, radius, sh, level, row):
    """Whether the hip at r [m] from a leg's reach centre lies well inside the set of :func:`into_leg`
    (False: it may still, the exact test decides), without a square root where the leg has no pitch
    limits."""
    d2 = r0 * r0 + r1 * r1 + r2 * r2
    # without branches (``&``, not ``and``): 3.5 ns a point against 23 ns with short-circuits (measured)
    ok = ((d2 <= radius * radius) & (d2 >= sh[level, row, 4] * sh[level, row, 4]) & (r2 > 0.0)
          & (r1 * sh[level, row, 3] - r2 * sh[level, row, 2] <= 0.0)
          & (r1 * sh[level, row, 1] - r2 * sh[level, row, 0] >= 0.0))
    if sh[level, row, 12] == -np.inf:
        return ok
    g = math.sqrt(r1 * r1 + r2 * r2)
    return ok & (r0 >= sh[level, row, 12] * g) & (r0 <= sh[level, row, 13] * g)


@numba.njit(cache=True, inline="always")
def into_reach_one(p0, p1, p2, c, centre_w, centre_s, radius, shapes, level):
    """One point of :func:`into_reach` for cell ``c``."""
    a0, a1, a2 = centre_w[c, 0], centre_w[c, 1], centre_w[c, 2]
    b0, b1, b2 = centre_s[c, 0], centre_s[c, 1], centre_s[c, 2]
    if level == 0:
        return _balls_one(p0, p1, p2, a0, a1, a2, b0, b1, b2, radius)
    if (_inside_fast(p0 - a0, p1 - a1, p2 - a2, radius, shapes, level, 0)
            & _inside_fast(p0 - b0, p1 - b1, p2 - b2, radius, shapes, level, 1)):
        return p0, p1, p2
    return _into_sets(p0, p1, p2, a0, a1, a2, b0, b1, b2, radius, shapes, level)


@numba.njit(cache=True)
def _into_sets(p0, p1, p2, a0, a1, a2, b0, b1, b2, radius, shapes, level):
    """:func:`into_reach_one` where the fast test fails: alternating moves into the balls and each leg's set."""
    for _ in range(4):
        p0, p1, p2 = _balls_one(p0, p1, p2, a0, a1, a2, b0, b1, b2, radius)
        ok_w, p0, p1, p2 = into_leg(p0, p1, p2, a0, a1, a2, b0, b1, b2, radius, shapes, level, 0)
        ok_s, p0, p1, p2 = into_leg(p0, p1, p2, b0, b1, b2, a0, a1, a2, radius, shapes, level, 1)
        if ok_w and ok_s:
            return p0, p1, p2
    # no point of all the sets found: within both balls at least (beyond a joint limit, not out of reach)
    return _balls_one(p0, p1, p2, a0, a1, a2, b0, b1, b2, radius)


@numba.njit(cache=True)
def into_reach(P, idx, centre_w, centre_s, radius, shapes, level):
    """P (M, 3) [m] projected onto the intersection of the two legs' reach balls (radius ``radius``
    [m] around the cells' swing and support centres, rows ``idx``): the nearest point from which both
    legs reach. Points already inside are unchanged; where the balls do not meet, P is returned.
    ``level`` > 0: then also into each leg's joint limits by :func:`into_leg` with the sets
    ``shapes[level]`` (row 0 the swing leg's, row 1 the support leg's; ``search.leg_shapes``),
    alternating up to four times; a point for which that does not settle is left in the balls only.
    A new array.
    """
    out = np.empty_like(P)
    for j in range(len(idx)):
        out[j, 0], out[j, 1], out[j, 2] = into_reach_one(P[j, 0], P[j, 1], P[j, 2], idx[j], centre_w, centre_s,
                                                          radius, shapes, level)
    return out

