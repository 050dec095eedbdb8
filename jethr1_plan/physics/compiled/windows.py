"""The thrust that balances a CoM, compiled: the window of (A-1, A-2) of one fan under any tolerance, the
window of several fans carrying fixed shares, and the least total thrust of several fans (a small linear
programme solved by its vertices). The one implementation of ``physics.balance``'s windows and of every
search's thrust; the numpy statements are the tests' oracle (``tests/oracles/balance.py``).

Units: m, N.
"""

from __future__ import annotations

import numpy as np

from jethr1_plan.physics.compiled.jit import kernel

__all__ = ["least_total", "least_totals", "mixed_windows", "thrust_lo", "windows"]


@kernel(inline="always")
def _edge_need(cx, cy, nx, ny, off, weight, tol_mass, tol_com):
    """The right-hand side of one edge's row: M·g·((d + ε) + Y·|d + ε|), d the CoM's distance beyond
    the edge [N·m]."""
    d = cx * nx + cy * ny - off + tol_com
    return weight * (d + tol_mass * abs(d))


@kernel(inline="always")
def _fan_lift(fx, fy, nx, ny, off, tol_thrust):
    """One fan's coefficient in one edge's row: a − X·|a|, a the fan's distance beyond the edge [m]."""
    a = fx * nx + fy * ny - off
    return a - tol_thrust * abs(a)


@kernel(inline="always")
def _cap(weight, tol_thrust, tol_mass):
    """The largest total thrust the ZMP formula admits: F(1 + X) < M·g(1 − Y) [N]."""
    return weight * (1.0 - tol_mass) / (1.0 + tol_thrust) * (1.0 - 1e-9)


@kernel(inline="always")
def _bound(lo, hi, blocked, coef, rhs):
    """One edge's row T·coef ≥ rhs applied to the window [lo, hi]: a lower bound (coef > 0), an upper
    bound (coef < 0), or, where no thrust moves the ZMP across the edge (coef = 0), blocked if the
    CoM lies beyond it."""
    if coef > 0:
        lo = max(lo, rhs / coef)
    elif coef < 0:
        hi = min(hi, rhs / coef)
    elif rhs > 0:
        blocked = True
    return lo, hi, blocked


@kernel(inline="always")
def _window(cx, cy, fx, fy, normals, offsets, weight, tol_thrust, tol_mass, tol_com):
    """(lo, hi, blocked) of balance.thrust_window for one CoM and one fan: per edge k,
    F·(a_k − X|a_k|) ≥ M·g·((d_k + ε) + Y|d_k + ε|), d_k and a_k the CoM's and the fan's distances beyond
    edge k; ``blocked`` where an edge no thrust moves the ZMP across lies on the wrong side."""
    lo, hi = 0.0, _cap(weight, tol_thrust, tol_mass)
    blocked = False
    for k in range(len(offsets)):
        rhs = _edge_need(cx, cy, normals[k, 0], normals[k, 1], offsets[k], weight, tol_mass, tol_com)
        coef = _fan_lift(fx, fy, normals[k, 0], normals[k, 1], offsets[k], tol_thrust)
        lo, hi, blocked = _bound(lo, hi, blocked, coef, rhs)
    return lo, hi, blocked


@kernel
def thrust_lo(cx, cy, fx, fy, normals, offsets, weight, tol_thrust, tol_mass, tol_com):
    """The window's lower end for one CoM (inf where the window is empty). With the tolerance zero this
    is the minimal thrust H(P_body) of (A-5)."""
    lo, hi, blocked = _window(cx, cy, fx, fy, normals, offsets, weight, tol_thrust, tol_mass, tol_com)
    return lo if (lo <= hi and not blocked) else np.inf


@kernel
def windows(com, fan, normals, offsets, weight, tol_thrust, tol_mass, tol_com):
    """balance.window_bounds over rows: com, fan (N, 2) [m] → lo, hi (N,) [N], blocked (N,)."""
    n = len(com)
    lo, hi, blocked = np.empty(n), np.empty(n), np.empty(n, dtype=np.bool_)
    for j in range(n):
        lo[j], hi[j], blocked[j] = _window(com[j, 0], com[j, 1], fan[j, 0], fan[j, 1], normals, offsets, weight,
                                           tol_thrust, tol_mass, tol_com)
    return lo, hi, blocked


@kernel
def _window_mix(cx, cy, fxs, fys, share, normals, offsets, weight, tol_thrust, tol_mass, tol_com):
    """(lo, hi, blocked) of the total thrust T of several fans carrying the fixed shares ``share``
    (F,) (summing to 1) of it: per edge k, T·Σ_i share_i·(a_ik − X|a_ik|) ≥ M·g·((d_k + ε) + Y|d_k + ε|).
    With one fan (share 1) it is :func:`_window`."""
    lo, hi = 0.0, _cap(weight, tol_thrust, tol_mass)
    blocked = False
    for k in range(len(offsets)):
        rhs = _edge_need(cx, cy, normals[k, 0], normals[k, 1], offsets[k], weight, tol_mass, tol_com)
        coef = 0.0
        for i in range(len(fxs)):
            coef += share[i] * _fan_lift(fxs[i], fys[i], normals[k, 0], normals[k, 1], offsets[k], tol_thrust)
        lo, hi, blocked = _bound(lo, hi, blocked, coef, rhs)
    return lo, hi, blocked


