"""walking.pelvis_yaw: Paper B's reference pelvic rotation (B-30..B-32), as a yaw about +z: a left foot ahead and a
right foot behind turn the pelvis so that the left hip moves forward (a negative yaw)."""

from __future__ import annotations

import numpy as np

from jethr1_plan.walking.pelvis_yaw import reference_yaw


def test_feet_side_by_side_give_no_rotation() -> None:
    pelvis = np.zeros((3, 2))
    assert np.allclose(reference_yaw(pelvis, np.tile([0.0, 0.1], (3, 1)), np.tile([0.0, -0.1], (3, 1)), 0.4), 0.0)


def test_a_left_foot_ahead_turns_the_left_hip_forward() -> None:
    pelvis = np.zeros((1, 2))
    yaw = reference_yaw(pelvis, np.array([[0.15, 0.1]]), np.array([[-0.15, -0.1]]), 0.4)[0]
    # each foot's angle atan(k·dx/dy) = atan(0.4·1.5) about −z; their mean, negated about +z
    assert yaw < 0 and np.isclose(yaw, -np.arctan(0.6))
    mirrored = reference_yaw(pelvis, np.array([[-0.15, 0.1]]), np.array([[0.15, -0.1]]), 0.4)[0]
    assert np.isclose(mirrored, -yaw)


def test_the_rotation_grows_with_k_pel_and_is_the_mean_of_the_two_feet() -> None:
    pelvis = np.array([[0.05, 0.0]])
    left, right = np.array([[0.25, 0.12]]), np.array([[0.0, -0.1]])
    k = 0.3
    expect = -0.5 * (np.arctan(k * 0.20 / 0.12) + np.arctan(k * -0.05 / -0.1))
    assert np.isclose(reference_yaw(pelvis, left, right, k)[0], expect)
    assert abs(reference_yaw(pelvis, left, right, 0.6)[0]) > abs(expect)
    assert reference_yaw(pelvis, left, right, 0.0)[0] == 0.0
