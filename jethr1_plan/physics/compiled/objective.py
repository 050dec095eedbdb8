"""The balance-space objective, compiled: closed-form IK of both legs, joint limits, CoM, least thrust and
edge angle of one pelvis position per candidate, fused in one loop (what every P_body search scores).

In numpy the objective is a long chain of array operations per batch, each a pass over memory; here one loop
whose per-candidate arithmetic stays in registers (docs/benchmarks.md measures the difference).
``tests/physics/test_compiled.py`` holds it to the numpy statements of the same formulas (``tests/oracles``).

Units: m, rad, kg, N.
"""

from __future__ import annotations

import math

import numpy as np

from jethr1_plan.physics.compiled.edge import edge_excess
from jethr1_plan.physics.compiled.jit import kernel
from jethr1_plan.physics.compiled.legs import body_com, leg_angles, leg_cs
from jethr1_plan.physics.compiled.windows import least_total, thrust_lo
from jethr1_plan.reasons import Reason

__all__ = ["balance_objective", "objective_into", "objective_scratch", "surely_within"]

# the reason codes as plain integers (compile-time constants in the kernels)
OK, UNREACHABLE, JOINT_LIMIT = int(Reason.OK), int(Reason.UNREACHABLE), int(Reason.JOINT_LIMIT)
NO_BALANCE, THRUST_MAX, EDGE_ANGLE = int(Reason.NO_BALANCE), int(Reason.THRUST_MAX), int(Reason.EDGE_ANGLE)


@kernel(inline="always")
def surely_within(cs, arcs):
    """Whether every joint lies within its limits by a margin, judged on its cosine and sine ``cs`` (12, 2)
    alone: sin(θ − lo) > 1e-9 and sin(hi − θ) > 1e-9 for a range narrower than π, one of the two for a wider
    one (then θ lies outside the narrower complement). ``arcs`` (12, 5): cos lo, sin lo, cos hi, sin hi, and
    1 where hi − lo > π. Exact for angles in (−π, π] (the IK's, with the hip above the ankle); False: the
    angles decide."""
    for k in range(12):
        c, s = cs[k, 0], cs[k, 1]
        above_lo = s * arcs[k, 0] - c * arcs[k, 1] > 1e-9  # sin(θ − lo)
        below_hi = arcs[k, 3] * c - arcs[k, 2] * s > 1e-9  # sin(hi − θ)
        if arcs[k, 4] == 0.0:
            if not (above_lo and below_hi):
                return False
        elif not (above_lo or below_hi):
            return False
    return True


