"""geometry: the trunk's pose difference and the rotation's quaternion, against pinocchio."""

from __future__ import annotations

import numpy as np


def test_pose_difference_is_pinocchios_log6():
    """log(T0⁻¹·T1) on SE(3), linear part first, batched (..., 4, 4): the twist that made T1 from T0
    (exp6) to 1e-12 for rotations from 1e-10 to 2 rad, and pinocchio's log6 to 5e-12 (both lose a
    little near 1e-3 rad, where V⁻¹'s coefficient cancels)."""
    import pinocchio as pin

    from jethr1_plan.geometry import pose_difference

    rng = np.random.default_rng(5)
    T0s, T1s, want, made = [], [], [], []
    for scale in 10.0 ** rng.uniform(-10, -0.5, 300):  # rotations below 2 rad
        M0 = pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(size=3))
        xi = np.concatenate([rng.normal(size=3), rng.normal(size=3) * scale])
        M1 = M0 * pin.exp6(xi)
        T0s.append(M0.homogeneous)
        T1s.append(M1.homogeneous)
        want.append(pin.log6(M0.inverse() * M1).vector)
        made.append(xi)
    got = pose_difference(np.array(T0s), np.array(T1s))
    assert np.max(np.abs(got - np.array(made))) < 1e-12
    assert np.max(np.abs(got - np.array(want))) < 5e-12


def test_quaternion_from_matrix_is_exact_for_small_rotations_too():
    """(x, y, z, w), w ≥ 0, within 1e-15 of pinocchio's for rotations from 1e-9 rad to π: the rows'
    second differences of a walk amplify its error by 1/Δt² (a square-root formula lost 1 % at 1e-7 rad)."""
    import pinocchio as pin

    from jethr1_plan.geometry import pose_from_quaternion, quaternion_from_matrix

    rng = np.random.default_rng(6)
    for angle in np.concatenate([10.0 ** rng.uniform(-9, 0, 300), rng.uniform(3.0, np.pi, 20)]):
        axis = rng.normal(size=3)
        R = pin.exp3(angle * axis / np.linalg.norm(axis))
        ref = pin.Quaternion(R).coeffs()
        ref = -ref if ref[3] < 0 else ref
        q = quaternion_from_matrix(R)
        assert np.max(np.abs(q - ref)) < 1e-15 and q[3] >= 0
        assert np.max(np.abs(pose_from_quaternion(np.zeros(3), q)[:3, :3] - R)) < 1e-15
