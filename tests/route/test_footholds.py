"""route.footholds: candidate sole centres on every carton top, the sole inside its top by the edge margin, the
grid symmetric about the top's centre, the start soles among them."""

from __future__ import annotations

import numpy as np

from jethr1_plan.route.footholds import footholds
from jethr1_plan.route.terrain import load_terrain_text
from jethr1_plan.swing_path import sole_on_carton
from tests.conftest import SMALL_TERRAIN


def test_every_foothold_puts_the_sole_inside_its_carton_by_the_margin() -> None:
    terrain = load_terrain_text(SMALL_TERRAIN, "small.yaml")
    holds = footholds(terrain)
    robot, opt = terrain.robot, terrain.options
    L, W = robot.sole_length_m, robot.sole_width_m
    assert len(holds) == len(holds.xyz) == len(holds.carton) == len(holds.edge_m)
    for p, k, e in zip(holds.xyz, holds.carton, holds.edge_m, strict=True):
        c = terrain.cartons[k]
        assert sole_on_carton(p, 0.0, L, W, c)
        x0, x1, y0, y1 = c.top_rectangle()
        edge = min(p[0] - L / 2 - x0, x1 - p[0] - L / 2, p[1] - W / 2 - y0, y1 - p[1] - W / 2)
        assert e == max(edge, 0.0) or abs(e - edge) < 1e-12
        assert p[2] == c.top_z
    starts = set(holds.start.values())
    others = np.array([i not in starts for i in range(len(holds))])
    assert np.all(holds.edge_m[others] >= opt.edge_margin_m - 1e-6)  # (rounded to 1 µm)


def test_the_grid_is_symmetric_about_each_top_and_the_start_soles_are_footholds() -> None:
    terrain = load_terrain_text(SMALL_TERRAIN, "small.yaml")
    holds = footholds(terrain)
    for side, i in holds.start.items():
        assert np.allclose(holds.xyz[i], terrain.base.start[side])
    goal = terrain.names.index("goal")
    c = terrain.cartons[goal]
    pts = holds.xyz[holds.carton == goal, :2] - np.asarray(c.top_centre_m[:2])
    mirrored = pts * np.array([-1.0, 1.0])
    assert all(np.any(np.all(np.abs(pts - m) < 1e-6, axis=1)) for m in mirrored)
    # the goal's top is 0.4 m wide: more than one row of footholds across it, 2 cm apart
    assert len(np.unique(np.round(pts[:, 1], 6))) > 10
