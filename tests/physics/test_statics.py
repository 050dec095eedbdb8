"""Static torques, κ, energy and yaw momentum, against independent computations."""

from __future__ import annotations

import numpy as np
import pytest

from jethr1_plan.geometry import GRAVITY
from jethr1_plan.physics.statics import energy_consumption, leg_condition_numbers, static_torques
from tests.conftest import JOINT_NAMES
from tests.oracles.leg import link_poses


def _potential(robot, reference, q, support, support_pose, thrust_side, thrust):
    """Gravity minus thrust potential [J] with the support sole held at ``support_pose`` (numpy FK)."""
    poses = reference.link_poses(np.zeros(3), 0.0, dict(zip(JOINT_NAMES, q, strict=True)))
    T_fix = support_pose @ np.linalg.inv(poses[f"{support}_foot"])
    v = 0.0
    for name, (m, c) in reference.links.items():
        T = T_fix @ poses[name]
        v += m * GRAVITY * (T[:3, :3] @ c + T[:3, 3])[2]
    if thrust:
        v -= thrust * (T_fix @ poses[f"{thrust_side}_fan"])[2, 3]
    return v


def _posture(robot, rng):
    q = rng.uniform(robot.lower_rad * 0.6, robot.upper_rad * 0.6)
    q[[3, 9]] = rng.uniform(0.3, 1.5, 2)  # bent knees
    return q


def _robot_at(robot, q):
    """A PlaCo robot with its trunk at the origin and joints ``q``, kinematics updated."""
    wrapper = robot.wrapper()
    wrapper.set_T_world_fbase(np.eye(4))
    wrapper.state.q[7:] = q
    wrapper.update_kinematics()
    return wrapper


