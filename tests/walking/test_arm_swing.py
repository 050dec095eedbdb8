"""walking.arm_swing: (B-43) solved exactly over its box of rates: the active-set QP is the box-constrained optimum
(its KKT conditions hold), and with room enough the arms cancel the lower body's yaw momentum."""

from __future__ import annotations

import itertools
import math

import numpy as np

from jethr1_plan.walking.arm_swing import arm_rates, box_qp


def _kkt(H, g, lo, hi, u, tol=1e-9) -> bool:
    """Inside the box; the gradient zero on free variables, pushing outward on bound ones."""
    grad = H @ u + g
    scale = max(1.0, float(np.max(np.abs(grad))))
    inside = np.all(u >= lo - tol) and np.all(u <= hi + tol)
    free = (u > lo + tol) & (u < hi - tol)
    at_lo, at_hi = np.abs(u - lo) <= tol, np.abs(u - hi) <= tol
    return bool(inside and np.all(np.abs(grad[free]) <= 1e-8 * scale) and np.all(grad[at_lo & ~at_hi] >= -1e-8 * scale)
                and np.all(grad[at_hi & ~at_lo] <= 1e-8 * scale))


def _box_problems(seed: int, count: int, n_max: int, lo_m: float, hi_m: float):
    """``count`` random convex box QPs (H, g, lo, hi) of 1..n_max variables, bounds of size lo_m..hi_m."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        n = int(rng.integers(1, n_max + 1))
        M = rng.normal(size=(n, n))
        H = M @ M.T + 0.1 * np.eye(n)
        g = rng.normal(size=n) * 3
        lo = -rng.uniform(lo_m, hi_m, size=n)
        hi = rng.uniform(lo_m, hi_m, size=n)
        yield H, g, lo, hi


def test_the_active_set_answer_is_the_box_optimum() -> None:
    for H, g, lo, hi in _box_problems(4, 200, 6, 0.0, 1.0):
        u = box_qp(H, g, lo, hi)
        assert _kkt(H, g, lo, hi, u)


def test_the_answer_is_the_best_of_every_active_set() -> None:
    """box_qp against enumeration of the active sets (each variable free, at its lower or its upper
    bound): the same minimiser on random convex problems."""
    for H, g, lo, hi in _box_problems(3, 60, 4, 0.1, 1.5):
        best, best_u = math.inf, None
        for pattern in itertools.product((0, -1, 1), repeat=len(g)):
            u = np.where(np.array(pattern) == -1, lo, np.where(np.array(pattern) == 1, hi, 0.0))
            free = np.array(pattern) == 0
            if free.any():
                rhs = -(g[free] + H[np.ix_(free, ~free)] @ u[~free])
                u[free] = np.linalg.solve(H[np.ix_(free, free)], rhs)
            if np.all(u >= lo - 1e-12) and np.all(u <= hi + 1e-12):
                f = 0.5 * u @ H @ u + g @ u
                if f < best:
                    best, best_u = f, u
        assert np.allclose(box_qp(H, g, lo, hi), best_u, atol=1e-8)


def test_without_bounds_it_solves_the_linear_system() -> None:
    H = np.array([[2.0, 0.5], [0.5, 1.0]])
    g = np.array([-1.0, 0.3])
    u = box_qp(H, g, np.full(2, -1e9), np.full(2, 1e9))
    assert np.allclose(H @ u, -g)


def test_free_arms_cancel_the_lower_bodys_momentum() -> None:
    a_up = np.array([0.08, -0.08])  # the two arms' columns of the yaw row [kg·m²]
    q = np.zeros(2)
    wide = np.full(2, 50.0)
    rates = arm_rates(0.02, a_up, q, q, -wide, wide, 0.01, 1.0, 0.0, 1e-9)
    assert abs(0.02 + a_up @ rates) < 1e-6  # (B-41) + (B-42): the total yaw momentum is cancelled
    assert np.isclose(rates[0], -rates[1])  # the arms swing opposite ways
    narrow = np.full(2, 0.01)
    held = arm_rates(0.02, a_up, q, q, -narrow, narrow, 0.01, 1.0, 0.0, 1e-9)
    assert np.all(np.abs(held) <= narrow + 1e-12)  # within their window, as much as it allows
    assert abs(0.02 + a_up @ held) < abs(0.02)
