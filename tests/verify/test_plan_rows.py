"""The verifier's batched statics against ``physics.statics`` solved one posture at a time."""

from __future__ import annotations

import numpy as np

from jethr1_plan.geometry import SIDES
from jethr1_plan.physics.statics import leg_condition_numbers, static_torques
from jethr1_plan.verify.plan_rows import batched_statics


def test_batched_statics_match_the_row_by_row_solution(robot):
    rng = np.random.default_rng(3)
    wrapper = robot.wrapper()
    supports = np.array(["left", "right", "both", "both", "right", "left", "nowhere"])
    m, nv, nf = len(supports), 6 + len(robot.joint_names), len(robot.fans)
    gravity, jac, fan_z = np.zeros((m, nv)), {s: np.zeros((m, 6, nv)) for s in SIDES}, np.zeros((m, nf, nv))
    thrust = rng.uniform(0.0, 15.0, (m, nf))
    thrust[1, 0] = 0.0
    feet = {s: np.zeros((m, 4, 4)) for s in SIDES}
    expected_tau, expected_kappa = np.full((m, len(robot.joint_names)), np.nan), np.zeros((m, 2))
    for i, sup in enumerate(supports):
        T = np.eye(4)
        c, s = np.cos(0.3 * i), np.sin(0.3 * i)
        T[:2, :2] = [[c, -s], [s, c]]
        T[:3, 3] = (0.01 * i, -0.02, 0.29)
        wrapper.set_T_world_fbase(T)
        q = np.clip(rng.normal(0.0, 0.3, len(robot.joint_names)), robot.lower_rad, robot.upper_rad)
        wrapper.state.q[7:] = q
        wrapper.update_kinematics()
        gravity[i] = wrapper.generalized_gravity()
        for side in SIDES:
            jac[side][i] = wrapper.frame_jacobian(robot.legs[side].sole, "local_world_aligned")
            feet[side][i] = wrapper.get_T_world_frame(robot.legs[side].sole)
        for k, fan in enumerate(robot.fans):
            fan_z[i, k] = wrapper.frame_jacobian(fan.frame, "local_world_aligned")[2]
        on = SIDES if sup == "both" else ((sup,) if sup in SIDES else ())
        if on:
            expected_tau[i], _ = static_torques(robot, wrapper, thrust[i], on)
        kappa = leg_condition_numbers(robot, wrapper)
        expected_kappa[i] = kappa["left"], kappa["right"]
    tau, kappa = batched_statics(robot, gravity, jac, fan_z, thrust, supports, feet)
    assert np.isnan(tau[-1]).all()  # no sole on the ground: no static torques
    np.testing.assert_allclose(tau[:-1], expected_tau[:-1], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(kappa, expected_kappa, rtol=1e-9)
    assert np.ptp(tau[:-1], axis=0).max() > 0.1  # the postures differ: the comparison is not of one row


def test_pair_hull_edges_are_qhulls_hull_of_both_soles():
    """The hull of two soles from its six edges in closed form (the Minkowski sum of a sole and the segment
    between the centres) is the polygon Qhull finds (``verify.balance.hull_edges``): every point's distance
    inside (negative outside) is the same, for soles apart in any direction, side by side, overlapping and at
    one place, shrunk or not."""
    from jethr1_plan.verify.balance import hull_edges, support_margin
    from jethr1_plan.verify.plan_geometry import pair_hull_edges

    rng = np.random.default_rng(40)
    n = 400
    a = rng.uniform(-0.5, 0.5, (n, 2))
    b = a + rng.uniform(-0.4, 0.4, (n, 2))
    b[:20] = a[:20]  # one place
    b[20:40, 1] = a[20:40, 1]  # one ahead of the other
    b[40:60, 0] = a[40:60, 0]  # side by side
    b[60:80] = a[60:80] + rng.uniform(-0.05, 0.05, (20, 2))  # overlapping
    length, width = 0.16, 0.09
    shrink = np.where(rng.random(n) < 0.5, 0.0, rng.uniform(0.0, 0.03, n))
    for i in range(n):
        normals, offsets = pair_hull_edges(a[i], b[i], length, width, shrink[i])
        assert np.allclose(np.linalg.norm(normals[0], axis=1), 1.0, rtol=0, atol=1e-15)
        qn, qb = hull_edges([a[i], b[i]], length, width, shrink[i])
        points = (a[i] + b[i]) / 2 + rng.uniform(-0.5, 0.5, (50, 2)) * (np.abs(b[i] - a[i]) + 0.2)
        mine = support_margin(points, np.broadcast_to(normals, (50, 6, 2)), np.broadcast_to(offsets, (50, 6)))
        qhull = support_margin(points, np.broadcast_to(qn, (50, *qn.shape)), np.broadcast_to(qb, (50, len(qb))))
        np.testing.assert_allclose(mine, qhull, rtol=0, atol=1e-12)
    both = pair_hull_edges(a, b, length, width, 0.01)  # every pair at once: the same as one by one
    for i in range(0, n, 37):
        one = pair_hull_edges(a[i], b[i], length, width, 0.01)
        assert np.array_equal(both[0][i], one[0][0]) and np.array_equal(both[1][i], one[1][0])


def test_distances_to_a_polyline_are_each_points_least_over_its_segments():
    """Every point's distance to a polyline at once is, for each point, the least distance to each segment
    (the foot of the perpendicular clipped to the segment), points beside, beyond both ends and on it."""
    from jethr1_plan.verify.plan_geometry import distance_to_polyline, distances_to_polyline

    rng = np.random.default_rng(40)
    pts = np.cumsum(rng.normal(0.0, 0.05, (15, 3)), axis=0)
    pts[7] = pts[6]  # a segment of no length
    points = np.concatenate([rng.normal(pts.mean(axis=0), 0.2, (200, 3)), pts[[0, 3, -1]],
                             pts[:1] - 0.3 * (pts[1] - pts[0]), (pts[4] + pts[5])[None] / 2])

    def each(p):
        best = np.inf
        for k in range(len(pts) - 1):
            a, ab = pts[k], pts[k + 1] - pts[k]
            t = 0.0 if ab @ ab == 0 else min(max((p - a) @ ab / (ab @ ab), 0.0), 1.0)
            best = min(best, float(np.linalg.norm(a + t * ab - p)))
        return best

    expected = np.array([each(p) for p in points])
    got = distances_to_polyline(points, pts)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-14)
    assert np.all(got[200:203] < 1e-15) and got[-1] < 1e-15  # on the polyline
    np.testing.assert_allclose(got[203], 0.3 * np.linalg.norm(pts[1] - pts[0]), rtol=1e-12)  # beyond its start
    assert distance_to_polyline(points[5], pts) == got[5]