def test_single_support_torques_equal_the_virtual_work(robot, reference):
    """τ_j = ∂V/∂q_j with the support sole fixed, V = Σ m g z − F z_fan (central differences)."""
    rng = np.random.default_rng(2)
    wrapper = robot.wrapper()
    for _ in range(6):
        q = _posture(robot, rng)
        yaw = rng.uniform(-1, 1)
        T = np.eye(4)
        T[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
        T[:3, 3] = rng.uniform(-0.1, 0.1, 3)
        wrapper.set_T_world_fbase(T)
        wrapper.state.q[7:] = q
        wrapper.update_kinematics()
        support = "right"
        thrust = rng.uniform(0, 20)
        tau, _ = static_torques(robot, wrapper, np.array([thrust, 0.0]), (support,))
        pose = wrapper.get_T_world_frame(f"{support}_foot")
        h = 1e-6
        for j in range(12):
            dq = np.zeros(12)
            dq[j] = h
            dv = (_potential(robot, reference, q + dq, support, pose, "left", thrust)
                  - _potential(robot, reference, q - dq, support, pose, "left", thrust)) / (2 * h)
            assert tau[j] == pytest.approx(dv, abs=1e-6)


def test_support_wrench_balances_weight_and_thrust(robot):
    wrapper = _robot_at(robot, _posture(robot, np.random.default_rng(3)))
    for supports in (("right",), ("left", "right")):
        _, w = static_torques(robot, wrapper, np.array([12.0, 0.0]), supports)
        fz = w.reshape(-1, 6)[:, 2].sum()
        assert fz == pytest.approx(robot.mass_kg * GRAVITY - 12.0, abs=1e-9)


def test_kappa_from_an_independent_jacobian(robot):
    """κ of each leg from a finite-difference Jacobian of the numpy FK (relative sole twist)."""
    q = _posture(robot, np.random.default_rng(4))
    wrapper = _robot_at(robot, q)
    kappa = leg_condition_numbers(robot, wrapper)
    h = 1e-7
    for k, side in enumerate(("left", "right")):
        def sole(qq, side=side):
            R, p = link_poses(robot, np.zeros(3), 0.0, qq[None])[f"{side}_foot"]
            return R[:, :, 0], p[:, 0]
        R0, p0 = sole(q)
        J = np.zeros((6, 6))
        for j in range(6):
            dq = np.zeros(12)
            dq[6 * k + j] = h
            R1, p1 = sole(q + dq)
            W = (R1 @ R0.T - np.eye(3)) / h  # ≈ skew(ω), ω in the world frame
            J[:3, j] = (p1 - p0) / h
            J[3:, j] = [W[2, 1], W[0, 2], W[1, 0]]
        s = np.linalg.svd(J, compute_uv=False)
        assert kappa[side] == pytest.approx(s[0] / s[-1], rel=1e-4)


def test_energy_counts_only_positive_power():
    t = np.arange(0, 1.0001, 0.01)
    q = np.stack([np.sin(2 * np.pi * t)] + [np.zeros_like(t)] * 11, axis=1)
    tau = np.zeros_like(q)
    tau[:, 0] = 2.0  # constant torque on a joint that goes up then down
    e = energy_consumption(tau, q, 0.01)
    # ∫ max(2·q̇, 0) dt = 2 × (total rise of sin over one period) = 2 × 2
    assert e == pytest.approx(4.0, rel=2e-3)


def _two_soles(p_left, p_right):
    """The floating-base rows A (6, 12) of two sole wrenches [f; m] at ``p_left``, ``p_right``: the
    resultant force and its moment about the origin, Σ (f_s, m_s + p_s × f_s)."""
    def block(p):
        x, y, z = p
        skew = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
        return np.block([[np.eye(3), np.zeros((3, 3))], [skew, np.eye(3)]])
    return np.hstack([block(p_left), block(p_right)])


def test_load_split_gives_the_whole_load_to_the_sole_under_the_zmp(robot):
    """A vertical load W at the ZMP: a ZMP inside one sole puts all the weight there (the other's weight 0,
    so a transfer's ends equal the single supports beside them), halfway between the soles half each, and
    the weight moves over monotonically as the ZMP crosses the gap."""
    from jethr1_plan.physics.statics import load_split

    left, right = np.array([0.0, 0.1, 0.0]), np.array([0.3, -0.1, -0.03])
    a = _two_soles(left, right)
    weight = robot.mass_kg * GRAVITY

    def beta(zmp):
        b = np.array([0.0, 0.0, weight, weight * zmp[1], -weight * zmp[0], 0.0])
        return load_split(a, b, [left, right], [0.0, 0.0], robot.sole_length_m, robot.sole_width_m)

    np.testing.assert_allclose(beta(left[:2] + np.array([0.02, -0.01])), [1.0, 0.0])
    np.testing.assert_allclose(beta(right[:2]), [0.0, 1.0])
    np.testing.assert_allclose(beta(0.5 * (left[:2] + right[:2])), [0.5, 0.5], atol=1e-12)
    path = [beta(left[:2] + s * (right[:2] - left[:2]))[1] for s in np.linspace(0.0, 1.0, 41)]
    assert np.all(np.diff(path) >= -1e-12) and path[0] == 0.0 and path[-1] == 1.0


def test_double_support_wrench_balances_and_is_the_single_support_one_at_a_sole(robot):
    """Both soles down with the ZMP (the CoM, without thrust) inside the right sole: the split still
    balances the weight (A w = b), the left sole carries nothing, and the torques are those of the right
    support alone."""
    from jethr1_plan.kinematics.closed_form import solve_postures

    feet = {"left": (np.array([0.0, 0.09, 0.0]), 0.0), "right": (np.array([0.12, -0.09, -0.02]), 0.0)}
    target = feet["right"][0][:2] + np.array([0.0, 0.03])  # inside the right sole, 15 mm from its inner edge
    p = np.array([[0.06, 0.0, 0.33]])
    for _ in range(20):  # P_body moved until the CoM stands over the target
        q, com, status = solve_postures(robot, p, np.zeros(1), feet)
        assert status[0] == 0
        p[0, :2] += target - com[0, :2]
    q, com, _ = solve_postures(robot, p, np.zeros(1), feet)
    assert np.linalg.norm(com[0, :2] - target) < 0.002
    wrapper = robot.wrapper()
    T = np.eye(4)
    T[:3, 3] = p[0]
    wrapper.set_T_world_fbase(T)
    wrapper.state.q[7:] = q[0]
    wrapper.update_kinematics()
    none = np.zeros(len(robot.fans))
    tau2, w2 = static_torques(robot, wrapper, none, ("left", "right"))
    tau1, _ = static_torques(robot, wrapper, none, ("right",))
    assert w2.reshape(2, 6)[:, 2].sum() == pytest.approx(robot.mass_kg * GRAVITY, abs=1e-9)
    np.testing.assert_allclose(w2[:6], 0.0, atol=1e-9)
    np.testing.assert_allclose(tau2, tau1, atol=1e-9)


def test_condition_numbers_of_many_matrices_are_each_ones(robot):
    """κ of a stack of matrices at once is, to the bit, σ_max/σ_min of each matrix's own SVD (inf where
    singular), and analyse_rows' κ of every row is that of each leg's Jacobian at that row's posture."""
    from jethr1_plan.physics.statics import analyse_rows, condition_numbers

    rng = np.random.default_rng(40)
    J = rng.normal(size=(30, 2, 6, 6))
    J[3, 1] = 0.0  # a singular one (σ_min exactly 0)
    each = np.empty((30, 2))
    for i in range(30):
        for k in range(2):
            s = np.linalg.svd(J[i, k], compute_uv=False)
            each[i, k] = float(s[0] / s[-1]) if s[-1] > 0 else float("inf")
    got = condition_numbers(J)
    assert np.array_equal(got, each)
    assert got[3, 1] == np.inf and np.all(np.isfinite(np.delete(got.ravel(), 7)))

    n = 12
    q = np.array([_posture(robot, rng) for _ in range(n)])
    p = rng.normal([0.0, 0.0, 0.4], 0.02, (n, 3))
    yaw = rng.uniform(-0.3, 0.3, n)
    a = analyse_rows(robot, p, yaw, q, np.zeros((n, 2)), np.array(["left", "right", "both"] * 4), 0.02)
    wrapper = robot.wrapper()
    for i in range(n):
        T = np.eye(4)
        T[:2, :2] = [[np.cos(yaw[i]), -np.sin(yaw[i])], [np.sin(yaw[i]), np.cos(yaw[i])]]
        T[:3, 3] = p[i]
        wrapper.set_T_world_fbase(T)
        wrapper.state.q[7:] = q[i]
        wrapper.update_kinematics()
        for k, side in enumerate(("left", "right")):
            leg = robot.legs[side]
            s = np.linalg.svd(wrapper.frame_jacobian(leg.sole, "local_world_aligned")[:, 6 + np.asarray(leg.index)],
                              compute_uv=False)
            assert a["kappa"][i, k] == float(s[0] / s[-1])
