"""Shared geometry, stated once: the two sides, gravity, sole rectangles, convex polygons, rotations.

Polygons are (K, 2) arrays of ground-plane corners [m], convex and counter-clockwise. Quaternions
are (x, y, z, w), as ROS, Foxglove and pinocchio order them. World frame: z up, x forward, y left
(REP 103).
"""

from __future__ import annotations

import functools
import math
from enum import StrEnum

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "GRAVITY",
    "SIDES",
    "Side",
    "convex_hull",
    "halfplanes",
    "inside_polygon",
    "other_side",
    "polygon_margin",
    "pose_difference",
    "pose_from_quaternion",
    "pose_matrix",
    "quat_axis_angle",
    "quat_mul",
    "quat_rpy",
    "quaternion_from_matrix",
    "sole_polygon",
    "soles_hull",
    "wrap_angle",
    "yaw_quaternion",
]

GRAVITY = 9.81  # standard gravity [m/s²]


class Side(StrEnum):
    """A foot, a leg or a fan's mount. Compares and prints as ``"left"``/``"right"``."""

    LEFT = "left"
    RIGHT = "right"

    @property
    def other(self) -> Side:
        """The opposite side."""
        return Side.RIGHT if self is Side.LEFT else Side.LEFT


SIDES: tuple[str, str] = (Side.LEFT, Side.RIGHT)  # Side members, typed as the strings they are


def other_side(side: str) -> str:
    """The side opposite ``side`` (``"left"`` or ``"right"``), as its plain string.

    Raises:
        ValueError: ``side`` is neither.
    """
    return Side(side).other.value


# --- polygons ---------------------------------------------------------------------------------


def sole_polygon(centre_xy: ArrayLike, yaw_rad: float, length_m: float, width_m: float,
                 margin_m: float = 0.0) -> np.ndarray:
    """Counter-clockwise corners (4, 2) [m] of a sole rectangle, shrunk by ``margin_m`` on every side.

    Raises:
        ValueError: the margin leaves no rectangle.
    """
    hl, hw = length_m / 2 - margin_m, width_m / 2 - margin_m
    if hl <= 0 or hw <= 0:
        raise ValueError(f"sole margin {margin_m} m leaves no support polygon")
    local = np.array([[hl, -hw], [hl, hw], [-hl, hw], [-hl, -hw]])
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    return local @ np.array([[c, s], [-s, c]]) + np.asarray(centre_xy, dtype=float)[:2]


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull (K, 2) of 2-D points (Andrew's monotone chain)."""
    pts = np.unique(np.round(points, 12), axis=0)
    pts = pts[np.lexsort((pts[:, 1], pts[:, 0]))]

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[np.ndarray] = []
    upper: list[np.ndarray] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in pts[::-1]:
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])


def soles_hull(centres_xy: list[ArrayLike], yaws_rad: list[float], length_m: float, width_m: float,
               margin_m: float = 0.0) -> np.ndarray:
    """The support polygon of the soles at ``centres_xy``: one sole's rectangle, or the convex hull
    of several (each shrunk by ``margin_m``) [m]."""
    polys = [sole_polygon(c, y, length_m, width_m, margin_m) for c, y in zip(centres_xy, yaws_rad, strict=True)]
    return polys[0] if len(polys) == 1 else convex_hull(np.vstack(polys))


