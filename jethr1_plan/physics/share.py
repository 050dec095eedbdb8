"""The share of a tolerance a posture, or a posture and its thrust, survives (the robust policy's
"most robust plan", ``docs/robust_planning.md``).

A tolerance T = (X, Y, ε) scaled by a share s ∈ [0, 1] is (s·X, s·Y, s·ε). For every edge k of the
support polygon and thrusts F_i at the fans, the balance row of ``balance.thrust_window`` is

    slack_k(s) = Σ_i F_i·(a_ik − s·X·|a_ik|) − M·g·(d_k + s·ε)·(1 ± s·Y)      (+ where d_k + s·ε ≥ 0)

Each slack_k falls as s grows (its fan side loses s·X·Σ F_i|a_ik|; the weight side, (d + sε)(1 ± sY),
has the derivative ε(1 ± 2sY) ± Y·d > 0 on either branch for sY < 1), so the thrusts that balance
under s·T shrink as s grows, and "the largest share" is well defined and found by bisection:

* :func:`largest_shares`: per posture (CoM, fans), the largest s for which *some* thrust within the
  fans' maxima balances under s·T (the thrust window of one fan, the least-total LP of several, still
  open): what a posture offers, the quantity GAS's share pass maximises;
* :func:`row_shares`: per posture *and thrust*, the largest s for which that thrust balances under
  s·T (min_k slack_k(s) ≥ 0): what a written row survives (the plan's ``tolerance_share`` column).

Both return values in [0, 1]; :func:`largest_shares` returns −1 where not even the nominal model
balances. Units: m, N.
"""

from __future__ import annotations

import numpy as np

from jethr1_plan.geometry import GRAVITY, halfplanes
from jethr1_plan.physics.balance import Tolerance
from jethr1_plan.physics.compiled.jit import kernel
from jethr1_plan.physics.compiled.windows import _window, least_total

__all__ = ["SHARE_ITERATIONS", "largest_shares", "row_shares"]

SHARE_ITERATIONS = 40  # bisection steps: the share to 1e-12


@kernel
def _balances_at(s, cx, cy, fxs, fys, fmax, normals, offsets, weight, tol_thrust, tol_mass, tol_com, out):
    """Whether some thrust within ``fmax`` balances one CoM under s × the tolerance."""
    if len(fxs) == 1:
        lo, hi, blocked = _window(cx, cy, fxs[0], fys[0], normals, offsets, weight, s * tol_thrust, s * tol_mass,
                                  s * tol_com)
        return (not blocked) and lo <= min(hi, fmax[0])
    total = least_total(cx, cy, fxs, fys, fmax, normals, offsets, weight, s * tol_thrust, s * tol_mass, s * tol_com,
                        True, out)
    return total < np.inf


@kernel
def _largest(com, fans, fmax, normals, offsets, weight, tol_thrust, tol_mass, tol_com, iterations):
    n, nf = fans.shape[0], fans.shape[1]
    share = np.empty(n)
    out = np.empty(nf)
    for j in range(n):
        fxs, fys = fans[j, :, 0].copy(), fans[j, :, 1].copy()
        args = (com[j, 0], com[j, 1], fxs, fys, fmax, normals, offsets, weight, tol_thrust, tol_mass, tol_com, out)
        if _balances_at(1.0, *args):
            share[j] = 1.0
            continue
        if not _balances_at(0.0, *args):
            share[j] = -1.0
            continue
        lo, hi = 0.0, 1.0
        for _ in range(iterations):
            mid = 0.5 * (lo + hi)
            if _balances_at(mid, *args):
                lo = mid
            else:
                hi = mid
        share[j] = lo
    return share


@kernel
def _least_slack(s, cx, cy, fxs, fys, thrust, normals, offsets, weight, tol_thrust, tol_mass, tol_com):
    """min_k slack_k(s) [N·m] (the module docstring)."""
    least = np.inf
    for k in range(len(offsets)):
        nx, ny = normals[k, 0], normals[k, 1]
        lift = 0.0
        for i in range(len(fxs)):
            a = fxs[i] * nx + fys[i] * ny - offsets[k]
            lift += thrust[i] * (a - s * tol_thrust * abs(a))
        d = cx * nx + cy * ny - offsets[k] + s * tol_com
        least = min(least, lift - weight * (d + s * tol_mass * abs(d)))
    return least


