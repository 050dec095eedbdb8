"""The largest share of the tolerance one swing sample reaches, as a smooth program (SQP's share stage).

Where no posture of a sample balances within the whole tolerance T = (X, Y, ε) and F_max, the robust
policy takes the largest share s ∈ [0, 1] of it that some posture reaches (docs/robust_planning.md).
With s as a variable next to x = (P_body, u), u_i = F_i / (M·g), the balance rows of
:class:`~jethr1_plan.optimisers.sqp_sample.AnalyticSample` become, for every edge k and both signs,

    g_k±(P, u, s) = Σ_i u_i·(a_ik − s·X·|a_ik|) − (1 ± s·Y)·(d_k(P) + s·ε)  ≥  0,

a_ik = n_k·P_Ti − b_k (the fan beyond the edge), d_k = n_k·CoM(P) − b_k (the CoM beyond it), with the
derivatives ∂g/∂u_i = a_ik − s·X·|a_ik| and ∂g/∂s = −X·Σ_i u_i·|a_ik| ∓ Y·(d_k + s·ε) − (1 ± s·Y)·ε
exact, and ∂g/∂P by forward differences as the sample's own rows. Maximising s under these rows and
the sample's P-only constraints (reach, joint limits, (A-10)), with 0 ≤ u_i ≤ u_max,i and s ∈ [0, 1],
is stage 1 (:func:`max_share`); stage 2 is the sample's usual least-thrust solve at s* − δ
(``sqp.optimise_path``): one solve where a bisection of a tolerance scale over full solves needs many
(docs/benchmarks.md compares them).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from jethr1_plan.optimisers.problem import SampleProblem
from jethr1_plan.optimisers.slsqp import minimize_slsqp
from jethr1_plan.optimisers.sqp_sample import FD_STEP, MARGIN, AnalyticSample, grid_starts

__all__ = ["SHARE_ITER", "max_share", "scaled"]

SHARE_ITER = 60  # SLSQP iterations of stage 1
P_SCALE = 100.0  # stage 1 solves for P_body in cm
SHARE_SNAP = 1e-9  # a share this close to 1 is the whole tolerance


def scaled(problem: SampleProblem, share: float) -> SampleProblem:
    """``problem`` with ``share`` × its tolerance (the problem itself at share 1)."""
    return problem if share >= 1.0 else replace(problem, tolerance=problem.tolerance.scaled(share))


class _ShareRows:
    """The balance rows g_k± of the module docstring, with P-only constraints, over x = (P, u_1..u_F, s)."""

    def __init__(self, sample: AnalyticSample):
        self.sample = sample
        pr = sample.problem
        self.tol = pr.tolerance
        self.nf = len(pr.fan_xy)
        self.signs = np.array([1.0, -1.0]) if self.tol.mass > 0 else np.ones(1)
        self._cache: dict[bytes, np.ndarray] = {}

    def _a(self, P: np.ndarray) -> np.ndarray:
        """(F, K): each fan's distance beyond each edge [m], the trunk at ``P``."""
        s = self.sample
        return s.problem.fans_at(P)[0] @ s.normals.T - s.offsets

    def rows(self, x: np.ndarray, com_xy: np.ndarray, cons: np.ndarray) -> np.ndarray:
        s = self.sample
        P, u, k = x[:3], x[3:3 + self.nf], x[-1]
        a = self._a(P)
        lift = u @ (a - k * self.tol.thrust * np.abs(a))  # (K,)
        d = com_xy @ s.normals.T - s.offsets + k * self.tol.com_m
        bal = np.concatenate([lift - (1.0 + sg * k * self.tol.mass) * d for sg in self.signs])
        return np.concatenate([bal, cons])

    def values(self, x: np.ndarray) -> np.ndarray:
        key = x.tobytes()
        if key not in self._cache:
            com, cons, _ = self.sample.posture_terms(x[None, :3])
            self._cache[key] = self.rows(x, com[0, :2], cons[0])
        return self._cache[key]

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        s = self.sample
        g0 = self.values(x)
        com, cons, _ = s.posture_terms(x[:3] + FD_STEP * np.eye(3))
        J = np.zeros((len(g0), len(x)))
        for j in range(3):
            moved = x.copy()
            moved[j] += FD_STEP
            J[:, j] = (self.rows(moved, com[j, :2], cons[j]) - g0) / FD_STEP
        P, u, k = x[:3], x[3:3 + self.nf], x[-1]
        a = self._a(P)  # (F, K)
        nk = a.shape[1]
        com0, _, _ = s.posture_terms(x[None, :3])
        d = com0[0, :2] @ s.normals.T - s.offsets + k * self.tol.com_m
        lift_abs = u @ np.abs(a)
        for r, sg in enumerate(self.signs):
            block = slice(r * nk, (r + 1) * nk)
            J[block, 3:3 + self.nf] = (a - k * self.tol.thrust * np.abs(a)).T
            J[block, -1] = (-self.tol.thrust * lift_abs - sg * self.tol.mass * d
                            - (1.0 + sg * k * self.tol.mass) * self.tol.com_m)
        return J


