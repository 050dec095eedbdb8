"""Swing path geometry: the circular arc and carton clearance."""

from __future__ import annotations

import numpy as np
import pytest

from jethr1_plan.swing_path import (
    Carton,
    arc_path,
    arc_paths,
    collides,
    first_collision,
    interpolate_path,
    sole_on_carton,
    vertical_intervals,
)


@pytest.mark.parametrize("end", [(0.6, 0.0, 0.0), (0.3, 0.4, 0.0), (0.0, 0.35, 0.05), (0.45, -0.2, -0.03)])
def test_arc_is_a_circle_through_both_ends_in_a_vertical_plane(end):
    start, end = np.array([0.0, 0.1, 0.0]), np.array(end)
    pts = arc_path(start, end, 0.06, 41)
    np.testing.assert_array_equal(pts[0], start)
    np.testing.assert_array_equal(pts[-1], end)
    # vertical plane through both ends: horizontal offsets are collinear with the chord
    h = end[:2] - start[:2]
    cross = h[0] * (pts[:, 1] - start[1]) - h[1] * (pts[:, 0] - start[0])
    np.testing.assert_allclose(cross, 0.0, atol=1e-12)
    # all points equidistant from one centre (a circle), equally spaced
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    np.testing.assert_allclose(seg, seg[0], rtol=1e-9)
    # sagitta: the midpoint is 'clearance' above the chord's midpoint, along the in-plane normal
    mid = pts[20]
    chord_mid = (start + end) / 2
    assert np.linalg.norm(mid - chord_mid) == pytest.approx(0.06, rel=1e-9)
    assert mid[2] > chord_mid[2]


def test_zero_clearance_is_the_straight_chord():
    pts = arc_path(np.zeros(3), np.array([0.5, 0.0, 0.0]), 0.0, 11)
    np.testing.assert_allclose(pts[:, 0], np.linspace(0, 0.5, 11))
    assert np.all(pts[:, 2] == 0)


def test_interpolate_path_by_length():
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0]], dtype=float)
    np.testing.assert_allclose(interpolate_path(pts, np.array([0.25, 0.75])), [[0.5, 0, 0], [1, 0.5, 0]])


def test_sole_on_carton():
    c = Carton((0.0, 0.0, 0.0))
    assert sole_on_carton(np.array([0.025, 0.01, 0.0]), 0.0, 0.16, 0.09, c)
    assert not sole_on_carton(np.array([0.03, 0.0, 0.0]), 0.0, 0.16, 0.09, c)  # toe 5 mm over the edge
    assert not sole_on_carton(np.array([0.0, 0.0, 0.01]), 0.0, 0.16, 0.09, c)  # hovering


def test_collision_with_a_carton_edge_is_found_and_clearance_fixes_it():
    cartons = [Carton((0.0, 0.0, 0.0)), Carton((0.3, 0.0, 0.05), (0.21, 0.11, 0.19)), Carton((0.6, 0.0, 0.0))]
    low = arc_path(np.array([0.0, 0.0, 0.0]), np.array([0.6, 0.0, 0.0]), 0.02, 30)
    hit = first_collision(low, 0.0, 0.16, 0.09, cartons)
    assert hit is not None and hit[2] == 1
    high = arc_path(np.array([0.0, 0.0, 0.0]), np.array([0.6, 0.0, 0.0]), 0.12, 30)
    assert first_collision(high, 0.0, 0.16, 0.09, cartons) is None


def _first_collision_loop(points, yaw, length, width, cartons, densify=10):
    """The oracle: every point between samples against every carton, one at a time (the definition)."""
    c, s = np.cos(yaw), np.sin(yaw)
    local = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]]) * [length / 2, width / 2]
    for i in range(len(points) - 1):
        for t in np.linspace(0.0, 1.0, densify, endpoint=False):
            p = points[i] + t * (points[i + 1] - points[i])
            corners = local @ np.array([[c, s], [-s, c]]) + p[:2]
            for k, carton in enumerate(cartons):
                x0, x1, y0, y1 = carton.top_rectangle()
                overlap = (min(corners[:, 0].max(), x1) - max(corners[:, 0].min(), x0) > 1e-9) and \
                          (min(corners[:, 1].max(), y1) - max(corners[:, 1].min(), y0) > 1e-9)
                if overlap and carton.top_z - carton.size_m[2] < p[2] < carton.top_z - 1e-9:
                    return i, p, k
    return None


