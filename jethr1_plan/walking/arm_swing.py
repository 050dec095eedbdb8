"""Arm swing that cancels the lower body's yaw angular momentum (Paper B, V-E, eqs. B-41..B-43).

With h_low = A_low,yaw·q̇_low the lower body's yaw momentum about the CoM (B-41) and A_up,yaw the
columns of the arm joints (B-42), the arm rates solve

    min  ω1/2·(h_low + A_up,yaw·q̇_up)² + ω2/2·‖q_up^init − (q_up + Δt·q̇_up)‖² + ω3/2·‖q̇_up‖²
    s.t. the joint limits reached within Δt, and the rate limits                            (B-43)

(the second term written with the posture the rates lead to), the rates also within the joints'
acceleration limits (the same window as the IK's joints). The momentum cancelled is the lower
body's over the same period, not the one before it. A convex quadratic over a box: solved
exactly by a primal active-set method (a handful of variables).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["arm_rates", "box_qp"]


@numba.njit(cache=True)
def box_qp(H: np.ndarray, g: np.ndarray, lo: np.ndarray, hi: np.ndarray, max_iter: int = 100) -> np.ndarray:
    """argmin ½uᵀHu + gᵀu over lo ≤ u ≤ hi (H positive definite), by a primal active-set method:
    from a feasible point, each iteration solves for the free variables with the bound ones fixed,
    steps towards that solution as far as the box allows (fixing the blocking bound), and, at a
    solution of the free problem, releases the bound whose multiplier has the wrong sign."""
    n = len(g)
    u = np.minimum(np.maximum(np.zeros(n), lo), hi)
    at = np.zeros(n, dtype=np.int64)  # 0 free, -1 at its lower bound, +1 at its upper bound
    for i in range(n):
        if u[i] <= lo[i]:
            at[i] = -1
        elif u[i] >= hi[i]:
            at[i] = 1
    for _ in range(max_iter):
        free = np.flatnonzero(at == 0)
        target = u.copy()
        if len(free):
            m = len(free)
            A = np.empty((m, m))
            b = np.empty(m)
            for r in range(m):
                acc = -g[free[r]]
                for c in range(n):
                    if at[c] != 0:
                        acc -= H[free[r], c] * u[c]
                b[r] = acc
                for c in range(m):
                    A[r, c] = H[free[r], free[c]]
            x = np.linalg.solve(A, b)
            for r in range(m):
                target[free[r]] = x[r]
        # the largest fraction of the step that keeps every free variable in its box
        alpha, block, side = 1.0, -1, 0
        for i in free:
            step = target[i] - u[i]
            if step < 0 and target[i] < lo[i]:
                a = (lo[i] - u[i]) / step
                if a < alpha:
                    alpha, block, side = a, i, -1
            elif step > 0 and target[i] > hi[i]:
                a = (hi[i] - u[i]) / step
                if a < alpha:
                    alpha, block, side = a, i, 1
        for i in range(n):
            u[i] += alpha * (target[i] - u[i])
        if block >= 0:
            at[block] = side
            u[block] = lo[block] if side < 0 else hi[block]
            continue
        grad = H @ u + g  # at the free problem's solution: the bound variables' multipliers
        scale = 1.0
        for i in range(n):
            scale = max(scale, abs(grad[i]))
        k, worst = -1, 1e-12 * scale
        for i in range(n):
            wrong = -grad[i] if at[i] < 0 else (grad[i] if at[i] > 0 else 0.0)  # > 0: leaving the bound helps
            if wrong > worst:
                k, worst = i, wrong
        if k < 0:
            return u
        at[k] = 0
    return u


@numba.njit(cache=True)
def arm_rates(h_low: float, a_up: np.ndarray, q_up: np.ndarray, q_home: np.ndarray, rate_lo: np.ndarray,
              rate_hi: np.ndarray, dt: float, w1: float = 1.0, w2: float = 1e-2, w3: float = 1e-4) -> np.ndarray:
    """(B-43): the arm joints' rates [rad/s] over the period whose lower-body yaw momentum is ``h_low``.

    Args:
        h_low: the lower body's yaw momentum about the CoM [N·m·s]; a_up: (n,) the yaw row of the
            centroidal momentum matrix at the arm joints [kg·m²]; q_up, q_home: (n,) the arms at the
            period's start and at home [rad]; rate_lo, rate_hi: (n,) the rates the joints may take
            (``joint_window.rate_window``: rate and acceleration limits, room to brake before the
            angle limits) [rad/s]; dt: the control period [s]; w1, w2, w3: ω1, ω2, ω3 of (B-43).
    """
    n = len(a_up)
    H = w1 * np.outer(a_up, a_up) + (w2 * dt * dt + w3) * np.eye(n)
    g = w1 * h_low * a_up - w2 * dt * (q_home - q_up)
    return box_qp(H, g, np.minimum(rate_lo, rate_hi), rate_hi)