def halfplanes(polygon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Outward unit normals n (K, 2) and offsets b (K,) with n·x ≤ b inside a CCW convex polygon."""
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


def inside_polygon(p_xy: ArrayLike, polygon: np.ndarray, tol_m: float = 1e-12) -> np.ndarray:
    """True where ``p_xy`` (..., 2) lies in the convex CCW ``polygon`` (boundary included)."""
    n, b = halfplanes(polygon)
    return np.all(np.einsum("...d,kd->...k", np.asarray(p_xy, dtype=float), n) <= b + tol_m, axis=-1)


def polygon_margin(p_xy: ArrayLike, polygon: np.ndarray) -> np.ndarray:
    """Signed distance [m] from ``p_xy`` (..., 2) to the nearest edge line of a convex CCW polygon:
    positive inside (the distance to the nearest edge), negative outside (how far beyond the worst
    edge)."""
    n, b = halfplanes(polygon)
    return (b - np.asarray(p_xy, dtype=float) @ n.T).min(axis=-1)


# --- rotations ---------------------------------------------------------------------------------


def wrap_angle(a: ArrayLike) -> np.ndarray:
    """Wrap [rad] to (−π, π]: odd to the bit (wrap(−a) = −wrap(a) but at ±π), angles within range unchanged.

    The magnitude is wrapped and the sign put back, so a left support's yaw is the exact mirror of a right's
    (``physics.balance.body_yaw_eq4``)."""
    a = np.asarray(a, dtype=float)
    w = np.abs(a)
    w = np.where(w > np.pi, w - 2 * np.pi * np.floor((w + np.pi) / (2 * np.pi)), w)
    out = np.where(a < 0, -w, w)
    return np.where(out == -np.pi, np.pi, out)[()]


def yaw_quaternion(yaw_rad: float) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) of a rotation by ``yaw_rad`` about z."""
    return 0.0, 0.0, math.sin(yaw_rad / 2), math.cos(yaw_rad / 2)


def quat_mul(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """Hamilton product of quaternions (x, y, z, w)."""
    ax, ay, az, aw = np.asarray(a, dtype=float)
    bx, by, bz, bw = np.asarray(b, dtype=float)
    return np.array([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz])


def quat_axis_angle(axis: ArrayLike, angle_rad: float) -> np.ndarray:
    """Quaternion (x, y, z, w) of a rotation by ``angle_rad`` about ``axis``."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    return np.array([*(a * math.sin(angle_rad / 2)), math.cos(angle_rad / 2)])


def quat_rpy(rpy: ArrayLike) -> np.ndarray:
    """Quaternion of URDF fixed-axis roll, pitch, yaw [rad]: R = Rz(y)·Ry(p)·Rx(r)."""
    r, p, y = (float(v) for v in np.asarray(rpy, dtype=float))
    return quat_mul(quat_axis_angle((0, 0, 1), y), quat_mul(quat_axis_angle((0, 1, 0), p),
                                                            quat_axis_angle((1, 0, 0), r)))


def pose_matrix(xyz: ArrayLike, yaw_rad: float) -> np.ndarray:
    """4×4 homogeneous transform of a level frame at ``xyz`` [m] turned by ``yaw_rad`` about z."""
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    T = np.eye(4)
    T[0, 0], T[0, 1], T[1, 0], T[1, 1] = c, -s, s, c
    T[:3, 3] = xyz
    return T


def pose_from_quaternion(xyz: ArrayLike, quat_xyzw: ArrayLike) -> np.ndarray:
    """4×4 homogeneous transform from a position [m] and a unit quaternion (x, y, z, w)."""
    qx, qy, qz, qw = (float(v) for v in np.asarray(quat_xyzw, dtype=float))
    T = np.eye(4)
    T[:3, :3] = [[1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
                 [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
                 [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)]]
    T[:3, 3] = xyz
    return T


def quaternion_from_matrix(R: np.ndarray) -> np.ndarray:
    """(x, y, z, w) of a rotation matrix (the inverse of :func:`pose_from_quaternion`'s rotation; w ≥ 0),
    by Shepperd's method: the largest component from the diagonal, the others from the off-diagonal
    sums and differences (accurate to round-off for small rotations too, where the square roots of
    1 ± R_ii ∓ … cancel)."""
    R = np.asarray(R, dtype=float)
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    k = int(np.argmax([tr, R[0, 0], R[1, 1], R[2, 2]]))
    if k == 0:
        w = np.sqrt(1.0 + tr) / 2.0
        x, y, z = (R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w)
    elif k == 1:
        x = np.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2]) / 2.0
        w, y, z = (R[2, 1] - R[1, 2]) / (4 * x), (R[0, 1] + R[1, 0]) / (4 * x), (R[0, 2] + R[2, 0]) / (4 * x)
    elif k == 2:
        y = np.sqrt(1.0 - R[0, 0] + R[1, 1] - R[2, 2]) / 2.0
        w, x, z = (R[0, 2] - R[2, 0]) / (4 * y), (R[0, 1] + R[1, 0]) / (4 * y), (R[1, 2] + R[2, 1]) / (4 * y)
    else:
        z = np.sqrt(1.0 - R[0, 0] - R[1, 1] + R[2, 2]) / 2.0
        w, x, y = (R[1, 0] - R[0, 1]) / (4 * z), (R[0, 2] + R[2, 0]) / (4 * z), (R[1, 2] + R[2, 1]) / (4 * z)
    out = np.array([x, y, z, w])
    return -out if w < 0 else out


def pose_difference(T0: np.ndarray, T1: np.ndarray) -> np.ndarray:
    """(..., 6) the twist (linear [m], angular [rad], in ``T0``'s own frame) that carries pose ``T0`` to
    ``T1`` (..., 4, 4) in unit time: log of T0⁻¹·T1 on SE(3), the free-flyer's difference in pinocchio's
    convention (its second central differences are the base's spatial acceleration). Rotations between
    the two poses below π/2."""
    T0, T1 = np.asarray(T0, dtype=float), np.asarray(T1, dtype=float)
    R0t = np.swapaxes(T0[..., :3, :3], -1, -2)
    R = R0t @ T1[..., :3, :3]
    p = np.einsum("...ij,...j->...i", R0t, T1[..., :3, 3] - T0[..., :3, 3])
    c = np.clip((np.trace(R, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    theta = np.arccos(c)
    small = theta < 1e-4
    sin = np.sin(theta)
    k = np.where(small, 0.5 + theta**2 / 12.0, theta / (2.0 * np.where(small, 1.0, sin)))
    w = k[..., None] * np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                                 R[..., 1, 0] - R[..., 0, 1]], axis=-1)
    # V(ω)⁻¹ = I − ½[ω]× + b·[ω]×², b = (1 − θ·sin θ / (2(1 − cos θ)))/θ² (1/12 + θ²/720 near 0)
    safe = np.where(small, 1.0, theta)
    b = np.where(small, 1.0 / 12.0 + theta**2 / 720.0,
                 (1.0 - safe * sin / (2.0 * np.where(small, 1.0, 1.0 - c))) / safe**2)
    wxp = np.cross(w, p)
    v = p - 0.5 * wxp + b[..., None] * np.cross(w, wxp)
    return np.concatenate([v, w], axis=-1)
