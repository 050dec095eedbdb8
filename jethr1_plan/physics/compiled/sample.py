"""One swing sample's smooth constraints and exact least thrust, compiled: what SLSQP (``optimisers.sqp``)
evaluates thousands of times per swing path.

Units: m, rad, N.
"""

from __future__ import annotations

import math

import numpy as np

from jethr1_plan.physics.compiled.edge import edge_error
from jethr1_plan.physics.compiled.jit import kernel
from jethr1_plan.physics.compiled.legs import body_com, leg_ik
from jethr1_plan.physics.compiled.windows import thrust_lo

__all__ = ["sample_terms"]


@kernel
def sample_terms(P, yaw, feet, feet_yaw, geom, trunk, joints, links, limits, mask, margins, origin, ankle, rho, fan,
                 normals, offsets, weight, tol_thrust, tol_mass, tol_com):
    """One swing sample's terms for trunk positions P (M, 3) [m] (``optimisers.sqp_sample.AnalyticSample``):
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
            reach &= leg_ik(q, cs, 6 * leg, sgn, geom, px, py, pz, cty, sty, feet[leg, 0], feet[leg, 1],
                             feet[leg, 2], math.cos(feet_yaw[leg]), math.sin(feet_yaw[leg]))
            d0 = px - sty * (sgn * w) - feet[leg, 0]
            d1 = py + cty * (sgn * w) - feet[leg, 1]
            d2 = pz - (feet[leg, 2] + ah)
            cons[j, 1 + leg] = reach_sq - (d0 * d0 + d1 * d1 + d2 * d2) - margins[1]
        cx, cy, cz = body_com(cs, trunk, joints, links, px, py, pz, cty, sty)
        com_out[j, 0], com_out[j, 1], com_out[j, 2] = cx, cy, cz
        cons[j, 0] = rho - edge_error(origin[0], origin[1], cx, cy, ankle[0], ankle[1]) - margins[0]
        col = 3
        for r in range(24):
            if mask[r]:
                k = r % 12
                v = q[k] - limits[0, k] if r < 12 else limits[1, k] - q[k]
                cons[j, col] = v - margins[2] if reach else 1.0
                col += 1
        thrust[j] = thrust_lo(cx, cy, fan[0], fan[1], normals, offsets, weight, tol_thrust, tol_mass, tol_com)
    return com_out, cons, thrust
