"""The IMU thrust law: its error is the trunk's tilt towards the fan (by geometry, against a numerical
rotation), its rate the gyro's, and the PID saturates and leaks as stated."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from jethr1_plan.control.imu_thrust import ImuGains, ImuThrust, tilt_error


def test_a_trunk_leaning_towards_the_fan_reads_a_positive_tilt_of_its_angle():
    # the fan to the +y side: a roll about −x leans the trunk's z axis towards +y by the angle
    for angle in (0.001, 0.02, 0.1):
        R = Rotation.from_rotvec([-angle, 0.0, 0.0]).as_matrix()
        e, _ = tilt_error(R, np.zeros(3), np.eye(3), np.array([0.0, 0.3]))
        assert e == pytest.approx(math.sin(angle), rel=1e-12) and e > 0
        e_away, _ = tilt_error(R, np.zeros(3), np.eye(3), np.array([0.0, -0.3]))
        assert e_away == pytest.approx(-e)
        # a turn about the vertical is no tilt; a tilt across the fan's direction is none either
        turned = R @ Rotation.from_rotvec([0.0, 0.0, 0.7]).as_matrix()  # the trunk turned about its own axis
        assert tilt_error(turned, np.zeros(3), np.eye(3), np.array([0.0, 0.3]))[0] == pytest.approx(e, rel=1e-12)
        assert tilt_error(R, np.zeros(3), np.eye(3), np.array([0.3, 0.0]))[0] == pytest.approx(0.0, abs=1e-15)
    # the planned attitude is the reference: leaning as planned is no error
    P = Rotation.from_rotvec([0.05, -0.02, 0.3]).as_matrix()
    assert tilt_error(P, np.zeros(3), P, np.array([0.2, 0.1]))[0] == pytest.approx(0.0, abs=1e-15)


def test_the_tilt_rate_is_the_derivative_of_the_tilt_under_the_gyros_rate():
    R = Rotation.from_rotvec([0.03, -0.05, 0.4]).as_matrix()
    w = np.array([0.3, -0.2, 0.5])  # body frame [rad/s]
    toward = np.array([0.25, -0.1])
    e0, de = tilt_error(R, w, np.eye(3), toward)
    h = 1e-7
    R1 = R @ Rotation.from_rotvec(w * h).as_matrix()  # a body-frame rate turns R on the right
    e1, _ = tilt_error(R1, w, np.eye(3), toward)
    assert de == pytest.approx((e1 - e0) / h, rel=1e-5)


def test_the_pid_adds_thrust_for_a_lean_saturates_and_leaks():
    g = ImuGains(rate_hz=100.0, kp_n_per_rad=300.0, ki_n_per_rad_s=200.0, kd_n_s_per_rad=10.0, leak_time_s=0.1)
    law = ImuThrust(g)
    assert law.step(0.01, 0.0, 5.0, 23.0) == pytest.approx(5.0 + 3.0 + 0.0)  # the integral starts at 0
    assert law.integral == pytest.approx(0.01 / 100.0)
    assert law.step(0.0, 0.5, 5.0, 23.0) == pytest.approx(5.0 + 200.0 * 1e-4 + 5.0)
    # saturated at the fans' top against a growing error: the integral stops
    law = ImuThrust(g)
    out = law.step(1.0, 0.0, 20.0, 23.0)
    assert out == 23.0 and law.integral == 0.0
    # below zero for a lean away, clipped at 0
    assert ImuThrust(g).step(-0.2, 0.0, 5.0, 23.0) == 0.0
    # double support: the integral leaks with the leak time
    law = ImuThrust(g)
    law.integral = 1.0
    for _ in range(10):
        law.idle()
    assert law.integral == pytest.approx((1 - 0.1) ** 10)
