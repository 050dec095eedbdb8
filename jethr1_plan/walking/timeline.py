"""Footsteps in time (Paper B, IV-A and IV-C): where each sole is, which soles support, the ZMP reference
and the support polygon at any instant.

A walk starts standing (both soles down), shifts onto the first support sole over ``start_s``, then
alternates single support (one swing, ``single_support_s``) and double support
(``double_support_s``), and ends standing after ``end_s``. The swing sole follows (B-21): a cubic
in time from the foothold it leaves to the one it lands on, zero velocity at both ends; its height
is a raised cosine of ``swing_height_m`` (B-21 moves between two footholds on the ground and gives
no clearance). The ZMP reference of (B-18) is the support sole's centre in single support and moves
linearly to the next support sole's centre in double support; its bounds are the support sole, or
the convex hull of both soles, shrunk by a margin.

Every function takes an array of times [s] and returns arrays (vectorised over the time axis).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jethr1_plan.geometry import SIDES, other_side

__all__ = [ "Footstep", "Timeline", "polygon_of", "repetitive_footsteps"]

@dataclass(frozen=True)
class Footstep:
    """One swing: the ``side`` foot leaves its foothold at ``t_lift`` and lands on ``position_m`` at ``t_land``."""

    side: str
    start_m: np.ndarray  # (3,) the foothold it leaves [m]
    position_m: np.ndarray  # (3,) the foothold it lands on [m]
    t_lift: float  # [s]
    t_land: float  # [s]


def repetitive_footsteps(start: dict[str, np.ndarray], step_length_m: float, steps: int, first: str
                         ) -> list[tuple[str, np.ndarray]]:
    """Footholds of a straight walk: each swing foot lands ``step_length_m`` ahead of the other one
    (the step length of Paper B: the distance between successive footholds), the last one beside it."""
    feet = {k: np.asarray(v, dtype=float).copy() for k, v in start.items()}
    out = []
    side = first
    for k in range(steps):
        other = other_side(side)
        x = feet[other][0] + (step_length_m if k < steps - 1 else 0.0)
        target = np.array([x, feet[side][1], feet[side][2]])
        out.append((side, target))
        feet[side] = target
        side = other
    return out


@dataclass(frozen=True)
class Timeline:
    """A walk's footsteps in time (SI units)."""

    start: dict[str, np.ndarray]  # both sole centres at t = 0 [m]
    steps: tuple[Footstep, ...]
    start_s: float
    single_support_s: float
    double_support_s: float
    end_s: float
    swing_height_m: float
    sole_length_m: float
    sole_width_m: float

    @classmethod
    def build(cls, start: dict[str, np.ndarray], footholds: list[tuple[str, np.ndarray]], start_s: float,
              single_support_s: float, double_support_s: float, end_s: float, swing_height_m: float,
              sole_length_m: float, sole_width_m: float) -> Timeline:
        """The timeline of ``footholds`` (side, landing sole centre) taken in order from ``start``."""
        feet = {k: np.asarray(v, dtype=float).copy() for k, v in start.items()}
        steps, t = [], start_s
        for side, target in footholds:
            steps.append(Footstep(side, feet[side].copy(), np.asarray(target, dtype=float), t, t + single_support_s))
            feet[side] = np.asarray(target, dtype=float)
            t += single_support_s + double_support_s
        return cls({k: np.asarray(v, dtype=float) for k, v in start.items()}, tuple(steps), start_s,
                   single_support_s, double_support_s, end_s, swing_height_m, sole_length_m, sole_width_m)

    @property
    def duration_s(self) -> float:
        """From standing to standing [s]."""
        return (self.steps[-1].t_land + self.end_s) if self.steps else self.start_s + self.end_s

    def footholds(self) -> dict[str, list[np.ndarray]]:
        """Every foothold of each foot, in order (the start included)."""
        out = {s: [self.start[s]] for s in SIDES}
        for st in self.steps:
            out[st.side].append(st.position_m)
        return out

    def feet(self, t: np.ndarray) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """Both soles' centres (N, 3) [m] at times ``t`` (N,), and where each is in the air (N,)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        pos, air = {}, {}
        for s in SIDES:
            mine = [st for st in self.steps if st.side == s]
            holds = np.array([self.start[s], *[st.position_m for st in mine]])
            if not mine:
                pos[s] = np.broadcast_to(self.start[s], (len(t), 3)).copy()
                air[s] = np.zeros(len(t), dtype=bool)
                continue
            lift = np.array([st.t_lift for st in mine])
            land = np.array([st.t_land for st in mine])
            landed = np.searchsorted(land, t, side="right")  # steps of this foot already landed
            p = holds[landed].copy()
            k = np.minimum(landed, len(mine) - 1)
            during = (landed < len(mine)) & (t > lift[k]) & (t < land[k])
            if during.any():
                kk = k[during]
                u = (t[during] - lift[kk]) / (land[kk] - lift[kk])
                h = 3 * u * u - 2 * u ** 3  # (B-21): cubic, zero velocity at both footholds
                q = holds[kk] + h[:, None] * (holds[kk + 1] - holds[kk])
                q[:, 2] += self.swing_height_m * 0.5 * (1 - np.cos(2 * np.pi * u))
                p[during] = q
            pos[s], air[s] = p, during
        return pos, air

    def phase(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per time: the support ('left', 'right' or 'both') and the index of the step under way
        (the next one in double support; len(steps) at the end)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        support = np.full(len(t), "both", dtype=object)
        step = np.full(len(t), len(self.steps), dtype=np.int64)
        for k in range(len(self.steps) - 1, -1, -1):
            st = self.steps[k]
            step[t < st.t_land] = k
            swing = (t > st.t_lift) & (t < st.t_land)
            support[swing] = other_side(st.side)
        return support, step

    def _centres(self) -> list[np.ndarray]:
        """The ZMP reference's waypoints: the stance's midpoint, each support sole's centre, the final midpoint."""
        feet = {k: v.copy() for k, v in self.start.items()}
        out = [0.5 * (feet["left"] + feet["right"])]
        for st in self.steps:
            out.append(feet[other_side(st.side)].copy())
            feet[st.side] = st.position_m
        out.append(0.5 * (feet["left"] + feet["right"]))
        return out

    def zmp_reference(self, t: np.ndarray) -> np.ndarray:
        """(N, 2) the ZMP reference of (B-18) [m]: each support sole's centre in its single support,
        moving linearly between them in double support (from and to the stance's midpoint at the ends)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        c = self._centres()
        knots, corners = [0.0], [c[0][:2]]
        for k, st in enumerate(self.steps):
            knots += [st.t_lift, st.t_land]
            corners += [c[k + 1][:2], c[k + 1][:2]]
        knots.append(self.duration_s)
        corners.append(c[-1][:2])
        times, points = np.array(knots), np.array(corners)
        return np.column_stack([np.interp(t, times, points[:, 0]), np.interp(t, times, points[:, 1])])

    def support_keys(self, t: np.ndarray) -> list[tuple]:
        """What fixes the support polygon at each time: the soles on the ground and where."""
        pos, air = self.feet(t)
        xy = {s: np.round(pos[s][:, :2], 9) for s in SIDES}
        return [tuple((s, float(xy[s][i, 0]), float(xy[s][i, 1])) for s in SIDES if not air[s][i])
                for i in range(len(xy["left"]))]

    def support_key(self, t: float) -> tuple:
        """What fixes the support polygon at time ``t``."""
        return self.support_keys(np.array([t]))[0]

    def support_polygon(self, t: float, margin_m: float = 0.0) -> np.ndarray:
        """(K, 2) the support polygon at time ``t``, counter-clockwise, shrunk by ``margin_m`` [m]."""
        return polygon_of(self.support_key(t), self.sole_length_m, self.sole_width_m, margin_m)


def polygon_of(key: tuple, sole_length_m: float, sole_width_m: float, margin_m: float) -> np.ndarray:
    """The convex hull (K, 2) [m], counter-clockwise, of the soles in ``key`` (``Timeline.support_key``),
    each a rectangle facing +x shrunk by ``margin_m``."""
    from scipy.spatial import ConvexHull

    hl, hw = sole_length_m / 2 - margin_m, sole_width_m / 2 - margin_m
    corners = np.array([[hl, -hw], [hl, hw], [-hl, hw], [-hl, -hw]])
    pts = np.vstack([np.array([x, y]) + corners for _, x, y in key])
    if len(key) == 1:
        return pts
    return pts[ConvexHull(pts).vertices]