@kernel
def _row(com, fans, thrust, normals, offsets, weight, tol_thrust, tol_mass, tol_com, iterations):
    n = len(com)
    share = np.empty(n)
    for j in range(n):
        fxs, fys = fans[j, :, 0].copy(), fans[j, :, 1].copy()
        args = (com[j, 0], com[j, 1], fxs, fys, thrust[j], normals, offsets, weight, tol_thrust, tol_mass, tol_com)
        if _least_slack(1.0, *args) >= 0.0:
            share[j] = 1.0
            continue
        if _least_slack(0.0, *args) < 0.0:
            share[j] = 0.0
            continue
        lo, hi = 0.0, 1.0
        for _ in range(iterations):
            mid = 0.5 * (lo + hi)
            if _least_slack(mid, *args) >= 0.0:
                lo = mid
            else:
                hi = mid
        share[j] = lo
    return share


def _flat(com_xy: np.ndarray, fan_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple]:
    fan_xy = np.asarray(fan_xy, dtype=float)
    nf = fan_xy.shape[-2]
    shape = np.broadcast_shapes(np.shape(com_xy)[:-1], fan_xy.shape[:-2])
    com = np.ascontiguousarray(np.broadcast_to(np.asarray(com_xy, dtype=float), (*shape, 2)).reshape(-1, 2))
    fans = np.ascontiguousarray(np.broadcast_to(fan_xy, (*shape, nf, 2)).reshape(-1, nf, 2))
    return com, fans, shape


def largest_shares(com_xy: np.ndarray, fan_xy: np.ndarray, polygon: np.ndarray, mass_kg: float, tol: Tolerance,
                   fan_max_n: np.ndarray, g: float = GRAVITY) -> np.ndarray:
    """The largest share s ∈ [0, 1] of ``tol`` under which some thrust of the fans, each within its
    maximum, keeps the ZMP in ``polygon`` (−1 where none does even without errors).

    Args:
        com_xy: (..., 2) [m]; fan_xy: (..., F, 2) [m]; fan_max_n: (F,) [N], each fan's maximum.
    """
    com, fans, shape = _flat(com_xy, fan_xy)
    n, b = halfplanes(polygon)
    fmax = np.ascontiguousarray(np.broadcast_to(np.asarray(fan_max_n, dtype=float), (fans.shape[1],)))
    out = _largest(com, fans, fmax, np.ascontiguousarray(n), np.ascontiguousarray(b), mass_kg * g, tol.thrust,
                   tol.mass, tol.com_m, SHARE_ITERATIONS)
    return out.reshape(shape)


def row_shares(com_xy: np.ndarray, fan_xy: np.ndarray, thrust_n: np.ndarray, polygon: np.ndarray, mass_kg: float,
               tol: Tolerance, g: float = GRAVITY) -> np.ndarray:
    """The largest share s ∈ [0, 1] of ``tol`` under which the given thrusts keep the ZMP in
    ``polygon`` (``balance.balance_slack`` ≥ 0 at s·tol; 0 where they do not even without errors).

    Args:
        com_xy: (..., 2) [m]; fan_xy: (..., F, 2) [m]; thrust_n: (..., F) [N].
    """
    com, fans, shape = _flat(com_xy, fan_xy)
    thrust = np.ascontiguousarray(np.broadcast_to(np.asarray(thrust_n, dtype=float), (*shape, fans.shape[1]))
                                  .reshape(-1, fans.shape[1]))
    n, b = halfplanes(polygon)
    out = _row(com, fans, thrust, np.ascontiguousarray(n), np.ascontiguousarray(b), mass_kg * g, tol.thrust, tol.mass,
               tol.com_m, SHARE_ITERATIONS)
    return out.reshape(shape)
