"""``verify``'s motion of the rows, computed for every row at once (:mod:`jethr1_plan.verify.motion`), held
to its per-row formulas: :func:`twists` to :func:`twist` pose pair by pose pair, :func:`row_motion` to its
central differences of those twists, and :func:`vertical_ground_force` to the world's vertical force of
PlaCo's generalised forces moved out of the trunk's frame row by row (:func:`base_wrench`)."""

from __future__ import annotations

import numpy as np

from jethr1_plan.geometry import pose_from_quaternion
from jethr1_plan.verify.motion import base_wrench, row_motion, twist, twists, vertical_ground_force


def _unit(q: np.ndarray) -> np.ndarray:
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def _pose_pairs(rng: np.random.Generator, n: int) -> tuple[np.ndarray, ...]:
    """n pose pairs: a random first pose, the second turned about a random axis by angles from 0 (exactly) and
    below the series' 1e-4 rad to π/2, sometimes given as the opposite quaternion (w < 0 after the product)."""
    quat0 = _unit(rng.normal(size=(n, 4)))
    angle = np.concatenate([[0.0, 0.0, 1e-9, 3e-5, 9e-5, 1.1e-4], rng.uniform(0.0, np.pi / 2, n - 6)])
    axis = _unit(rng.normal(size=(n, 3)))
    turn = np.column_stack([axis * np.sin(angle / 2)[:, None], np.cos(angle / 2)])
    x0, y0, z0, w0 = quat0.T
    x1, y1, z1, w1 = turn.T  # quat1 = quat0 ⊗ turn
    quat1 = np.stack([w0 * x1 + x0 * w1 + y0 * z1 - z0 * y1, w0 * y1 - x0 * z1 + y0 * w1 + z0 * x1,
                      w0 * z1 + x0 * y1 - y0 * x1 + z0 * w1, w0 * w1 - x0 * x1 - y0 * y1 - z0 * z1], axis=1)
    quat1 *= rng.choice([-1.0, 1.0], size=(n, 1))
    p0 = rng.normal(0.0, 0.5, (n, 3))
    p1 = p0 + rng.normal(0.0, 0.05, (n, 3)) * rng.choice([0.0, 1.0], size=(n, 1), p=[0.1, 0.9])
    return quat0, p0, quat1, p1


def test_twists_are_the_per_pair_twist():
    rng = np.random.default_rng(40)
    quat0, p0, quat1, p1 = _pose_pairs(rng, 400)
    each = np.array([twist(*pair) for pair in zip(quat0, p0, quat1, p1, strict=True)])
    np.testing.assert_allclose(twists(quat0, p0, quat1, p1), each, rtol=0, atol=1e-14)
    assert np.abs(each[:, 3:]).max() > 1.0  # large turns are among them
    assert np.all(each[:2, 3:] == 0.0)  # and no turn at all


def test_twist_of_a_known_screw_motion():
    """A turn by θ about z with a move d along the turned x axis: ω = (0, 0, θ), and the linear part the
    logarithm's V⁻¹·d, V = [[sin θ/θ, −(1 − cos θ)/θ], [(1 − cos θ)/θ, sin θ/θ]] on the (x, y) plane."""
    theta, d = 0.7, np.array([0.3, -0.1, 0.05])
    quat1 = np.array([[0.0, 0.0, np.sin(theta / 2), np.cos(theta / 2)]])
    got = twists(np.array([[0.0, 0.0, 0.0, 1.0]]), np.zeros((1, 3)), quat1, d[None])[0]
    V = np.array([[np.sin(theta) / theta, -(1 - np.cos(theta)) / theta], [(1 - np.cos(theta)) / theta,
                                                                          np.sin(theta) / theta]])
    np.testing.assert_allclose(got[3:], [0.0, 0.0, theta], atol=1e-15)
    np.testing.assert_allclose(got[:2], np.linalg.solve(V, d[:2]), atol=1e-15)
    assert got[2] == d[2]


def _rows(rng: np.random.Generator, n: int, nj: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """n rows of a trunk moving smoothly (small yaw, roll and pitch) and nj joints."""
    t = np.arange(n) / n
    angle = np.stack([0.05 * np.sin(3 * t), 0.04 * np.cos(2 * t), 1.5 * t ** 2], axis=1)
    half = angle / 2
    # roll, pitch, yaw (R = Rz·Ry·Rx) as a quaternion (x, y, z, w)
    cr, sr, cp, sp, cy, sy = (np.cos(half[:, 0]), np.sin(half[:, 0]), np.cos(half[:, 1]), np.sin(half[:, 1]),
                              np.cos(half[:, 2]), np.sin(half[:, 2]))
    quat = np.stack([sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
                     cr * cp * cy + sr * sp * sy], axis=1)
    pos = np.column_stack([0.4 * t, 0.1 * np.sin(5 * t), 0.3 + 0.02 * np.cos(4 * t)]) + rng.normal(0, 1e-4, (n, 3))
    q = 0.3 * np.sin(np.outer(t, np.arange(1, nj + 1))) + rng.normal(0.0, 1e-3, (n, nj))
    return pos, quat, q


def test_row_motion_is_central_differences_of_each_rows_twist():
    rng = np.random.default_rng(41)
    pos, quat, q = _rows(rng, 60, 12)
    dt = 0.02
    D = np.zeros((61, 18))
    for k in range(1, 60):
        D[k] = np.concatenate([twist(quat[k - 1], pos[k - 1], quat[k], pos[k]), q[k] - q[k - 1]])
    v, a = row_motion(pos, quat, q, dt)
    np.testing.assert_allclose(v, (D[1:] + D[:-1]) / (2 * dt), rtol=0, atol=1e-12)
    np.testing.assert_allclose(a, (D[1:] - D[:-1]) / dt**2, rtol=0, atol=1e-9)
    assert np.all(v[[0, -1], :] == D[[1, -2]] / (2 * dt))  # the robot holds its posture beyond both ends


def test_vertical_ground_force_is_the_world_force_of_each_row(robot):
    rng = np.random.default_rng(42)
    n, nj = 40, len(robot.joint_names)
    pos, quat, q = _rows(rng, n, nj)
    thrust = rng.uniform(0.0, 20.0, (n, len(robot.fans)))
    dt = 0.02
    v, a = row_motion(pos, quat, q, dt)
    w = robot.wrapper()
    each = np.empty(n)
    for i in range(n):
        w.state.q[:3], w.state.q[3:7], w.state.q[7:] = pos[i], quat[i], q[i]
        w.state.qd, w.state.qdd = v[i], a[i]
        w.update_kinematics()
        force, _ = base_wrench(pose_from_quaternion(pos[i], quat[i]), w.mass_matrix() @ a[i] + w.non_linear_effects())
        each[i] = force[2] - thrust[i].sum()
    got = vertical_ground_force(robot, pos, quat, q, thrust, dt)
    np.testing.assert_allclose(got, each, rtol=0, atol=1e-9)
    assert np.ptp(got + thrust.sum(axis=1)) > 1.0  # the rows accelerate: not the weight alone
