"""The soles' support polygons and the swing paths as ``verify`` computes them for a plan's rows, every row
at once: the hull of both soles in closed form (:func:`pair_hull_edges`) and the distance of points to a
polyline (:func:`distances_to_polyline`). Ground-plane edges as in :mod:`.balance`: outward unit normals
and offsets, n·z ≤ b inside."""

from __future__ import annotations

import numpy as np

__all__ = ["distance_to_polyline", "distances_to_polyline", "pair_hull_edges"]


def pair_hull_edges(first_xy: np.ndarray, second_xy: np.ndarray, length_m: float, width_m: float,
                    shrink_m: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The edges of the convex hull of two soles facing +x, centred at ``first_xy`` and ``second_xy`` (N, 2) [m],
    each shrunk by ``shrink_m`` [m]: outward unit normals (N, 6, 2) and offsets (N, 6), n·z ≤ b inside.

    The hull of two translates a + R, b + R of one rectangle R is R ⊕ [a, b] (the Minkowski sum with the
    segment), whose support is h(n) = h_R(n) + max(n·a, n·b), h_R(n) = (L/2)|n_x| + (W/2)|n_y|. Its edges
    are R's four (normals ±x, ±y) and the two parallel to b − a (normals ±(b − a)⊥/|b − a|); where a = b
    those two repeat the first edge (a repeated edge changes no minimum or maximum)."""
    a = np.asarray(first_xy, dtype=float).reshape(-1, 2)
    b = np.asarray(second_xy, dtype=float).reshape(-1, 2)
    hl, hw = length_m / 2 - shrink_m, width_m / 2 - shrink_m
    axes = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
    n = len(a)
    normals, offsets = np.empty((n, 6, 2)), np.empty((n, 6))
    normals[:, :4] = axes
    offsets[:, :4] = np.array([hl, hw, hl, hw]) + np.maximum(a @ axes.T, b @ axes.T)
    d = b - a
    span = np.hypot(d[:, 0], d[:, 1])
    apart = span > 0.0
    across = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.where(apart, span, 1.0)[:, None]
    for k, m in ((4, across), (5, -across)):
        support = hl * np.abs(m[:, 0]) + hw * np.abs(m[:, 1]) + np.maximum(np.einsum("nd,nd->n", m, a),
                                                                            np.einsum("nd,nd->n", m, b))
        normals[:, k] = np.where(apart[:, None], m, normals[:, 0])
        offsets[:, k] = np.where(apart, support, offsets[:, 0])
    return normals, offsets


def distance_to_polyline(p: np.ndarray, pts: np.ndarray) -> float:
    """The distance [m] from point ``p`` (3,) to the polyline through ``pts`` (K, 3)."""
    return float(distances_to_polyline(np.asarray(p, dtype=float)[None], pts)[0])


def distances_to_polyline(points: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """(M,) the distance [m] from each of ``points`` (M, 3) to the polyline through ``pts`` (K, 3): the least
    over its segments a → b of |a + t·(b − a) − p|, t = (p − a)·(b − a)/|b − a|² clipped to [0, 1]."""
    a, b = pts[:-1], pts[1:]
    ab = b - a
    rel = np.asarray(points, dtype=float)[:, None, :] - a[None]  # (M, K − 1, 3)
    t = np.clip(np.einsum("mkj,kj->mk", rel, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-30), 0, 1)
    return np.min(np.linalg.norm(t[..., None] * ab - rel, axis=2), axis=1)
