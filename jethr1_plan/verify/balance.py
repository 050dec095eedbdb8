"""Balance with thrust as ``verify`` recomputes it from written rows, restated from docs/physics.md
("Quasistatic balance with a vertical thrust") and docs/robust_planning.md, never from the planner's
code: the support polygon, the ZMP of the written thrust, the thrust window, the balance slack under a
tolerance and the largest share of it a row's thrust holds.

Ground-plane points are (x, y) in metres, forces in newtons, moments in newton-metres; every function
takes a leading row axis (N, ...). A support polygon is given by its edges: outward unit normals
``normals`` (N, K, 2) and offsets ``offsets`` (N, K), a point z inside exactly when n_k·z ≤ b_k for
every edge k (rows of fewer edges repeat one: a repeated edge changes no minimum or maximum).

The formulations differ on purpose from the planner's (``physics/balance.py``, ``physics/share.py``,
``physics/compiled/windows.py``), so that a mistake in one is not repeated in the other:

* **the window** follows the ZMP along its ray (docs/physics.md: as F grows from 0 the ZMP travels from
  the CoM away from the fan): ZMP(u) = c + u·(c − P), u = F/(W − F) ∈ [0, ∞), W = M·g; edge k is
  crossed where d_k + u·(d_k − a_k) = 0, d_k and a_k the CoM's and the fan's distances beyond it. The
  interval of u inside every edge is mapped back to F = W·u/(1 + u). (The planner solves F·a_k ≥ W·d_k
  for F directly.)
* **the slack** enumerates the corners of the error box (each fan's thrust error ±X, the mass error ±Y;
  the CoM error ε towards each edge), where the planner folds the worst case into |a| terms.
* **the share** solves each corner's moment about each edge, a quadratic in the share s, for its first
  root in closed form, where the planner bisects.
"""

from __future__ import annotations

import itertools
from typing import NamedTuple

import numpy as np

from jethr1_plan.geometry import GRAVITY

__all__ = ["Tolerance", "balance_slack", "hull_edges", "largest_share", "pad_edges", "sole_edges", "support_margin",
           "thrust_window", "zmp_of_thrust"]


class Tolerance(NamedTuple):
    """The model errors a plan's ``balance.tolerance`` names: each fan's thrust off by ±``thrust`` (relative),
    the mass by ±``mass`` (relative, the CoM unchanged), the CoM's ground point by ``com_m`` [m] in any
    direction."""

    thrust: float = 0.0
    mass: float = 0.0
    com_m: float = 0.0

    def times(self, share: float) -> Tolerance:
        """``share`` of every error."""
        return Tolerance(self.thrust * share, self.mass * share, self.com_m * share)

    @property
    def nominal(self) -> bool:
        return self.thrust == 0.0 and self.mass == 0.0 and self.com_m == 0.0


# --- the support polygon ----------------------------------------------------------------------------


_SOLE_NORMALS = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])


def sole_edges(centre_xy: np.ndarray, length_m: float, width_m: float, shrink_m: float = 0.0
               ) -> tuple[np.ndarray, np.ndarray]:
    """The edges of soles facing +x (a plan's soles are flat and unturned: ``verify`` checks it) centred at
    ``centre_xy`` (N, 2), each side moved in by ``shrink_m``: normals (N, 4, 2), offsets (N, 4)."""
    c = np.asarray(centre_xy, dtype=float).reshape(-1, 2)
    half = np.array([length_m / 2, width_m / 2, length_m / 2, width_m / 2]) - shrink_m
    offsets = np.einsum("kd,nd->nk", _SOLE_NORMALS, c) + half
    return np.broadcast_to(_SOLE_NORMALS, (len(c), 4, 2)).copy(), offsets


def hull_edges(centres_xy: list[np.ndarray], length_m: float, width_m: float, shrink_m: float = 0.0
               ) -> tuple[np.ndarray, np.ndarray]:
    """The edges (K, 2), (K,) of the convex hull of several soles facing +x (``centres_xy`` (2,) each), each
    shrunk by ``shrink_m``: Qhull's facets (scipy), whose equations n·z + e ≤ 0 hold inside."""
    from scipy.spatial import ConvexHull

    hl, hw = length_m / 2 - shrink_m, width_m / 2 - shrink_m
    corners = np.array([[hl, hw], [-hl, hw], [-hl, -hw], [hl, -hw]])
    pts = np.vstack([np.asarray(c, dtype=float)[:2] + corners for c in centres_xy])
    eq = ConvexHull(pts).equations
    return eq[:, :2].copy(), -eq[:, 2]


