"""SLSQP (Kraft's sequential least squares programming) for the planner's small problems, driven without
``scipy.optimize.minimize``'s set-up.

The optimisers solve thousands of problems of 4-6 variables a plan, each in a few iterations; SciPy's
``minimize`` spends more time building its wrappers (bounds, constraint dictionaries, a memoising scalar
function) than its compiled SLSQP step takes. :func:`minimize_slsqp` calls that same compiled step
(SciPy's ``_slsqplib.slsqp``, the routine ``minimize(method="SLSQP")`` calls) in the same loop, with the same
workspace, evaluations and stopping rule, so that its iterates are SciPy's to the bit. Where the installed SciPy
has no such routine (before 1.16) it calls ``minimize`` itself.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from jethr1_plan.arithmetic import scipy_extension

import numpy as np

__all__ = ["SlsqpResult", "minimize_slsqp"]


def _compiled_step() -> Callable[..., None] | None:
    """SciPy's compiled SLSQP step (``scipy.optimize._slsqplib.slsqp``, SciPy ≥ 1.16), else None.

    The extension is loaded from its file (:func:`jethr1_plan.arithmetic.scipy_extension`), without running
    ``scipy.optimize``'s ``__init__`` (which imports all of SciPy's optimisers, linear algebra and statistics:
    about 0.25 s of every command that plans). Loading it also loads SciPy's BLAS, which
    :func:`jethr1_plan.planning.plan.one_blas_thread` then limits to one thread.
    """
    module = scipy_extension("optimize", "_slsqplib")
    if module is not None and hasattr(module, "slsqp"):
        step: Callable[..., None] = module.slsqp
        return step
    try:  # pragma: no cover - the file was not found where SciPy's wheels put it
        from scipy.optimize._slsqplib import slsqp as imported

        return imported
    except ImportError:  # pragma: no cover - older SciPy
        return None


_step = _compiled_step()

Objective = Callable[[np.ndarray], tuple[float, np.ndarray]]
Constraints = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class SlsqpResult:
    """Where SLSQP ended: ``x`` (n,), the objective ``fun`` there, ``status`` (SciPy's exit mode; 0 = converged)
    and the major iterations ``nit``."""

    x: np.ndarray
    fun: float
    status: int
    nit: int

    @property
    def success(self) -> bool:
        return self.status == 0


def minimize_slsqp(objective: Objective, x0: np.ndarray, bounds: list[tuple[float | None, float | None]],
                   ineq: Constraints, ineq_jac: Constraints, maxiter: int, ftol: float) -> SlsqpResult:
    """min f(x) subject to c(x) ≥ 0 and the box ``bounds`` (None: unbounded), from ``x0`` (clipped into the box).

    Args:
        objective: x ↦ (f(x), ∇f(x) (n,)); ineq: x ↦ c(x) (m,); ineq_jac: x ↦ ∂c/∂x (m, n).
        maxiter: the major iterations allowed; ftol: SLSQP's accuracy goal on f (SciPy's ``ftol``).
    """
    if _step is None:  # pragma: no cover - older SciPy
        return _with_minimize(objective, x0, bounds, ineq, ineq_jac, maxiter, ftol)
    x = np.array(x0, dtype=float).reshape(-1)
    n = len(x)
    box = np.array([(np.nan if lo is None else lo, np.nan if hi is None else hi) for lo, hi in bounds], dtype=float)
    if box.shape != (n, 2):
        raise ValueError(f"SLSQP: {len(bounds)} bounds for {n} variables")
    if np.any(box[:, 0] > box[:, 1]):
        raise ValueError("SLSQP: a lower bound above its upper bound")
    lower = np.where(np.isfinite(box[:, 0]), box[:, 0], -np.inf)
    upper = np.where(np.isfinite(box[:, 1]), box[:, 1], np.inf)
    xl = np.where(np.isfinite(box[:, 0]), box[:, 0], np.nan)
    xu = np.where(np.isfinite(box[:, 1]), box[:, 1], np.nan)
    x = np.clip(x, lower, upper)

    d = np.atleast_1d(np.asarray(ineq(x), dtype=float)).ravel().copy()  # (m,) the constraints at x
    m = len(d)
    state = {"acc": ftol, "alpha": 0.0, "f0": 0.0, "gs": 0.0, "h1": 0.0, "h2": 0.0, "h3": 0.0, "h4": 0.0, "t": 0.0,
             "t0": 0.0, "tol": 10.0 * ftol, "exact": 0, "inconsistent": 0, "reset": 0, "iter": 0,
             "itermax": int(maxiter), "line": 0, "m": m, "meq": 0, "mode": 0, "n": n}
    indices = np.zeros(max(m + 2 * n + 2, 1), dtype=np.int32)
    size = n * (n + 1) // 2 + 3 * m * n + 9 * m + 8 * n * n + 35 * n + 28  # SciPy's worst case, no equalities
    if m == 0:
        size += 2 * n * (n + 1)
    buffer = np.zeros(max(size, 1), dtype=np.float64)
    fx, g = _evaluate(objective, x)
    mult = np.zeros(max(1, m + 2 * n + 2), dtype=np.float64)
    C = np.zeros((max(1, m), n), dtype=np.float64, order="F")
    if m:
        C[:] = ineq_jac(x)
    d = np.zeros(max(1, m), dtype=np.float64) if m == 0 else d
    while True:
        _step(state, fx, g, C, d, x, mult, xl, xu, buffer, indices)
        mode = state["mode"]
        if mode == 1:  # the objective and the constraints at the new x
            fx, g = _evaluate(objective, x)
            if m:
                d[:] = np.asarray(ineq(x), dtype=float).ravel()
        elif mode == -1:  # their gradients
            fx, g = _evaluate(objective, x)
            if m:
                C[:] = ineq_jac(x)
        if abs(mode) != 1:
            break
    return SlsqpResult(x, float(fx), int(state["mode"]), int(state["iter"]))


def _evaluate(objective: Objective, x: np.ndarray) -> tuple[float, np.ndarray]:
    f, g = objective(x.copy())
    return float(f), np.atleast_1d(np.asarray(g, dtype=float))


def _with_minimize(objective: Objective, x0: np.ndarray, bounds: list[tuple[float | None, float | None]],
                   ineq: Constraints, ineq_jac: Constraints, maxiter: int, ftol: float
                   ) -> SlsqpResult:  # pragma: no cover - older SciPy
    from scipy.optimize import minimize

    res = minimize(objective, x0, jac=True, method="SLSQP", bounds=bounds,
                   options={"maxiter": maxiter, "ftol": ftol},
                   constraints=[{"type": "ineq", "fun": ineq, "jac": ineq_jac}])
    return SlsqpResult(np.asarray(res.x, dtype=float), float(res.fun), int(res.status), int(res.nit))
