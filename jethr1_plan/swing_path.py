"""Swing paths of the swing sole centre (Paper A, IV-B: "based on a circular curve").

A path is an array of sole positions (N, 3) [m]. The arc lies in the vertical plane through the
start and landing sole centres; its sagitta (height of the arc over the midpoint of the chord) is
the clearance. Terrain checks test the whole sole rectangle against every carton.

An arc may begin with a vertical lift and end with a vertical descent (``lift_m``, ``descent_m``):
the sole leaves its carton straight up and comes down on the next one straight down, the arc then
joining the top of the lift to the top of the descent. Why: a robot whose servos sag by more or
less than its commands assume (their stiffness known to ±25 %) holds its swing sole a few
millimetres too low or too high; on an arc's slanted end that height error becomes an error along
the step (the sole touches early or late), on a vertical descent it does not, and a sole that sags
at lift-off does not drag over the carton it leaves. Each vertical segment takes
:data:`VERTICAL_INTERVALS_PER` of the path's sample intervals (at least one); the swing's time law,
slow at both ends, spends about a fifth of the swing on each.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "VERTICAL_INTERVALS_PER",
    "Carton",
    "arc_path",
    "arc_paths",
    "collides",
    "first_collision",
    "interpolate_path",
    "path_length",
    "sole_on_carton",
    "vertical_intervals",
]


@dataclass(frozen=True)
class Carton:
    """An axis-aligned box: ``top_centre_m`` is the centre of its top face, ``size_m`` its extent."""

    top_centre_m: tuple[float, float, float]
    size_m: tuple[float, float, float] = (0.21, 0.11, 0.14)

    @property
    def top_z(self) -> float:
        return self.top_centre_m[2]

    def top_rectangle(self) -> tuple[float, float, float, float]:
        """(x_min, x_max, y_min, y_max) of the top face [m]."""
        x, y, _ = self.top_centre_m
        hx, hy = self.size_m[0] / 2, self.size_m[1] / 2
        return x - hx, x + hx, y - hy, y + hy


VERTICAL_INTERVALS_PER = 24  # a vertical segment takes one in this many of a path's sample intervals


def vertical_intervals(samples: int, lift_m: float, descent_m: float) -> tuple[int, int]:
    """The sample intervals of a path's vertical lift and descent (0 where there is none): each
    ``round((samples − 1) / VERTICAL_INTERVALS_PER)``, at least 1.

    Raises:
        ValueError: too few samples to leave the arc two of them.
    """
    each = max(1, round((samples - 1) / VERTICAL_INTERVALS_PER))
    lift, descent = (each if lift_m > 0 else 0), (each if descent_m > 0 else 0)
    if samples - lift - descent < 2:
        raise ValueError(f"{samples} samples leave the arc fewer than 2 beside its vertical lift and descent")
    return lift, descent


def _with_vertical_ends(arc, start: np.ndarray, end: np.ndarray, lift_m: float, descent_m: float,
                        samples: int) -> np.ndarray:
    """``arc(a, b, n)`` between the top of the lift over ``start`` and the top of the descent onto
    ``end`` (each (..., 3)), with the vertical segments before and after it: (..., samples, 3)."""
    n_lift, n_down = vertical_intervals(samples, lift_m, descent_m)
    up = np.array([0.0, 0.0, 1.0])
    a, b = start + lift_m * up, end + descent_m * up
    middle = arc(a, b, samples - n_lift - n_down)
    lift = start[..., None, :] + (np.arange(n_lift) / max(n_lift, 1))[:, None] * (lift_m * up)
    down = b[..., None, :] - (np.arange(1, n_down + 1) / max(n_down, 1))[:, None] * (descent_m * up)
    out = np.concatenate([np.broadcast_to(lift, (*middle.shape[:-2], n_lift, 3)), middle,
                          np.broadcast_to(down, (*middle.shape[:-2], n_down, 3))], axis=-2)
    out[..., 0, :] = start
    out[..., -1, :] = end
    return out


def arc_path(start_m: np.ndarray, end_m: np.ndarray, clearance_m: float = 0.05, samples: int = 25,
             lift_m: float = 0.0, descent_m: float = 0.0) -> np.ndarray:
    """Circular arc from ``start_m`` to ``end_m`` (3,) with sagitta ``clearance_m``, ``samples`` points.

    Points are equally spaced in arc angle; the first and last are exactly the end points. With
    zero clearance or coincident horizontal positions the path degenerates to the straight chord.
    With ``lift_m`` or ``descent_m`` [m] the arc runs between the top of a vertical lift over the
    start and the top of a vertical descent onto the end (:func:`vertical_intervals` of the samples
    each, equally spaced).
    """
    start, end = np.asarray(start_m, dtype=float), np.asarray(end_m, dtype=float)
    if samples < 2:
        raise ValueError("an arc needs at least 2 samples")
    if lift_m > 0 or descent_m > 0:
        return _with_vertical_ends(lambda a, b, n: arc_path(a, b, clearance_m, n), start, end, lift_m, descent_m,
                                   samples)
    chord = end - start
    c = float(np.linalg.norm(chord))
    t = np.linspace(0.0, 1.0, samples)
    if clearance_m <= 0 or c == 0:
        return start + t[:, None] * chord
    # unit vector along the chord and the "up" normal to it in the vertical plane through both ends
    u = chord / c
    horiz = np.array([chord[0], chord[1], 0.0])
    side = np.cross(horiz, [0.0, 0.0, 1.0]) if np.linalg.norm(horiz) > 1e-12 else np.array([0.0, 1.0, 0.0])
    n = np.cross(side, u)
    n /= np.linalg.norm(n)
    if n[2] < 0:
        n = -n
    h = clearance_m
    radius = (c * c / 4 + h * h) / (2 * h)
    half = np.arcsin(min(1.0, (c / 2) / radius))
    if h > radius:  # more than a half circle
        half = np.pi - half
    centre = start + chord / 2 + n * (h - radius)
    ang = np.linspace(-half, half, samples)
    pts = centre + radius * (np.sin(ang)[:, None] * u + np.cos(ang)[:, None] * n)
    pts[0], pts[-1] = start, end
    return pts


def arc_paths(start_m: np.ndarray, ends_m: np.ndarray, clearance_m: float = 0.05, samples: int = 25,
              lift_m: float = 0.0, descent_m: float = 0.0) -> np.ndarray:
    """:func:`arc_path` from one ``start_m`` (3,) to each of ``ends_m`` (K, 3) at once: (K, samples, 3) [m].

    The same arcs as :func:`arc_path` to rounding (numpy's vectorised sin and arcsin may differ from
    the scalar ones in the last bit); a path that must be exactly a scenario's comes from :func:`arc_path`.
    """
    start, ends = np.asarray(start_m, dtype=float), np.asarray(ends_m, dtype=float).reshape(-1, 3)
    if samples < 2:
        raise ValueError("an arc needs at least 2 samples")
    if lift_m > 0 or descent_m > 0:
        up = np.array([0.0, 0.0, 1.0])
        a, b = start + lift_m * up, ends + descent_m * up
        n_lift, n_down = vertical_intervals(samples, lift_m, descent_m)
        middle = arc_paths(a, b, clearance_m, samples - n_lift - n_down)
        lift = start + (np.arange(n_lift) / max(n_lift, 1))[:, None] * (lift_m * up)
        down = b[:, None, :] - (np.arange(1, n_down + 1) / max(n_down, 1))[:, None] * (descent_m * up)
        out = np.concatenate([np.broadcast_to(lift, (len(ends), n_lift, 3)), middle, down], axis=1)
        out[:, 0], out[:, -1] = start, ends
        return out
    chord = ends - start
    c = np.linalg.norm(chord, axis=1)
    t = np.linspace(0.0, 1.0, samples)
    out = start + t[None, :, None] * chord[:, None, :]
    arc = (c > 0) & (clearance_m > 0)
    if not arc.any():
        return out
    ch, cc = chord[arc], c[arc]
    u = ch / cc[:, None]
    horiz = np.column_stack([ch[:, 0], ch[:, 1], np.zeros(len(ch))])
    flat = np.linalg.norm(horiz, axis=1) <= 1e-12
    side = np.where(flat[:, None], [0.0, 1.0, 0.0], np.cross(horiz, [0.0, 0.0, 1.0]))
    n = np.cross(side, u)
    n /= np.linalg.norm(n, axis=1)[:, None]
    n[n[:, 2] < 0] *= -1
    h = clearance_m
    radius = (cc * cc / 4 + h * h) / (2 * h)
    half = np.arcsin(np.minimum(1.0, (cc / 2) / radius))
    half = np.where(h > radius, np.pi - half, half)
    centre = start + ch / 2 + n * (h - radius)[:, None]
    ang = np.linspace(-half, half, samples, axis=1)  # (K, samples)
    pts = centre[:, None, :] + radius[:, None, None] * (np.sin(ang)[..., None] * u[:, None, :]
                                                        + np.cos(ang)[..., None] * n[:, None, :])
    pts[:, 0], pts[:, -1] = start, ends[arc]
    out[arc] = pts
    return out


def path_length(points: np.ndarray) -> np.ndarray:
    """Cumulative length [m] along a polyline (N, 3), starting at 0."""
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    return np.concatenate([[0.0], np.cumsum(seg)])


def interpolate_path(points: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Positions at normalised arc length ``s`` ∈ [0, 1] along the polyline ``points`` (N, 3)."""
    cum = path_length(points)
    total = cum[-1]
    if total == 0:
        return np.repeat(points[:1], len(np.atleast_1d(s)), axis=0)
    target = np.clip(np.asarray(s, dtype=float), 0, 1) * total
    return np.stack([np.interp(target, cum, points[:, k]) for k in range(3)], axis=-1)