@kernel
def _solve_small(A, b, x):
    """Solve the n × n system A x = b in place by Gaussian elimination with partial pivoting; False
    where A is singular (a pivot below 1e-12 of the largest entry)."""
    n = len(b)
    scale = 0.0
    for i in range(n):
        for j in range(n):
            scale = max(scale, abs(A[i, j]))
    if scale == 0.0:
        return False
    for c in range(n):
        p = c
        for r in range(c + 1, n):
            if abs(A[r, c]) > abs(A[p, c]):
                p = r
        if abs(A[p, c]) <= 1e-12 * scale:
            return False
        if p != c:
            for j in range(n):
                A[c, j], A[p, j] = A[p, j], A[c, j]
            b[c], b[p] = b[p], b[c]
        for r in range(c + 1, n):
            f = A[r, c] / A[c, c]
            for j in range(c, n):
                A[r, j] -= f * A[c, j]
            b[r] -= f * b[c]
    for c in range(n - 1, -1, -1):
        acc = b[c]
        for j in range(c + 1, n):
            acc -= A[c, j] * x[j]
        x[c] = acc / A[c, c]
    return True


@kernel
def least_total(cx, cy, fxs, fys, fmax, normals, offsets, weight, tol_thrust, tol_mass, tol_com, bounded, out):
    """The least total thrust of F fans that balances one CoM: a linear programme,

        min Σ_i F_i  s.t.  Σ_i F_i·(a_ik − X|a_ik|) ≥ M·g·((d_k + ε) + Y|d_k + ε|) for every edge k,
                           Σ_i F_i·(1 + X) ≤ M·g·(1 − Y),  F_i ≥ 0  (and F_i ≤ fmax_i if ``bounded``),

    solved by enumerating its vertices (F of the constraints active; F is small: the fans of a swing
    foot and the trunk). Writes the thrusts into ``out`` (F,) [N]; returns the total [N], inf where
    no thrust balances (``out`` then NaN). The tests hold it to SciPy's HiGHS."""
    nf, nk = len(fxs), len(offsets)
    rows = nk + 1 + nf + (nf if bounded else 0)
    G = np.zeros((rows, nf))
    h = np.zeros(rows)
    for k in range(nk):
        h[k] = _edge_need(cx, cy, normals[k, 0], normals[k, 1], offsets[k], weight, tol_mass, tol_com)
        for i in range(nf):
            G[k, i] = _fan_lift(fxs[i], fys[i], normals[k, 0], normals[k, 1], offsets[k], tol_thrust)
    for i in range(nf):
        G[nk, i] = -(1.0 + tol_thrust)
        G[nk + 1 + i, i] = 1.0
        if bounded:
            G[nk + 1 + nf + i, i] = -1.0
            h[nk + 1 + nf + i] = -fmax[i]
    h[nk] = -weight * (1.0 - tol_mass) * (1.0 - 1e-9)
    best = np.inf
    for i in range(nf):
        out[i] = np.nan
    idx = np.arange(nf)
    A = np.empty((nf, nf))
    b = np.empty(nf)
    x = np.empty(nf)
    while True:
        for r in range(nf):
            for c in range(nf):
                A[r, c] = G[idx[r], c]
            b[r] = h[idx[r]]
        if _solve_small(A, b, x):
            total = 0.0
            ok = True
            for r in range(rows):
                lhs = 0.0
                for c in range(nf):
                    lhs += G[r, c] * x[c]
                if lhs < h[r] - 1e-9 * (1.0 + abs(h[r])):
                    ok = False
                    break
            if ok:
                for c in range(nf):
                    total += max(x[c], 0.0)
                if total < best:
                    best = total
                    for c in range(nf):
                        out[c] = max(x[c], 0.0)
        # the next combination of nf rows out of ``rows``, in lexicographic order
        r = nf - 1
        while r >= 0 and idx[r] == rows - nf + r:
            r -= 1
        if r < 0:
            break
        idx[r] += 1
        for c in range(r + 1, nf):
            idx[c] = idx[c - 1] + 1
    return best


@kernel
def least_totals(com, fans, fmax, normals, offsets, weight, tol_thrust, tol_mass, tol_com, bounded):
    """:func:`least_total` over rows: com (N, 2), fans (N, F, 2) [m] → totals (N,) [N], thrusts (N, F) [N]."""
    n, nf = fans.shape[0], fans.shape[1]
    totals = np.empty(n)
    split = np.empty((n, nf))
    for j in range(n):
        totals[j] = least_total(com[j, 0], com[j, 1], fans[j, :, 0].copy(), fans[j, :, 1].copy(), fmax, normals,
                                offsets, weight, tol_thrust, tol_mass, tol_com, bounded, split[j])
    return totals, split


@kernel
def mixed_windows(com, fans, share, normals, offsets, weight, tol_thrust, tol_mass, tol_com):
    """:func:`_window_mix` over rows: com (N, 2), fans (N, F, 2) [m], share (N, F) → lo, hi (N,) [N], blocked (N,)."""
    n = len(com)
    lo, hi, blocked = np.empty(n), np.empty(n), np.empty(n, dtype=np.bool_)
    for j in range(n):
        lo[j], hi[j], blocked[j] = _window_mix(com[j, 0], com[j, 1], fans[j, :, 0].copy(), fans[j, :, 1].copy(),
                                               share[j], normals, offsets, weight, tol_thrust, tol_mass, tol_com)
    return lo, hi, blocked
