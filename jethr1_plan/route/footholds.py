"""The footholds of a terrain: candidate sole centres on every carton top, a grid ``foothold_spacing_m`` apart,
symmetric about the top's centre, and the sole as far to each side as the margin lets it where the grid
stops short of that, every sole (flat, yaw 0) inside the top by ``edge_margin_m`` (by default the
robot's measured landing error); the start soles are footholds too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from jethr1_plan.geometry import SIDES
from jethr1_plan.route.terrain import Terrain
from jethr1_plan.swing_path import sole_on_carton

__all__ = ["Footholds", "footholds"]


@dataclass
class Footholds:
    """Candidate sole centres (F, 3) [m], the carton under each, and the start soles' indices."""

    xyz: np.ndarray
    carton: np.ndarray
    start: dict[str, int]
    edge_m: np.ndarray  # (F,) the sole's least distance to the edge of its carton's top [m]

    def __len__(self) -> int:
        return len(self.xyz)


def footholds(terrain: Terrain) -> Footholds:
    """The footholds of every carton top (rounded to 1 µm, each checked to lie on its top), then the start soles."""
    robot = terrain.robot
    L, W = robot.sole_length_m, robot.sole_width_m
    opt = terrain.options
    s = opt.foothold_spacing_m
    pts, owner = [], []
    for k, c in enumerate(terrain.cartons):
        cx, cy, cz = c.top_centre_m
        axes = []
        for size, sole in ((c.size_m[0], L), (c.size_m[1], W)):
            half = (size - sole) / 2 - opt.edge_margin_m
            n = math.floor(half / s + 1e-9) if half >= 0 else -1
            axis = np.arange(-n, n + 1) * s if n >= 0 else np.zeros(0)
            if n >= 0 and half - n * s > 1e-6:  # the sole as far to each side as the margin lets it
                axis = np.concatenate([[-half], axis, [half]])
            axes.append(axis)
        for dx in axes[0]:
            for dy in axes[1]:
                p = np.array([round(cx + dx, 6), round(cy + dy, 6), cz])
                if sole_on_carton(p, 0.0, L, W, c):
                    pts.append(p)
                    owner.append(k)
    start = {}
    for side in SIDES:
        p = np.asarray(terrain.base.start[side], dtype=float)
        same = [i for i, q in enumerate(pts) if np.allclose(q, p, atol=1e-9)]
        if same:
            start[side] = same[0]
            continue
        k = next(k for k, c in enumerate(terrain.cartons) if sole_on_carton(p, 0.0, L, W, c))
        start[side] = len(pts)
        pts.append(p.copy())
        owner.append(k)
    xyz = np.array(pts, dtype=float).reshape(-1, 3)
    owner_a = np.array(owner, dtype=np.int64)
    rect = np.array([terrain.cartons[k].top_rectangle() for k in owner_a]).reshape(-1, 4)
    edge = np.min(np.column_stack([xyz[:, 0] - L / 2 - rect[:, 0], rect[:, 1] - xyz[:, 0] - L / 2,
                                   xyz[:, 1] - W / 2 - rect[:, 2], rect[:, 3] - xyz[:, 1] - W / 2]), axis=1)
    return Footholds(xyz, owner_a, start, np.maximum(edge, 0.0))