def test_the_vectorised_collision_checks_agree_with_the_definition():
    """first_collision (every point at once) and collides (every path at once) find what the loop finds,
    on arcs low and high over random cartons, at yaw 0 and turned."""
    rng = np.random.default_rng(3)
    found = 0
    for trial in range(60):
        cartons = [Carton((float(rng.uniform(0, 0.8)), float(rng.uniform(-0.3, 0.3)), float(rng.uniform(-0.05, 0.1))),
                          (0.21, 0.11, 0.2)) for _ in range(4)]
        start = np.array([0.0, 0.0, 0.0])
        ends = np.column_stack([rng.uniform(0.2, 0.9, 5), rng.uniform(-0.3, 0.3, 5), rng.uniform(-0.05, 0.1, 5)])
        clearance = float(rng.choice([0.02, 0.06, 0.15]))
        paths = np.array([arc_path(start, e, clearance, 20) for e in ends])
        yaw = 0.0 if trial % 2 else 0.3
        for p in paths:
            want, got = _first_collision_loop(p, yaw, 0.16, 0.09, cartons), first_collision(p, yaw, 0.16, 0.09, cartons)
            assert (want is None) == (got is None)
            if want is not None:
                found += 1
                assert (want[0], want[2]) == (got[0], got[2])
                np.testing.assert_array_equal(want[1], got[1])
        expect = [_first_collision_loop(p, 0.0, 0.16, 0.09, cartons) is not None for p in paths]
        assert collides(paths, 0.16, 0.09, cartons).tolist() == expect
    assert found > 20  # the cases include collisions


def test_arc_paths_are_the_arcs_of_arc_path():
    rng = np.random.default_rng(0)
    start = np.array([0.0, 0.1, 0.0])
    ends = np.vstack([start, start + np.array([0, 0, 0.1]), rng.uniform(-0.5, 0.5, (50, 3))])
    for clearance in (0.0, 0.05, 0.3):
        np.testing.assert_allclose(arc_paths(start, ends, clearance, 25),
                                   np.array([arc_path(start, e, clearance, 25) for e in ends]), atol=1e-14)


def test_an_arc_with_a_vertical_lift_and_descent():
    """The sole leaves straight up by lift_m and comes down straight down from descent_m over the landing:
    a height error on the way down moves the touchdown along the vertical, not along the step."""
    start, end = np.array([0.0, 0.1, 0.0]), np.array([0.3, 0.05, -0.02])
    pts = arc_path(start, end, 0.08, 25, lift_m=0.02, descent_m=0.03)
    n_lift, n_down = vertical_intervals(25, 0.02, 0.03)
    assert (n_lift, n_down) == (1, 1) and len(pts) == 25
    np.testing.assert_array_equal(pts[0], start)
    np.testing.assert_array_equal(pts[-1], end)
    np.testing.assert_allclose(pts[n_lift], start + np.array([0.0, 0.0, 0.02]), atol=1e-15)
    np.testing.assert_allclose(pts[-1 - n_down], end + np.array([0.0, 0.0, 0.03]), atol=1e-15)
    # the arc between them: its sagitta over the raised chord
    a, b = pts[n_lift], pts[-1 - n_down]
    np.testing.assert_allclose(pts[n_lift:len(pts) - n_down], arc_path(a, b, 0.08, 25 - n_lift - n_down), atol=1e-15)
    # the vectorised paths are the same
    many = arc_paths(start, np.array([end, end + np.array([0.02, 0.0, 0.0])]), 0.08, 25, 0.02, 0.03)
    np.testing.assert_allclose(many[0], pts, atol=1e-14)
    assert vertical_intervals(49, 0.02, 0.0) == (2, 0)
    with pytest.raises(ValueError, match="fewer than 2"):
        arc_path(start, end, 0.08, 3, lift_m=0.02, descent_m=0.02)
