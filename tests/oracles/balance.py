"""The numpy statements of the per-candidate physics that the package computes compiled
(``jethr1_plan.physics.compiled``): kept here as the oracle the tests hold the compiled code to.

The closed-form leg IK and CoM oracle is ``tests/leg_oracle.py``; the forward kinematics oracle is
``tests/urdf_reference.py``.
"""

from __future__ import annotations

import numpy as np

from jethr1_plan.geometry import GRAVITY, halfplanes
from jethr1_plan.physics.balance import NOMINAL, Tolerance


def window_bounds(com_xy: np.ndarray, fan_xy: np.ndarray, polygon: np.ndarray, mass_kg: float,
                  tol: Tolerance = NOMINAL, g: float = GRAVITY) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The bounds of :func:`thrust_window` before they are intersected: lo [N] (≥ 0), hi [N], and
    ``blocked`` (...,) where an edge no thrust can move the ZMP across lies on the wrong side. The
    window is [lo, hi] where ``lo <= hi`` and not ``blocked``; where ``lo > hi``, lo − hi [N] says how
    far it is from opening."""
    n, b = halfplanes(polygon)
    w = mass_kg * g
    d = np.asarray(com_xy, dtype=float) @ n.T - b + tol.com_m  # (..., K)
    a = np.asarray(fan_xy, dtype=float) @ n.T - b
    rhs = w * (d + tol.mass * np.abs(d))
    coef = a - tol.thrust * np.abs(a)
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = rhs / coef
    lo = np.maximum(np.where(coef > 0, bound, -np.inf).max(axis=-1), 0.0)
    hi = np.minimum(np.where(coef < 0, bound, np.inf).min(axis=-1),
                    w * (1.0 - tol.mass) / (1.0 + tol.thrust) * (1.0 - 1e-9))
    return lo, hi, np.any((coef == 0) & (rhs > 0), axis=-1)


def direction_from_y_axis(v_xy: np.ndarray) -> np.ndarray:
    """Angle [rad] of the direction ``v_xy`` measured from the +Y axis (positive towards +X)."""
    v = np.asarray(v_xy, dtype=float)
    return np.arctan2(v[..., 0], v[..., 1])


def edge_angle_error(origin_xy: np.ndarray, com_xy: np.ndarray, ankle_xy: np.ndarray) -> np.ndarray:
    """|θ_ZC − θ_CA| of (A-10) [rad], wrapped to [0, π].

    θ_ZC is the direction of origin→CoM and θ_CA of CoM→(swing ankle on the ground), both from
    the Y axis. A small value means the CoM lies near the line from the support point to the swing
    ankle. Where the CoM coincides with the origin (within 1e-9 m) the angle is undefined: 0.
    """
    zc = np.asarray(com_xy, dtype=float) - np.asarray(origin_xy, dtype=float)
    ca = np.asarray(ankle_xy, dtype=float) - np.asarray(com_xy, dtype=float)
    diff = direction_from_y_axis(zc) - direction_from_y_axis(ca)
    err = np.abs((diff + np.pi) % (2 * np.pi) - np.pi)
    degenerate = (np.linalg.norm(zc, axis=-1) < 1e-9) | (np.linalg.norm(ca, axis=-1) < 1e-9)
    return np.where(degenerate, 0.0, err)
