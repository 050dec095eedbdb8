"""The footstep search on synthetic maps: the route it finds holds on the map step by step and is as cheap
as the exhaustive search's; blacklisted steps and transfers are not taken again; without a route the
frontier names the nearest carton not reached and why."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from jethr1_plan.geometry import other_side
from jethr1_plan.route.footholds import footholds
from jethr1_plan.route.search import astar, exhaustive
from jethr1_plan.route.steps import StepModel
from jethr1_plan.route.terrain import load_terrain_text, random_terrain
from jethr1_plan.swing_path import arc_path, first_collision, sole_on_carton
from tests.route.conftest import SOLE

ROW = """
name: row
robot: jethr1
start: {left: [0.0, 0.1125, 0.0], right: [0.0, -0.1125, 0.0]}
terrain:
  cartons:
    - {name: sl, top_centre_m: [0.0, 0.1125, 0.0]}
    - {name: sr, top_centre_m: [0.0, -0.1125, 0.0]}
    - {name: a, top_centre_m: [0.3, 0.1125, 0.0]}
    - {name: b, top_centre_m: [0.3, -0.1125, 0.0]}
    - {name: far, top_centre_m: [%s, 0.0, 0.0], size_m: [0.21, 0.4, 0.14]}
goal: {carton: far}
"""


def terrain_of(text: str):
    return load_terrain_text(text, "test.yaml")


def row(far_x: float = 0.6, **extra):
    doc = yaml.safe_load(ROW % far_x)
    doc.update(extra)
    return terrain_of(yaml.safe_dump(doc))


def test_footholds_lie_on_their_carton_tops_a_grid_apart(synthetic_maps):
    t = row()
    # a terrain that does not set the edge margin takes the robot's measured landing error
    assert t.options.edge_margin_m == t.robot.landing_error_m == 0.008
    h = footholds(t)
    for p, k in zip(h.xyz, h.carton, strict=True):
        assert sole_on_carton(p, 0.0, *SOLE, t.cartons[k])
    on_a = h.xyz[h.carton == 2]
    # a 0.21 x 0.11 top holds the 0.16 x 0.09 sole 8 mm inside its edges at x offsets within ±17 mm and y
    # offsets within ±2 mm: the grid (2 cm apart) has only the centre, and the sole goes as far as the margin
    # lets it to each side
    assert sorted(set(np.round(on_a[:, 0] - 0.3, 6))) == [-0.017, 0.0, 0.017]
    assert sorted(set(np.round(on_a[:, 1] - 0.1125, 6))) == [-0.002, 0.0, 0.002]
    room = np.minimum(0.025 - np.abs(on_a[:, 0] - 0.3), 0.01 - np.abs(on_a[:, 1] - 0.1125))
    assert np.allclose(h.edge_m[h.carton == 2], room) and room.min() == pytest.approx(0.008)
    assert np.allclose(h.xyz[h.start["left"]], [0.0, 0.1125, 0.0])
    five = footholds(row(route={"edge_margin_m": 0.005}))
    assert sorted(set(np.round(five.xyz[five.carton == 2][:, 0] - 0.3, 6))) == [-0.02, 0.0, 0.02]
    wide = footholds(row(route={"edge_margin_m": 0.0, "foothold_spacing_m": 0.025}))
    assert sorted(set(np.round(wide.xyz[wide.carton == 2][:, 0] - 0.3, 6))) == [-0.025, 0.0, 0.025]
    narrow = footholds(row(route={"edge_margin_m": 0.01}))
    assert sorted(set(np.round(narrow.xyz[narrow.carton == 2][:, 0] - 0.3, 6))) == [-0.015, 0.0, 0.015]


def test_every_step_of_the_route_holds_on_the_map(synthetic_maps):
    t = row()
    model = StepModel(t, footholds(t), synthetic_maps)
    found = astar(model)
    assert found.steps
    feet = {s: np.asarray(t.base.start[s], dtype=float) for s in ("left", "right")}
    last = None
    for st in found.steps:
        sup = other_side(st.swing)
        assert np.allclose(model.holds.xyz[st.frm], feet[st.swing])
        assert np.allclose(model.holds.xyz[st.support], feet[sup])
        land = model.holds.xyz[st.to]
        assert sole_on_carton(land, 0.0, *SOLE, t.cartons[model.holds.carton[st.to]])
        assert np.linalg.norm(land[:2] - feet[sup][:2]) >= SOLE[1]
        path = arc_path(feet[st.swing], land, st.edge.clearance_m, t.options.samples)
        ok, thrust, _, _, _ = synthetic_maps[sup].lookup(path - feet[sup])
        assert ok.all() and np.max(thrust) == pytest.approx(st.edge.peak_n)
        assert first_collision(path, 0.0, *SOLE, list(t.cartons)) is None
        left, right = (model.holds.xyz.tolist().index(feet["left"].tolist()),
                       model.holds.xyz.tolist().index(feet["right"].tolist()))
        assert model.transfer(left, right, last, st.swing)
        feet[st.swing], last = land, st.swing
    assert any(model.holds.carton[st.to] == 4 for st in found.steps[-1:])  # a sole on the goal carton
    assert found.cost == pytest.approx(sum(st.edge.cost for st in found.steps))
    assert found.cost >= len(found.steps) * t.options.cost.step


@pytest.mark.parametrize("seed", range(3))
def test_the_route_is_as_cheap_as_the_exhaustive_search(synthetic_maps, seed):
    """A* with its admissible heuristic against Dijkstra over every reachable stance: both find a route
    or neither does, at the same cost, and A* expands fewer stances. (Within 4 steps seeds 0 and 1 have a
    route of 4 steps, seed 2 none; the exhaustive search's time grows with the limit: 6 steps took 3× as long.)"""
    doc = yaml.safe_load(random_terrain(seed, cartons=3, gaps_m=(0.02, 0.12)))
    t = terrain_of(yaml.safe_dump({**doc, "limits": {"max_steps": 4}}))
    holds = footholds(t)
    a = astar(StepModel(t, holds, synthetic_maps))
    e = exhaustive(StepModel(t, holds, synthetic_maps))
    assert (a.steps is None) == (e.steps is None)
    if a.steps is not None:
        assert a.cost == pytest.approx(e.cost, rel=1e-12)
        assert a.expanded <= e.expanded


def test_a_blacklisted_step_or_transfer_is_not_taken_again(synthetic_maps):
    t = row()
    model = StepModel(t, footholds(t), synthetic_maps)
    first = astar(model)
    model.blacklist.add(first.steps[0].key)
    second = astar(model)
    assert second.steps[0].key != first.steps[0].key
    assert second.cost >= first.cost - 1e-12
    h = model.holds
    left, right = h.start["left"], h.start["right"]
    model.transfer_blacklist.add((left, right, None, second.steps[0].swing))
    third = astar(model)
    assert third.steps is None or third.steps[0].swing != second.steps[0].swing or third.steps[0].frm != \
        second.steps[0].frm


def test_no_route_names_the_frontier_the_nearest_carton_and_why(synthetic_maps):
    # 1.2 m beyond the start: no step of a 0.45 m map gets there (two steps reach every other carton; without the
    # limit the two searches of this test took 33 s, with it 5.5 s)
    far = row(far_x=1.3, limits={"max_steps": 2})
    found = astar(StepModel(far, footholds(far), synthetic_maps))
    assert found.steps is None
    f = found.frontier
    assert [far.names[k] for k in f.reached] == ["sl", "sr", "a", "b"]
    assert far.names[f.nearest] == "far" and f.why == "reach"
    assert "0.45" in f.detail or "reaches" in f.detail
    tight = row(far_x=0.75, limits={"peak_thrust_n": 2.0, "max_steps": 2})  # the goal needs more than 2 N of thrust
    found = astar(StepModel(tight, footholds(tight), synthetic_maps))
    assert found.steps is None and found.frontier.why == "thrust"
    assert found.frontier.detail.count("N") >= 2  # the thrust needed and the limit


def test_the_step_limit_holds(synthetic_maps):
    t = row()
    model = StepModel(t, footholds(t), synthetic_maps)
    found = astar(model)
    n = len(found.steps)
    capped = row(limits={"max_steps": n - 1})
    assert astar(StepModel(capped, footholds(capped), synthetic_maps)).steps is None
    assert exhaustive(StepModel(capped, footholds(capped), synthetic_maps)).steps is None
    enough = row(limits={"max_steps": n})
    every = exhaustive(StepModel(enough, footholds(enough), synthetic_maps))
    assert len(every.steps) == n and every.cost == pytest.approx(found.cost, rel=1e-12)