def _u_max(sample: AnalyticSample) -> np.ndarray:
    if sample.one:
        return np.array([sample.u_max])
    return np.asarray(sample.u_maxes, dtype=float)


def _stage1(sample: AnalyticSample, p0: np.ndarray, half: float) -> tuple[float, np.ndarray] | None:
    """SLSQP for the largest share from P_body ``p0`` inside ``p0`` ± ``half`` [m]; (s, P) where its answer
    holds every row (within ``MARGIN``), else None. P_body is solved for in centimetres
    (``P_SCALE``): in metres its steps are a hundred times smaller than those of u and s, and SLSQP
    wandered off (measured: no answer in 150 iterations at the 450 mm ditch's landing, 9 in cm)."""
    rows = _ShareRows(sample)
    u_max = _u_max(sample)
    start = sample.restore(p0, iterations=3, max_step=half)
    scale = np.concatenate([np.full(3, P_SCALE), np.ones(len(u_max) + 1)])
    box = ([(float(c) - half, float(c) + half) for c in p0] + [(0.0, float(u)) for u in u_max] + [(0.0, 1.0)])
    x0 = np.clip(np.concatenate([start, u_max, [0.0]]), [b[0] for b in box], [b[1] for b in box])
    grad = np.zeros(len(x0))
    grad[-1] = -1.0
    res = minimize_slsqp(lambda y: (-float(y[-1]), grad), x0 * scale,
                         [(lo * k, hi * k) for (lo, hi), k in zip(box, scale, strict=True)],
                         lambda y: rows.values(y / scale), lambda y: rows.jacobian(y / scale) / scale,
                         SHARE_ITER, 1e-9)
    x = np.asarray(res.x, dtype=float) / scale
    if not np.all(rows.values(x) >= -MARGIN):
        return None
    share = float(np.clip(x[-1], 0.0, 1.0))
    # on its upper bound to rounding (SLSQP's last step: 1 - 5e-15 seen), the rows' change is far inside MARGIN
    return (1.0 if share > 1.0 - SHARE_SNAP else share), x[:3].copy()


def max_share(sample: AnalyticSample, centre: np.ndarray, half: float, moves: int = 6
              ) -> tuple[float, np.ndarray] | None:
    """Stage 1 at one sample: the largest share s ∈ [0, 1] of ``sample``'s tolerance some posture
    reaches, and that posture (P_body [m]), searched from ``centre`` inside a box of half-width
    ``half`` that follows the answer while it sits on the box's edge (up to ``moves`` times, while s
    grows); from the three best points of a coarse grid where that finds nothing. A local answer:
    a lower bound of the sample's largest share. None where no posture balances even at s = 0."""
    best = _stage1(sample, centre, half)
    for _ in range(moves):
        if best is None or best[0] >= 1.0 or np.all(np.abs(best[1] - centre) < half - 1e-4):
            break
        centre = best[1]
        again = _stage1(sample, centre, half)
        if again is None or again[0] <= best[0] + 1e-4:
            break
        best = again
    if best is None:
        for x0 in grid_starts(sample, centre, 4 * half):
            r = _stage1(sample, x0, half)
            if r is not None and (best is None or r[0] > best[0]):
                best = r
    return best
