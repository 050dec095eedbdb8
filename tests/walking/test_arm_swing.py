"""walking.arm_swing: (B-43) solved exactly over its box of rates: the active-set QP is the box-constrained optimum
(its KKT conditions hold), and with room enough the arms cancel the lower body's yaw momentum."""

from __future__ import annotations

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


def test_the_active_set_answer_is_the_box_optimum() -> None:
    rng = np.random.default_rng(4)
    for _ in range(200):
        n = int(rng.integers(1, 7))
        M = rng.normal(size=(n, n))
        H = M @ M.T + 0.1 * np.eye(n)
        g = rng.normal(size=n) * 3
        lo = -rng.uniform(0.0, 1.0, size=n)
        hi = rng.uniform(0.0, 1.0, size=n)
        u = box_qp(H, g, lo, hi)
        assert _kkt(H, g, lo, hi, u)


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
