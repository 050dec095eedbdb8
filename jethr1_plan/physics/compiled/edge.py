"""The edge angle of (A-10), compiled: the angle between the support centre → CoM and the CoM → swing ankle,
and the test that it lies within ρ without an inverse tangent (``physics.balance.edge_angle_error``).

Units: m, rad.
"""

from __future__ import annotations

import math

import numpy as np

from jethr1_plan.physics.compiled.jit import kernel

__all__ = ["edge_error", "edge_errors", "edge_excess"]


@kernel(inline="always")
def edge_error(ox, oy, cx, cy, ax, ay):
    """|θ_ZC − θ_CA| of (A-10) wrapped to [0, π] [rad]: the unsigned angle between origin→CoM and
    CoM→ankle, atan2(|u×v|, u·v); 0 where either is shorter than 1e-9 m (undefined)."""
    zc0, zc1 = cx - ox, cy - oy
    ca0, ca1 = ax - cx, ay - cy
    if math.sqrt(zc0 * zc0 + zc1 * zc1) < 1e-9 or math.sqrt(ca0 * ca0 + ca1 * ca1) < 1e-9:
        return 0.0
    return math.atan2(abs(zc0 * ca1 - zc1 * ca0), zc0 * ca0 + zc1 * ca1)


@kernel(inline="always")
def edge_excess(ox, oy, cx, cy, ax, ay, rho, tan_rho):
    """max(:func:`edge_error` − ρ, 0) [rad], the same bits, without the inverse tangent where the angle lies
    surely within ρ: u·v > 0 and |u×v| < tan ρ·(u·v)·(1 − 1e-9) (``tan_rho`` = tan ρ; ρ < π/2 for the
    shortcut to apply)."""
    zc0, zc1 = cx - ox, cy - oy
    ca0, ca1 = ax - cx, ay - cy
    dot = zc0 * ca0 + zc1 * ca1
    if dot > 0.0 and abs(zc0 * ca1 - zc1 * ca0) < tan_rho * dot * (1.0 - 1e-9):
        return 0.0
    return max(edge_error(ox, oy, cx, cy, ax, ay) - rho, 0.0)


@kernel
def edge_errors(origin, com, ankle):
    """balance.edge_angle_error over rows: origin, com, ankle (N, 2) [m] → (N,) [rad]."""
    n = len(com)
    out = np.empty(n)
    for j in range(n):
        out[j] = edge_error(origin[j, 0], origin[j, 1], com[j, 0], com[j, 1], ankle[j, 0], ankle[j, 1])
    return out
