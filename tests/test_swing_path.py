"""Swing path geometry: the circular arc and carton clearance."""

from __future__ import annotations

import numpy as np
import pytest

from jethr1_plan.swing_path import Carton, arc_path, first_collision, interpolate_path, sole_on_carton


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
