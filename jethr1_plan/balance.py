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

import functools

import numpy as np

from .robot_model import GRAVITY

#: sentinel thrust for a posture no thrust can balance (ray misses the sole)
NO_BALANCE = np.inf


def zmp_with_thrust(com_xy: np.ndarray, fan_xy: np.ndarray, thrust_n: np.ndarray, mass_kg: float,
                    g: float = GRAVITY) -> np.ndarray:
    """ZMP [m] of (A-1), (A-2) for thrust ``thrust_n`` [N] at ``fan_xy`` and the CoM at ``com_xy``."""
    w = mass_kg * g
    f = np.asarray(thrust_n, dtype=float)[..., None]
    return (w * np.asarray(com_xy) - f * np.asarray(fan_xy)) / (w - f)


def sole_polygon(centre_xy: np.ndarray, yaw_rad: float, length_m: float, width_m: float,
                 margin_m: float = 0.0) -> np.ndarray:
    """Counter-clockwise corners (4, 2) [m] of a sole rectangle, shrunk by ``margin_m`` on every side."""
    hl, hw = length_m / 2 - margin_m, width_m / 2 - margin_m
    if hl <= 0 or hw <= 0:
        raise ValueError(f"sole margin {margin_m} m leaves no support polygon")
    local = np.array([[hl, -hw], [hl, hw], [-hl, hw], [-hl, -hw]])
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    return local @ np.array([[c, s], [-s, c]]) + np.asarray(centre_xy, dtype=float)[:2]


def halfplanes(polygon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Outward normals n (K, 2) and offsets b (K,) with n·x ≤ b inside a CCW convex polygon."""
    polygon = np.asarray(polygon, dtype=float)
    return _halfplanes_of(polygon.tobytes(), len(polygon))


@functools.lru_cache(maxsize=4096)
def _halfplanes_of(data: bytes, k: int) -> tuple[np.ndarray, np.ndarray]:
    polygon = np.frombuffer(data, dtype=float).reshape(k, 2)
    edges = np.roll(polygon, -1, axis=0) - polygon
    normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    offsets = np.einsum("kd,kd->k", normals, polygon)
    normals.setflags(write=False)
    offsets.setflags(write=False)
    return normals, offsets


def inside_polygon(p_xy: np.ndarray, polygon: np.ndarray, tol_m: float = 1e-12) -> np.ndarray:
    """True where ``p_xy`` (..., 2) lies in the convex CCW ``polygon`` (boundary included)."""
    n, b = halfplanes(polygon)
    return np.all(np.einsum("...d,kd->...k", np.asarray(p_xy, dtype=float), n) <= b + tol_m, axis=-1)


def minimal_thrust(com_xy: np.ndarray, fan_xy: np.ndarray, polygon: np.ndarray, mass_kg: float,
                   g: float = GRAVITY) -> tuple[np.ndarray, np.ndarray]:
    """Exact minimal thrust H(P_body) of (A-5) and the ZMP it gives.

    The ZMP ray ZMP(s) = CoM + s·(CoM − P_T), s ≥ 0, is clipped against the polygon's half-planes
    (Cyrus–Beck); the smallest admissible s gives F = M·g·s / (1 + s).

    Args:
        com_xy: (..., 2) CoM ground projection [m].
        fan_xy: (..., 2) thrust point ground projection [m].
        polygon: (K, 2) support polygon, convex, counter-clockwise [m].
        mass_kg: total mass [kg].

    Returns:
        thrust_n (...,) [N], ``inf`` where no thrust balances (the ray misses the polygon);
        zmp_xy (..., 2) [m], the ray's entry point (the CoM if it is inside), NaN where ``inf``.
    """
    com = np.asarray(com_xy, dtype=float)
    d = com - np.asarray(fan_xy, dtype=float)
    n, b = halfplanes(polygon)
    nc = com @ n.T
    nd = d @ n.T
    slack = b - nc  # ≥ 0 on the inner side of edge k
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = slack / nd
    lower = np.where(nd < 0, ratio, -np.inf)
    upper = np.where(nd > 0, ratio, np.inf)
    parallel_out = (nd == 0) & (slack < 0)
    s_lo = np.maximum(lower.max(axis=-1), 0.0)
    s_hi = upper.min(axis=-1)
    ok = (s_lo <= s_hi) & ~parallel_out.any(axis=-1)
    s = np.where(ok, s_lo, np.nan)
    w = mass_kg * g
    thrust = np.where(ok, w * s / (1.0 + s), NO_BALANCE)
    zmp = com + s[..., None] * d
    return thrust, zmp


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


def edge_angle_excess(origin_xy: np.ndarray, com_xy: np.ndarray, ankle_xy: np.ndarray, rho_rad: float) -> np.ndarray:
    """How far (A-10) is violated [rad]: max(|θ_ZC − θ_CA| − ρ, 0).

    Applied to every posture, with or without thrust, as Paper A writes it: a condition that only
    switched on with the fan would let a thrust-free posture leave the cone, and the postures
    interpolated between it and the next (thrust-borne) sample would break it.
    """
    return np.maximum(edge_angle_error(origin_xy, com_xy, ankle_xy) - rho_rad, 0.0)


def wrap_angle(a: np.ndarray | float) -> np.ndarray:
    """Wrap [rad] to (−π, π]."""
    return -((-np.asarray(a, dtype=float) + np.pi) % (2 * np.pi) - np.pi)


def body_yaw_eq4(support_xy: np.ndarray, fan_xy: np.ndarray, support_side: str) -> np.ndarray:
    """Trunk yaw [rad] of (A-4): the hip line turned towards the fan.

    γ = atan2(P_T,y − Z_y, P_T,x − Z_x) is the direction from the support point Z to the fan. The
    trunk is yawed so that the line from the support hip to the swing hip points along γ. At zero
    yaw that line points along +y for a right support foot and along −y for a left one.
    """
    d = np.asarray(fan_xy, dtype=float) - np.asarray(support_xy, dtype=float)
    gamma = np.arctan2(d[..., 1], d[..., 0])
    hip_line0 = np.pi / 2 if support_side == "right" else -np.pi / 2
    return wrap_angle(gamma - hip_line0)


def body_yaw_forward_axis(support_xy: np.ndarray, fan_xy: np.ndarray) -> np.ndarray:
    """The other reading of (A-4): the trunk's forward (x) axis along γ [rad]."""
    d = np.asarray(fan_xy, dtype=float) - np.asarray(support_xy, dtype=float)
    return np.arctan2(d[..., 1], d[..., 0])
