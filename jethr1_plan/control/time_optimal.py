"""The fastest timing s(t) of a fixed path under constraints linear in s̈ and ṡ², by TOPP-RA.

Time-optimal path parametrisation by reachability analysis (Pham & Pham, IEEE T-RO 2018), as the
``toppra`` package implements it: on a grid s_0 < … < s_G−1 of the path parameter, with x = ṡ² and
u = s̈ constant on each interval (x_i+1 = x_i + 2·u_i·Δs_i), every constraint a_i·u + b_i·x + c_i ≤ 0
and x ≤ x_max,i at the grid points bounds a convex set; TOPP-RA sweeps the sets backwards (what can
still stop at the end) and forwards (the largest x reachable), at rest at both ends. The rows of the
constraints come from ``physics.path_dynamics``; this module only solves and resamples.

A law's time at the grid follows from Δt_i = 2·Δs_i / (ṡ_i + ṡ_i+1); between grid points s(t) is the
parabola of constant s̈, so resampling it on any clock is exact.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["X_CAP", "TimeLaw", "binding_constraints", "fastest_law"]

X_CAP = 1e4  # the largest ṡ² handed to the solver where nothing bounds it [1/s² in path units]: ṡ ≤ 100 (larger
# bounds leave TOPP-RA's controllable sets badly conditioned: measured, 1e6 failed on a swing 1e4 solves)


@dataclass(frozen=True)
class TimeLaw:
    """s(t) through the grid: ``grid`` (G,) s, ``sd`` (G,) ṡ there, ``sdd`` (G − 1,) s̈ on each interval,
    ``times`` (G,) [s] at which each grid point is passed."""

    grid: np.ndarray
    sd: np.ndarray
    sdd: np.ndarray
    times: np.ndarray

    @property
    def duration_s(self) -> float:
        return float(self.times[-1])

    def positions(self, t: np.ndarray) -> np.ndarray:
        """s at times ``t`` [s] (clipped to the law's span)."""
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.duration_s)
        i = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.grid) - 2)
        tau = t - self.times[i]
        s = self.grid[i] + self.sd[i] * tau + 0.5 * self.sdd[i] * tau * tau
        return np.clip(s, self.grid[i], self.grid[i + 1])


def _law(grid: np.ndarray, sd: np.ndarray) -> TimeLaw:
    ds = np.diff(grid)
    sdd = (sd[1:] ** 2 - sd[:-1] ** 2) / (2.0 * ds)
    dt = 2.0 * ds / np.maximum(sd[1:] + sd[:-1], 1e-12)
    return TimeLaw(grid, sd, sdd, np.concatenate([[0.0], np.cumsum(dt)]))


def fastest_law(grid: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray, x_max: np.ndarray) -> TimeLaw | None:
    """The time-optimal law on ``grid`` (G,) under a·s̈ + b·ṡ² + c ≤ 0 ((G, m) each) and ṡ² ≤ ``x_max``
    (G,), at rest at both ends; None where no law exists (a point infeasible at rest, or the solver fails)."""
    grid = np.asarray(grid, dtype=float)
    for cap in (X_CAP, X_CAP / 100):  # the second: where the first is still badly conditioned
        law = _solve(grid, a, b, c, np.minimum(np.asarray(x_max, dtype=float), cap))
        if law is not None:
            return law
    return None


def _solve(grid: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray, x_max: np.ndarray) -> TimeLaw | None:
    import toppra
    from toppra.constraint import DiscretizationType, LinearConstraint

    m = a.shape[1]
    xb = np.column_stack([np.zeros(len(grid)), x_max])

    class Rows(LinearConstraint):
        def __init__(self):
            super().__init__()
            self.identical = True
            self.discretization_type = DiscretizationType.Collocation

        def compute_constraint_params(self, path, gridpoints, *args, **kwargs):
            return a, b, c, np.eye(m), np.zeros(m), None, xb

    path = toppra.SplineInterpolator(grid, grid.reshape(-1, 1))
    algo = toppra.algorithm.TOPPRA([Rows()], path, gridpoints=grid, solver_wrapper="seidel")
    _, sd, _ = algo.compute_parameterization(0.0, 0.0)
    if sd is None or not np.all(np.isfinite(sd)):
        return None
    return _law(grid, np.sqrt(np.maximum(np.asarray(sd, dtype=float) ** 2, 0.0)))


def binding_constraints(law: TimeLaw, a: np.ndarray, b: np.ndarray, c: np.ndarray, x_max: np.ndarray,
                        names: tuple[str, ...], x_names: np.ndarray, tol: float = 1e-3) -> list[str]:
    """(G − 1,) the constraint that binds on each interval of ``law``: the velocity bound where ṡ² is within
    ``tol`` of it at either end, else the row a·s̈ + b·ṡ² + c nearest 0 relative to its terms' size."""
    out = []
    x = law.sd ** 2
    for i in range(len(law.sdd)):
        hit = [j for j in (i, i + 1) if np.isfinite(x_max[j]) and x[j] >= (1 - tol) * x_max[j] and x_max[j] < X_CAP]
        if hit:
            out.append(str(x_names[hit[0]]))
            continue
        u = law.sdd[i]
        val = a[i] * u + b[i] * x[i] + c[i]
        scale = np.abs(a[i] * u) + np.abs(b[i] * x[i]) + np.abs(c[i]) + 1e-12
        out.append(names[int(np.argmax(val / scale))])
    return out
