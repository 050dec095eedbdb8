"""Quasistatic balance with a vertical thrust: Paper A, eqs. (A-1)..(A-4), (A-10).

Pure functions over numpy arrays; positions are ground-plane (x, y) in metres, forces in newtons.
Every function accepts a leading batch dimension (``...``) so the optimisers evaluate whole
populations at once.

Moment balance (gravity M·g at the CoM, thrust F at the fan P_T, ground reaction at the ZMP)::

    ZMP = (M·g·CoM − F·P_T) / (M·g − F),   0 ≤ F < M·g            (A-1), (A-2)

As F grows from 0 the ZMP moves from the CoM along the ray pointing away from P_T:
ZMP = CoM + s·(CoM − P_T) with s = F / (M·g − F). The minimal thrust is where that ray first
enters the support polygon, which makes H(P_body) of (A-5) exact and closed-form.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from jethr1_plan.geometry import GRAVITY, halfplanes, wrap_angle

__all__ = [
    "NOMINAL",
    "Tolerance",
    "balance_slack",
    "body_yaw_eq4",
    "body_yaw_forward_axis",
    "edge_angle_error",
    "edge_angle_excess",
    "least_thrust",
    "minimal_thrust",
    "shared_window",
    "thrust_window",
    "window_bounds",
    "zmp_with_thrust",
    "zmp_with_thrusts",
]


def zmp_with_thrust(com_xy: ArrayLike, fan_xy: ArrayLike, thrust_n: ArrayLike, mass_kg: float,
                    g: float = GRAVITY) -> np.ndarray:
    """ZMP [m] of (A-1), (A-2) for thrust ``thrust_n`` [N] at ``fan_xy`` and the CoM at ``com_xy``."""
    w = mass_kg * g
    f = np.asarray(thrust_n, dtype=float)[..., None]
    return (w * np.asarray(com_xy) - f * np.asarray(fan_xy)) / (w - f)


def minimal_thrust(com_xy: np.ndarray, fan_xy: np.ndarray, polygon: np.ndarray, mass_kg: float,
                   g: float = GRAVITY) -> tuple[np.ndarray, np.ndarray]:
    """Exact minimal thrust H(P_body) of (A-5) and the ZMP it gives: the lower end of the nominal
    :func:`thrust_window`, where the ZMP ray ZMP(s) = CoM + s·(CoM − P_T), s = F/(M·g − F),
    enters the polygon.

    Args:
        com_xy: (..., 2) CoM ground projection [m].
        fan_xy: (..., 2) thrust point ground projection [m].
        polygon: (K, 2) support polygon, convex, counter-clockwise [m].
        mass_kg: total mass [kg].

    Returns:
        thrust_n (...,) [N], ``inf`` where no thrust balances (the ray misses the polygon);
        zmp_xy (..., 2) [m], the ray's entry point (the CoM if it is inside), NaN where ``inf``.
    """
    lo, _ = thrust_window(com_xy, fan_xy, polygon, mass_kg, NOMINAL, g)
    with np.errstate(invalid="ignore"):
        zmp = zmp_with_thrust(com_xy, fan_xy, np.where(np.isfinite(lo), lo, np.nan), mass_kg, g)
    return lo, zmp


@dataclass(frozen=True)
class Tolerance:
    """Model errors a balanced posture must survive (the robust policy; all zero: Paper A's).

    ``thrust``: relative error of each fan's thrust (0.1: the fan gives 90..110 % of its command);
    ``mass``: relative error of the total mass, the CoM unchanged (a uniform scale of every link);
    ``com_m``: error of the CoM's ground position, in any direction [m].
    """

    thrust: float = 0.0
    mass: float = 0.0
    com_m: float = 0.0

    def scaled(self, k: float) -> Tolerance:
        """Every tolerance times ``k``."""
        return Tolerance(self.thrust * k, self.mass * k, self.com_m * k)


NOMINAL = Tolerance()


def _rows(x: np.ndarray, shape: tuple) -> np.ndarray:
    """``x`` broadcast to ``shape`` + (2,) and flattened to contiguous (M, 2) rows."""
    return np.ascontiguousarray(np.broadcast_to(np.asarray(x, dtype=float), (*shape, 2)).reshape(-1, 2))


def window_bounds(com_xy: np.ndarray, fan_xy: np.ndarray, polygon: np.ndarray, mass_kg: float,
                  tol: Tolerance = NOMINAL, g: float = GRAVITY) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The bounds of :func:`thrust_window` before they are intersected: lo [N] (≥ 0), hi [N], and
    ``blocked`` (...,) where an edge no thrust can move the ZMP across lies on the wrong side. The
    window is [lo, hi] where ``lo <= hi`` and not ``blocked``; where ``lo > hi``, lo − hi [N] says how
    far it is from opening. Computed by ``physics.compiled.windows`` (one implementation for every caller).
    """
    from jethr1_plan.physics.compiled.windows import windows

    shape = np.broadcast_shapes(np.shape(com_xy)[:-1], np.shape(fan_xy)[:-1])
    n, b = halfplanes(polygon)
    lo, hi, blocked = windows(_rows(com_xy, shape), _rows(fan_xy, shape), np.ascontiguousarray(n),
                              np.ascontiguousarray(b), mass_kg * g, tol.thrust, tol.mass, tol.com_m)
    return lo.reshape(shape), hi.reshape(shape), blocked.reshape(shape)


def thrust_window(com_xy: np.ndarray, fan_xy: np.ndarray, polygon: np.ndarray, mass_kg: float,
                  tol: Tolerance = NOMINAL, g: float = GRAVITY) -> tuple[np.ndarray, np.ndarray]:
    """The thrusts [N] of one fan that keep the ZMP in ``polygon`` under every error within ``tol``.

    With d_k = n_k·CoM − b_k (how far the CoM lies beyond edge k) and a_k = n_k·P_T − b_k (the same
    for the fan), moment balance (A-1, A-2) puts the ZMP inside edge k exactly when
    F·a_k ≥ M·g·d_k. With the fan giving F(1 + e), |e| ≤ X, the mass M(1 + m), |m| ≤ Y, and the CoM
    off by a vector of length ≤ ε, the worst case of each side is taken separately (both are linear
    in the errors):

        F·(a_k − X·|a_k|)  ≥  M·g·((d_k + ε) + Y·|d_k + ε|)                          for every edge k.

    Each edge gives a lower bound (a_k − X|a_k| > 0), an upper bound (< 0) or a condition on the
    posture alone (= 0); the window is their intersection with F ≥ 0 and F(1 + X) < M·g(1 − Y)
    (the ZMP formula needs thrust below weight). With ``tol`` zero its lower end is the minimal
    thrust H(P_body) of (A-5), where the ZMP ray enters the polygon, and its upper end where the ray
    leaves it on the far side.

    Args:
        com_xy, fan_xy: (..., 2) ground projections of the CoM and the thrust point [m].
        polygon: (K, 2) support polygon, convex, counter-clockwise [m].
        mass_kg: the model's total mass [kg].

    Returns:
        lo, hi (...,) [N]: the window; lo = inf and hi = nan where it is empty (no thrust balances).
        The fan's maximum is not applied here.
    """
    lo, hi, blocked = window_bounds(com_xy, fan_xy, polygon, mass_kg, tol, g)
    empty = (lo > hi) | blocked
    return np.where(empty, np.inf, lo), np.where(empty, np.nan, hi)


def least_thrust(com_xy: np.ndarray, fan_xy: np.ndarray, polygon: np.ndarray, mass_kg: float,
                 fan_max_n: np.ndarray | None = None, tol: Tolerance = NOMINAL, g: float = GRAVITY
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The least total thrust of several fans that keeps the ZMP in ``polygon`` under every error
    within ``tol``, and its split: the inequalities of :func:`thrust_window` summed over the fans
    (each fan's error independent),

        Σ_i F_i·(a_ik − X·|a_ik|)  ≥  M·g·((d_k + ε) + Y·|d_k + ε|)   for every edge k,
        Σ_i F_i·(1 + X) < M·g·(1 − Y),   0 ≤ F_i (≤ fan_max_n[i] where given),

    a small linear programme (``physics.compiled.least_total``). With one fan and no maximum its
    total is the window's lower end (:func:`thrust_window`).

    Args:
        com_xy: (..., 2) [m]; fan_xy: (..., F, 2) [m]; fan_max_n: (F,) [N] or None (no maximum).
    Returns:
        total (...,) [N], inf where no thrust balances; split (..., F) [N], NaN there.
    """
    from jethr1_plan.physics.compiled.windows import least_totals

    fan_xy = np.asarray(fan_xy, dtype=float)
    nf = fan_xy.shape[-2]
    shape = np.broadcast_shapes(np.shape(com_xy)[:-1], fan_xy.shape[:-2])
    n, b = halfplanes(polygon)
    com = _rows(com_xy, shape)
    if nf == 0:  # no fan: the CoM itself must be inside, with its errors
        d = com @ n.T - b + tol.com_m
        ok = np.all(d + tol.mass * np.abs(d) <= 0.0, axis=1)
        return np.where(ok, 0.0, np.inf).reshape(shape), np.zeros((*shape, 0))
    fans = np.ascontiguousarray(np.broadcast_to(fan_xy, (*shape, nf, 2)).reshape(-1, nf, 2))
    bounded = fan_max_n is not None
    fmax = np.ascontiguousarray(np.full(nf, np.inf) if fan_max_n is None else np.asarray(fan_max_n, dtype=float))
    total, split = least_totals(com, fans, fmax, np.ascontiguousarray(n), np.ascontiguousarray(b), mass_kg * g,
                                tol.thrust, tol.mass, tol.com_m, bounded)
    return total.reshape(shape), split.reshape(*shape, nf)


def shared_window(com_xy: np.ndarray, fan_xy: np.ndarray, share: np.ndarray, polygon: np.ndarray, mass_kg: float,
                  tol: Tolerance = NOMINAL, g: float = GRAVITY) -> tuple[np.ndarray, np.ndarray]:
    """The thrust window of several fans that keep fixed shares of their total: the totals T [N] for
    which the thrusts T·share_i keep the ZMP in ``polygon`` under every error within ``tol`` (the
    window along the planned split). With one fan (share 1) it is :func:`thrust_window`.

    Args:
        com_xy: (..., 2) [m]; fan_xy: (..., F, 2) [m]; share: (..., F), summing to 1.
    Returns:
        lo, hi (...,) [N]; lo = inf and hi = nan where it is empty.
    """
    from jethr1_plan.physics.compiled.windows import mixed_windows

    fan_xy = np.asarray(fan_xy, dtype=float)
    nf = fan_xy.shape[-2]
    shape = np.broadcast_shapes(np.shape(com_xy)[:-1], fan_xy.shape[:-2], np.shape(share)[:-1])
    n, b = halfplanes(polygon)
    fans = np.ascontiguousarray(np.broadcast_to(fan_xy, (*shape, nf, 2)).reshape(-1, nf, 2))
    shares = np.ascontiguousarray(np.broadcast_to(np.asarray(share, dtype=float), (*shape, nf)).reshape(-1, nf))
    lo, hi, blocked = mixed_windows(_rows(com_xy, shape), fans, shares, np.ascontiguousarray(n),
                                    np.ascontiguousarray(b), mass_kg * g, tol.thrust, tol.mass, tol.com_m)
    lo, hi, blocked = lo.reshape(shape), hi.reshape(shape), blocked.reshape(shape)
    empty = (lo > hi) | blocked
    return np.where(empty, np.inf, lo), np.where(empty, np.nan, hi)


def zmp_with_thrusts(com_xy: np.ndarray, fan_xy: np.ndarray, thrust_n: np.ndarray, mass_kg: float,
                     g: float = GRAVITY) -> np.ndarray:
    """ZMP [m] of (A-1), (A-2) with several fans: (M·g·CoM − Σ_i F_i·P_Ti) / (M·g − Σ_i F_i).

    Args:
        com_xy: (..., 2) [m]; fan_xy: (..., F, 2) [m]; thrust_n: (..., F) [N].
    """
    w = mass_kg * g
    f = np.asarray(thrust_n, dtype=float)
    moment = np.einsum("...f,...fd->...d", f, np.asarray(fan_xy, dtype=float))
    return (w * np.asarray(com_xy, dtype=float) - moment) / (w - f.sum(axis=-1))[..., None]


def balance_slack(com_xy: np.ndarray, fan_xy: np.ndarray, thrust_n: np.ndarray, polygon: np.ndarray,
                  mass_kg: float, tol: Tolerance = NOMINAL, g: float = GRAVITY) -> np.ndarray:
    """How well given thrusts of several fans balance a posture under every error within ``tol`` [N·m]:
    min over the polygon's edges of Σ_i F_i·(a_ik − X·|a_ik|) − M·g·((d_k + ε) + Y·|d_k + ε|), the
    inequality of :func:`thrust_window` for each fan's thrust F_i at ``fan_xy[..., i, :]``. It is ≥ 0
    exactly when the ZMP stays in the polygon for every error (each fan's error independent).

    Args:
        com_xy: (..., 2) [m]; fan_xy: (..., F, 2) [m]; thrust_n: (..., F) [N].
    """
    n, b = halfplanes(polygon)
    d = np.asarray(com_xy, dtype=float) @ n.T - b + tol.com_m  # (..., K)
    a = np.asarray(fan_xy, dtype=float) @ n.T - b  # (..., F, K)
    lift = np.einsum("...f,...fk->...k", np.asarray(thrust_n, dtype=float), a - tol.thrust * np.abs(a))
    return (lift - mass_kg * g * (d + tol.mass * np.abs(d))).min(axis=-1)


def edge_angle_error(origin_xy: np.ndarray, com_xy: np.ndarray, ankle_xy: np.ndarray) -> np.ndarray:
    """|θ_ZC − θ_CA| of (A-10) [rad], wrapped to [0, π].

    θ_ZC is the direction of origin→CoM and θ_CA of CoM→(swing ankle on the ground), both from
    the Y axis, so their difference is the unsigned angle between the two directions,
    atan2(|u×v|, u·v). A small value means the CoM lies near the line from the support point to the
    swing ankle. Where either direction is shorter than 1e-9 m the angle is undefined: 0. Computed by
    ``physics.compiled.edge_errors``.
    """
    from jethr1_plan.physics.compiled.edge import edge_errors

    shape = np.broadcast_shapes(np.shape(origin_xy)[:-1], np.shape(com_xy)[:-1], np.shape(ankle_xy)[:-1])
    return edge_errors(_rows(origin_xy, shape), _rows(com_xy, shape), _rows(ankle_xy, shape)).reshape(shape)


def edge_angle_excess(origin_xy: np.ndarray, com_xy: np.ndarray, ankle_xy: np.ndarray, rho_rad: float) -> np.ndarray:
    """How far (A-10) is violated [rad]: max(|θ_ZC − θ_CA| − ρ, 0).

    Applied to every posture, with or without thrust, as Paper A writes it: a condition that only
    switched on with the fan would let a thrust-free posture leave the cone, and the postures
    interpolated between it and the next (thrust-borne) sample would break it.
    """
    return np.maximum(edge_angle_error(origin_xy, com_xy, ankle_xy) - rho_rad, 0.0)


def body_yaw_eq4(support_xy: np.ndarray, fan_xy: np.ndarray, support_side: str) -> np.ndarray:
    """Trunk yaw [rad] of (A-4): the hip line turned towards the fan.

    γ = atan2(P_T,y − Z_y, P_T,x − Z_x) is the direction from the support point Z to the fan. The
    trunk is yawed so that the line from the support hip to the swing hip points along γ. At zero
    yaw that line points along +y for a right support foot and along −y for a left one. The mirror image
    (y → −y) of a right support gives the opposite yaw of the left one exactly.
    """
    d = np.asarray(fan_xy, dtype=float) - np.asarray(support_xy, dtype=float)
    s = 1.0 if support_side == "right" else -1.0  # a left support computed as the mirror of a right, to the bit
    gamma = np.arctan2(s * d[..., 1], d[..., 0])
    return s * wrap_angle(gamma - np.pi / 2)


def body_yaw_forward_axis(support_xy: np.ndarray, fan_xy: np.ndarray) -> np.ndarray:
    """The other reading of (A-4): the trunk's forward (x) axis along γ [rad]."""
    d = np.asarray(fan_xy, dtype=float) - np.asarray(support_xy, dtype=float)
    return np.arctan2(d[..., 1], d[..., 0])