def pad_edges(edges: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """Per-row edges of different counts stacked to (N, K, 2), (N, K), each row's first edge repeated."""
    k = max(len(b) for _, b in edges)
    normals = np.empty((len(edges), k, 2))
    offsets = np.empty((len(edges), k))
    for i, (n, b) in enumerate(edges):
        normals[i], offsets[i] = n[0], b[0]
        normals[i, :len(b)], offsets[i, :len(b)] = n, b
    return normals, offsets


def support_margin(p_xy: np.ndarray, normals: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """(N,) how far [m] each point lies inside its polygon: min_k (b_k − n_k·p); negative outside."""
    return np.min(offsets - np.einsum("nkd,nd->nk", normals, np.asarray(p_xy, dtype=float)), axis=1)


# --- balance -----------------------------------------------------------------------------------------


def zmp_of_thrust(com_xy: np.ndarray, fan_xy: np.ndarray, thrust_n: np.ndarray, mass_kg: float) -> np.ndarray:
    """(N, 2) the ZMP [m] of gravity at the CoM and each fan's vertical thrust (A-1, A-2): the point where the
    ground's reaction W − ΣF balances the moments of the weight and the thrusts, (W·c − Σ F_i·p_i)/(W − ΣF).

    Args:
        com_xy: (N, 2) [m]; fan_xy: (N, F, 2) [m]; thrust_n: (N, F) [N].
    """
    w = mass_kg * GRAVITY
    thrust = np.asarray(thrust_n, dtype=float)
    moment = w * np.asarray(com_xy, dtype=float) - np.einsum("nf,nfd->nd", thrust, np.asarray(fan_xy, dtype=float))
    with np.errstate(invalid="ignore", divide="ignore"):
        return moment / (w - thrust.sum(axis=1))[:, None]


def thrust_window(com_xy: np.ndarray, fan_xy: np.ndarray, share: np.ndarray, normals: np.ndarray,
                  offsets: np.ndarray, mass_kg: float) -> tuple[np.ndarray, np.ndarray]:
    """The nominal thrust window [N] of fans carrying fixed ``share`` (N, F) (summing to 1) of a total: the
    totals T, 0 ≤ T < W, whose ZMP lies in the polygon (module docstring: the ZMP along its ray).

    With the shares fixed the thrusts act at one point, P = Σ s_i·P_i, and the ZMP is
    c + u·(c − P), u = T/(W − T). Beyond edge k it lies d_k + u·(d_k − a_k) [m] (d_k = n_k·c − b_k,
    a_k = n_k·P − b_k): where d_k > a_k that grows with u and the edge caps u at −d_k/(d_k − a_k); where
    d_k < a_k it falls and the edge asks u ≥ d_k/(a_k − d_k); where d_k = a_k it stays d_k and must be ≤ 0.

    Returns:
        lo, hi (N,) [N]; lo = inf and hi = NaN where no total balances. The fans' maxima are not applied.
    """
    w = mass_kg * GRAVITY
    c = np.asarray(com_xy, dtype=float)
    p = np.einsum("nf,nfd->nd", np.asarray(share, dtype=float), np.asarray(fan_xy, dtype=float))
    d = np.einsum("nkd,nd->nk", normals, c) - offsets
    a = np.einsum("nkd,nd->nk", normals, p) - offsets
    g = d - a  # how fast the ZMP moves beyond edge k per unit of u
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = -d / g  # where the ray meets edge k's line
    u_lo = np.max(np.where(g < 0, cross, 0.0), axis=1, initial=0.0)
    u_hi = np.min(np.where(g > 0, cross, np.inf), axis=1, initial=np.inf)
    stuck = np.any((g == 0) & (d > 0), axis=1)
    empty = stuck | (u_lo > u_hi)
    lo = w * u_lo / (1.0 + u_lo)
    with np.errstate(invalid="ignore"):
        hi = np.where(np.isinf(u_hi), w, w * u_hi / (1.0 + u_hi))
    return np.where(empty, np.inf, lo), np.where(empty, np.nan, hi)


def _corners(n_fans: int) -> tuple[np.ndarray, np.ndarray]:
    """Every corner of the error box: the signs of each fan's thrust error (C, F) and of the mass error (C,)."""
    signs = np.array(list(itertools.product((-1.0, 1.0), repeat=n_fans + 1))).reshape(-1, n_fans + 1)
    return signs[:, :n_fans], signs[:, n_fans]


def _edge_moments(com_xy: np.ndarray, fan_xy: np.ndarray, thrust_n: np.ndarray, normals: np.ndarray,
                  offsets: np.ndarray, mass_kg: float, tol: Tolerance) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The moment about each edge line that keeps the ZMP inside it, at each corner of the error box, as a
    quadratic in the share s of ``tol``: coefficients (N, K, C) of 1, s and s² [N·m].

    At a corner the fans give F_i·(1 + s·σ_i·X), the robot weighs W·(1 + s·μ·Y), and its CoM sits s·ε
    towards the edge; the ZMP is inside edge k when the thrusts' moment about the edge line is at least
    the weight's:

        Σ_i F_i·(1 + s·σ_i·X)·a_ik − W·(1 + s·μ·Y)·(d_k + s·ε)  ≥  0.
    """
    w = mass_kg * GRAVITY
    thrust = np.asarray(thrust_n, dtype=float)
    d = np.einsum("nkd,nd->nk", normals, np.asarray(com_xy, dtype=float)) - offsets  # (N, K)
    a = np.einsum("nkd,nfd->nfk", normals, np.asarray(fan_xy, dtype=float)) - offsets[:, None, :]  # (N, F, K)
    sigma, mu = _corners(thrust.shape[1])
    lever = np.einsum("nf,nfk->nk", thrust, a)  # Σ F_i a_ik
    spread = np.einsum("cf,nf,nfk->nkc", sigma, thrust, a) * tol.thrust  # X Σ σ_i F_i a_ik
    c0 = np.repeat((lever - w * d)[:, :, None], len(mu), axis=2)
    c1 = spread - w * (mu[None, None, :] * tol.mass * d[:, :, None] + tol.com_m)
    c2 = np.broadcast_to(-w * mu * tol.mass * tol.com_m, c0.shape)
    return c0, c1, c2


def balance_slack(com_xy: np.ndarray, fan_xy: np.ndarray, thrust_n: np.ndarray, normals: np.ndarray,
                  offsets: np.ndarray, mass_kg: float, tol: Tolerance, share: np.ndarray | float = 1.0) -> np.ndarray:
    """(N,) the least, over the polygon's edges and the corners of the error box ``share`` × ``tol``, of the
    moment by which the thrusts keep the ZMP inside the edge [N·m] (:func:`_edge_moments`): ≥ 0 exactly
    when the written thrusts balance under every error within that share of ``tol``.

    Args:
        com_xy: (N, 2) [m]; fan_xy: (N, F, 2) [m]; thrust_n: (N, F) [N]; normals, offsets: (N, K, 2), (N, K);
        share: (N,) or one share of ``tol`` per row.
    """
    c0, c1, c2 = _edge_moments(com_xy, fan_xy, thrust_n, normals, offsets, mass_kg, tol)
    s = np.broadcast_to(np.asarray(share, dtype=float), (len(c0),))[:, None, None]
    return np.min(c0 + c1 * s + c2 * s * s, axis=(1, 2))


def _first_negative(c0: np.ndarray, c1: np.ndarray, c2: np.ndarray) -> np.ndarray:
    """Where each quadratic c0 + c1·s + c2·s² (c0 ≥ 0) first turns negative for s ≥ 0 (inf: never)."""
    out = np.full(c0.shape, np.inf)
    line = c2 == 0
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(line & (c1 < 0), -c0 / c1, out)
        disc = c1 * c1 - 4.0 * c2 * c0
        root = np.sqrt(np.maximum(disc, 0.0))
        # the two roots without cancellation: q = −(c1 + sign(c1)·√disc)/2, roots q/c2 and c0/q
        q = -0.5 * (c1 + np.where(c1 >= 0, root, -root))
        r1, r2 = q / c2, np.where(q != 0, c0 / q, 0.0)
        small, large = np.minimum(r1, r2), np.maximum(r1, r2)
        # opening down: negative beyond the larger root; opening up: between the roots, from the smaller
        down = ~line & (c2 < 0)
        up = ~line & (c2 > 0) & (disc > 0) & (small >= 0)
        out = np.where(down, np.maximum(large, 0.0), out)
        out = np.where(up, small, out)
    return out


def largest_share(com_xy: np.ndarray, fan_xy: np.ndarray, thrust_n: np.ndarray, normals: np.ndarray,
                  offsets: np.ndarray, mass_kg: float, tol: Tolerance) -> np.ndarray:
    """(N,) the largest share s ∈ [0, 1] of ``tol`` under which the written thrusts keep the ZMP in the
    polygon (docs/robust_planning.md, "The share, derived"); 0 where they do not even without errors.

    The worst moment over the corners falls as s grows, so the share is where the first corner's moment
    about the first edge turns negative: the least first root of the quadratics of :func:`_edge_moments`.
    """
    c0, c1, c2 = _edge_moments(com_xy, fan_xy, thrust_n, normals, offsets, mass_kg, tol)
    if tol.nominal:
        return np.where(np.min(c0, axis=(1, 2)) >= 0, 1.0, 0.0)
    first = np.min(_first_negative(c0, c1, c2), axis=(1, 2))
    return np.where(np.min(c0, axis=(1, 2)) < 0, 0.0, np.clip(first, 0.0, 1.0))
