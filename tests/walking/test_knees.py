"""walking.knees: a knee's bend is the angle between thigh and shank (0 straight), by forward kinematics; the knee
limits narrowed so that a leg stays bent by a margin really keep it bent by that margin."""

from __future__ import annotations

import numpy as np
import pytest

from jethr1_plan.robot.load import load_robot
from jethr1_plan.walking.knees import knee_bend_rad, knee_limits_for_bend, leg_points, straight_knee_rad


def test_the_bend_is_the_angle_between_thigh_and_shank() -> None:
    hip, knee = np.zeros(3), np.array([0.0, 0.0, -0.2])
    assert np.isclose(knee_bend_rad(hip, knee, np.array([0.0, 0.0, -0.4])), 0.0)  # straight
    for angle in (0.1, 0.7, 1.5):
        ankle = knee + 0.2 * np.array([np.sin(angle), 0.0, -np.cos(angle)])
        assert np.isclose(knee_bend_rad(hip, knee, ankle), angle)
    many = knee_bend_rad(np.zeros((2, 3)), np.tile(knee, (2, 1)), np.array([[0.0, 0.0, -0.4], [0.2, 0.0, -0.2]]))
    assert np.allclose(many, [0.0, np.pi / 2])


@pytest.mark.parametrize("name", ["jethr1", "dyros_jet_like"])
def test_the_straight_knee_and_the_limits_that_keep_a_bend(name) -> None:
    robot = load_robot(name)
    w = robot.wrapper()
    for side in ("left", "right"):
        straight, sign = straight_knee_rad(robot, side)
        k = robot.legs[side].index[3]

        def bend(x: float, k: int = k, side: str = side) -> float:
            w.state.q[7:] = 0.0
            w.state.q[7 + k] = x
            w.update_kinematics()
            return float(knee_bend_rad(*leg_points(w, robot, side)))

        assert bend(straight) < 1e-6  # the leg is straight there
        lo, hi = knee_limits_for_bend(robot, side, 0.1)
        edge = lo if sign > 0 else hi
        assert np.isclose(bend(edge), 0.1, atol=1e-6) or edge in (robot.lower_rad[k], robot.upper_rad[k])
        inside = np.linspace(lo, hi, 25)
        assert min(bend(x) for x in inside) >= 0.1 - 1e-6