def sole_on_carton(centre_m: np.ndarray, yaw_rad: float, length_m: float, width_m: float, carton: Carton,
                   tol_m: float = 1e-9) -> bool:
    """True if the flat sole lies fully on the carton's top face (height within ``tol_m``)."""
    if abs(centre_m[2] - carton.top_z) > 1e-6:
        return False
    x0, x1, y0, y1 = carton.top_rectangle()
    corners = _sole_corners(centre_m, yaw_rad, length_m, width_m)
    return bool(np.all((corners[:, 0] >= x0 - tol_m) & (corners[:, 0] <= x1 + tol_m)
                       & (corners[:, 1] >= y0 - tol_m) & (corners[:, 1] <= y1 + tol_m)))


def _sole_corners(centre_m: np.ndarray, yaw_rad: float, length_m: float, width_m: float) -> np.ndarray:
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    local = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]]) * [length_m / 2, width_m / 2]
    return local @ np.array([[c, s], [-s, c]]) + np.asarray(centre_m)[:2]


def first_collision(points: np.ndarray, yaw_rad: float, length_m: float, width_m: float,
                    cartons: list[Carton], densify: int = 10) -> tuple[int, np.ndarray, int] | None:
    """First place where the sole, moved along the polyline, dips into a carton.

    The path is checked between its samples too (``densify`` points per segment). The sole is
    inside a carton when its rectangle overlaps the carton's top face (with positive area) and its
    height is below the top by more than 1e-9 m (and above the carton's bottom). Every point is
    tested against every carton at once (numpy); "first" is along the path, then in carton order.

    Returns:
        ``None`` if the path is clear, else (segment index, position [m], carton index).
    """
    pts = np.asarray(points, dtype=float)
    if len(pts) < 2 or not cartons:
        return None
    t = np.linspace(0.0, 1.0, densify, endpoint=False)
    p = (pts[:-1, None, :] + t[None, :, None] * (pts[1:] - pts[:-1])[:, None, :]).reshape(-1, 3)
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    local = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]]) * [length_m / 2, width_m / 2]
    corners = (local @ np.array([[c, s], [-s, c]]))[None] + p[:, None, :2]  # (P, 4, 2)
    sx0, sx1 = corners[..., 0].min(axis=1)[:, None], corners[..., 0].max(axis=1)[:, None]
    sy0, sy1 = corners[..., 1].min(axis=1)[:, None], corners[..., 1].max(axis=1)[:, None]
    rect = np.array([carton.top_rectangle() for carton in cartons])  # (C, 4): x0, x1, y0, y1
    top = np.array([carton.top_z for carton in cartons])
    bottom = np.array([carton.top_z - carton.size_m[2] for carton in cartons])
    overlap = ((np.minimum(sx1, rect[:, 1]) - np.maximum(sx0, rect[:, 0]) > 1e-9)
               & (np.minimum(sy1, rect[:, 3]) - np.maximum(sy0, rect[:, 2]) > 1e-9))
    z = p[:, 2:3]
    hit = overlap & (z < top - 1e-9) & (z > bottom)
    rows = np.flatnonzero(hit.any(axis=1))
    if not len(rows):
        return None
    j = int(rows[0])
    return j // densify, p[j], int(np.argmax(hit[j]))


