"""optimisers/slsqp.py: the planner's SLSQP driver gives SciPy's ``minimize(method="SLSQP")`` iterates to the
bit, on problems shaped like the planner's (a few variables, bounds partly open, nonlinear inequalities)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from jethr1_plan.optimisers.slsqp import minimize_slsqp


def _problem(seed: int):
    """A random smooth problem: a convex quadratic plus a sine, a ball and random half-planes as constraints."""
    rng = np.random.default_rng([40, seed])
    n = int(rng.integers(2, 7))
    m = int(rng.integers(1, 9))
    A = rng.normal(size=(n, n))
    H = A @ A.T + 0.1 * np.eye(n)
    b = rng.normal(size=n)
    W = rng.normal(size=(m, n))
    c = rng.uniform(0.2, 2.0, m)
    centre = rng.normal(0, 0.3, n)

    def objective(x):
        return 0.5 * x @ H @ x + b @ x + 0.1 * float(np.sin(x[0])), H @ x + b + 0.1 * np.eye(n)[0] * np.cos(x[0])

    def ineq(x):
        return np.concatenate([c - W @ x, [4.0 - float((x - centre) @ (x - centre))]])

    def ineq_jac(x):
        return np.vstack([-W, -2.0 * (x - centre)])

    bounds = [(None, None) if rng.random() < 0.3 else (float(lo), float(lo + rng.uniform(0.0, 3.0)))
              for lo in rng.uniform(-2.0, 0.0, n)]
    x0 = rng.normal(0, 1.5, n)  # partly outside its box: both clip it
    return objective, ineq, ineq_jac, bounds, x0


@pytest.mark.parametrize("seed", range(40))
def test_the_driver_follows_scipys_slsqp_to_the_bit(seed):
    objective, ineq, ineq_jac, bounds, x0 = _problem(seed)
    maxiter, ftol = (5, 1e-7) if seed % 4 == 0 else (100, 1e-9)  # some stopped by the iteration limit
    ours = minimize_slsqp(objective, x0, bounds, ineq, ineq_jac, maxiter, ftol)
    with np.errstate(all="ignore"):
        ref = minimize(objective, x0, jac=True, method="SLSQP", bounds=bounds,
                       options={"maxiter": maxiter, "ftol": ftol},
                       constraints=[{"type": "ineq", "fun": ineq, "jac": ineq_jac}])
    assert ours.x.tobytes() == np.asarray(ref.x, dtype=float).tobytes()
    assert (ours.fun, ours.status, ours.nit, ours.success) == (ref.fun, ref.status, ref.nit, ref.success)


def test_a_converged_answer_holds_its_constraints_and_optimality():
    """Independent of SciPy: a problem with a known answer, min (x−2)² + (y−1)² on x + y ≤ 2, x ≥ 0: (1.5, 0.5)."""
    def objective(x):
        return float((x[0] - 2) ** 2 + (x[1] - 1) ** 2), np.array([2 * (x[0] - 2), 2 * (x[1] - 1)])

    res = minimize_slsqp(objective, np.zeros(2), [(0.0, None), (None, None)], lambda x: np.array([2.0 - x[0] - x[1]]),
                         lambda x: np.array([[-1.0, -1.0]]), 100, 1e-12)
    assert res.success
    np.testing.assert_allclose(res.x, [1.5, 0.5], atol=1e-8)


def test_bounds_that_do_not_fit_are_refused():
    with pytest.raises(ValueError, match="bounds"):
        minimize_slsqp(lambda x: (0.0, np.zeros(2)), np.zeros(2), [(0.0, 1.0)], lambda x: np.ones(1),
                       lambda x: np.zeros((1, 2)), 10, 1e-6)
    with pytest.raises(ValueError, match="lower bound"):
        minimize_slsqp(lambda x: (0.0, np.zeros(1)), np.zeros(1), [(1.0, 0.0)], lambda x: np.ones(1),
                       lambda x: np.zeros((1, 1)), 10, 1e-6)
