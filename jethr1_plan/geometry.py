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
    """(x, y, z, w) of a rotation matrix (the inverse of :func:`pose_from_quaternion`'s rotation; w ≥ 0)."""
    w = np.sqrt(max(0.0, 1.0 + R[0, 0] + R[1, 1] + R[2, 2])) / 2.0
    x = np.copysign(np.sqrt(max(0.0, 1.0 + R[0, 0] - R[1, 1] - R[2, 2])) / 2.0, R[2, 1] - R[1, 2])
    y = np.copysign(np.sqrt(max(0.0, 1.0 - R[0, 0] + R[1, 1] - R[2, 2])) / 2.0, R[0, 2] - R[2, 0])
    z = np.copysign(np.sqrt(max(0.0, 1.0 - R[0, 0] - R[1, 1] + R[2, 2])) / 2.0, R[1, 0] - R[0, 1])
    return np.array([x, y, z, w])