def collides(paths: np.ndarray, length_m: float, width_m: float, cartons: list[Carton],
             densify: int = 10) -> np.ndarray:
    """(K,) whether each path of ``paths`` (K, N, 3) dips into a carton: :func:`first_collision` of
    each (a flat sole, yaw 0) at once."""
    paths = np.asarray(paths, dtype=float)
    k = len(paths)
    if paths.shape[1] < 2 or not cartons or not k:
        return np.zeros(k, dtype=bool)
    rect = np.array([carton.top_rectangle() for carton in cartons])  # (C, 4): x0, x1, y0, y1
    top = np.array([carton.top_z for carton in cartons])
    bottom = np.array([carton.top_z - carton.size_m[2] for carton in cartons])
    # each path's box (its densified points lie within it, to rounding) against each carton's, the sole's size
    # around: (K, C), those that cannot touch left out
    lo, hi = paths.min(axis=1) - 1e-9, paths.max(axis=1) + 1e-9
    near = ((rect[None, :, 1] > lo[:, None, 0] - length_m) & (rect[None, :, 0] < hi[:, None, 0] + length_m)
            & (rect[None, :, 3] > lo[:, None, 1] - width_m) & (rect[None, :, 2] < hi[:, None, 1] + width_m)
            & (top[None, :] > lo[:, None, 2]) & (bottom[None, :] < hi[:, None, 2]))
    hit = np.zeros(k, dtype=bool)
    rows = np.flatnonzero(near.any(axis=1))
    if not len(rows):
        return hit
    t = np.linspace(0.0, 1.0, densify, endpoint=False)
    some = paths[rows]
    p = (some[:, :-1, None, :] + t[None, None, :, None] * (some[:, 1:] - some[:, :-1])[:, :, None, :]).reshape(
        len(rows), -1, 3)
    for j in np.flatnonzero(near[rows].any(axis=0)):  # one carton at a time, over the paths that may touch it
        mine = np.flatnonzero(near[rows, j] & ~hit[rows])
        if not len(mine):
            continue
        q = p[mine]
        x, y, z = q[..., 0], q[..., 1], q[..., 2]
        over = ((np.minimum(x + length_m / 2, rect[j, 1]) - np.maximum(x - length_m / 2, rect[j, 0]) > 1e-9)
                & (np.minimum(y + width_m / 2, rect[j, 3]) - np.maximum(y - width_m / 2, rect[j, 2]) > 1e-9))
        hit[rows[mine]] = np.any(over & (z < top[j] - 1e-9) & (z > bottom[j]), axis=1)
    return hit