@kernel(inline="always")
def objective_into(P, idx, swing, yaw_cs, fan, geom, trunk, joints, links, limits, normals, offsets, support, scalars,
                   fans, arcs, obj, thrust_out, reason, q, cs, fxs, fys, fmax, split):
    """:func:`balance_objective` into ``obj``, ``thrust_out``, ``reason`` (each (M,), given); the rest is
    scratch from :func:`objective_scratch`.

    The joint angles are computed only where their cosines and sines do not show every joint well inside
    its limits (:func:`surely_within`), and the edge angle only where the angle may exceed ρ
    (``edge.edge_excess``): the same bits as computing both always, 1.4x faster near the optima."""
    n = len(idx)
    sup_sgn, rho, thrust_max, weight, edge_pen = scalars[0], scalars[1], scalars[2], scalars[3], scalars[4]
    tol_thrust, tol_mass, tol_com, tan_rho = scalars[5], scalars[6], scalars[7], scalars[8]
    w, L, ah = geom[0], geom[1] + geom[2], geom[3]
    nf = len(fans)
    one = nf == 1 and fans[0, 0] == 0.0
    for j in range(n):
        c = idx[j]
        px, py, pz = P[j, 0], P[j, 1], P[j, 2]
        cty, sty = yaw_cs[c, 0], yaw_cs[c, 1]
        sx, sy, sz = swing[c, 0], swing[c, 1], swing[c, 2]
        # left, right
        fx, fy, fz = (support[0], support[1], support[2]) if sup_sgn > 0 else (sx, sy, sz)
        reach_l, iv_l = leg_cs(cs, 0, 1.0, geom, px, py, pz, cty, sty, fx, fy, fz, 1.0, 0.0)
        fx, fy, fz = (support[0], support[1], support[2]) if sup_sgn < 0 else (sx, sy, sz)
        reach_r, iv_r = leg_cs(cs, 6, -1.0, geom, px, py, pz, cty, sty, fx, fy, fz, 1.0, 0.0)
        thrust_out[j] = np.inf
        if not (reach_l and reach_r):
            # reach excess: distance to the farther of the two reach-ball centres, beyond thigh + shank
            ox, oy = sty * (sup_sgn * w), -cty * (sup_sgn * w)
            ds = math.sqrt((px - (support[0] + ox)) ** 2 + (py - (support[1] + oy)) ** 2
                           + (pz - (support[2] + ah)) ** 2)
            ds_w = math.sqrt((px - (sx - ox)) ** 2 + (py - (sy - oy)) ** 2 + (pz - (sz + ah)) ** 2)
            obj[j] = 4000 + 1e4 * max(max(ds, ds_w) - L, 0.0)
            reason[j] = UNREACHABLE
            continue
        if not (iv_l[2] > 0.0 and iv_r[2] > 0.0 and surely_within(cs, arcs)):  # the angles decide
            leg_angles(q, 0, iv_l)
            leg_angles(q, 6, iv_r)
            within = True
            excess_l, excess_r = 0.0, 0.0  # per leg, then added: a mirrored posture's sum to the bit
            for k in range(12):
                e = max(limits[0, k] - q[k], 0.0) + max(q[k] - limits[1, k], 0.0)
                if k < 6:
                    excess_l += e
                else:
                    excess_r += e
                within &= (q[k] >= limits[0, k]) and (q[k] <= limits[1, k])
            if not within:
                obj[j] = 3000 + 1e3 * (excess_l + excess_r)
                reason[j] = JOINT_LIMIT
                continue
        cx, cy, _ = body_com(cs, trunk, joints, links, px, py, pz, cty, sty)
        if one:
            f = thrust_lo(cx, cy, fan[c, 0], fan[c, 1], normals, offsets, weight, tol_thrust, tol_mass, tol_com)
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
        edge = edge_excess(support[0], support[1], cx, cy, sx, sy, rho, tan_rho)
        obj[j] = f + edge_pen * math.degrees(edge)
        reason[j] = EDGE_ANGLE if edge > 0 else (THRUST_MAX if above else OK)
        if reason[j] != EDGE_ANGLE:
            thrust_out[j] = f


@kernel
def balance_objective(P, idx, swing, yaw_cs, fan, geom, trunk, joints, links, limits, normals, offsets, support,
                      scalars, fans, arcs):
    """Objective, thrust [N] and reason code of candidates P (M, 3) [m] for cells ``idx`` (M,) whose swing soles
    are ``swing`` (C, 3) [m], body yaws' cosines and sines ``yaw_cs`` (C, 2) (``legs.yaw_cos_sin``), fan ground
    points ``fan`` (C, 2) [m].

    As ``search.Evaluator``: an unreachable posture scores 4000 + 1e4·(reach excess [m]), one
    beyond the joint limits 3000 + 1e3·(excess [rad]), one no thrust balances 2000 + 1e3·(CoM to the
    support centre [m]); otherwise F* + (edge penalty)·(A-10 excess [deg]). The thrust is inf unless
    the posture is a member or only above the fan's maximum.

    ``fans`` (F, 4): per fan that may thrust, [on the trunk (1) or the swing sole (0), offset x, offset y
    [m], maximum [N]]. One fan on the swing sole is Paper A's case: its ground point is ``fan[c]`` and
    its least thrust is the window's lower end; otherwise the least total of ``windows.least_total``.
    ``arcs`` (12, 5): the joint limits as :func:`surely_within` reads them (``kinematics.closed_form.limit_arcs``).
    """
    n = len(idx)
    obj, thrust_out, reason = np.empty(n), np.empty(n), np.empty(n, dtype=np.int8)
    q, cs, fxs, fys, fmax, split = objective_scratch(fans, scalars[2])
    objective_into(P, idx, swing, yaw_cs, fan, geom, trunk, joints, links, limits, normals, offsets, support, scalars,
                   fans, arcs, obj, thrust_out, reason, q, cs, fxs, fys, fmax, split)
    return obj, thrust_out, reason


@kernel
def objective_scratch(fans, thrust_max):
    """Scratch arrays of :func:`objective_into`: joints, their cosines and sines, and per fan its ground
    point, its limit [N] (filled) and its share."""
    nf = len(fans)
    fmax = np.empty(nf)
    for i in range(nf):
        fmax[i] = min(fans[i, 3], thrust_max)
    return np.empty(12), np.empty((12, 2)), np.empty(nf), np.empty(nf), fmax, np.empty(nf)
