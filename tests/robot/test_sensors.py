"""robot.sensors: what a robot YAML declares it measures, and the thrust law those sensors allow."""

from __future__ import annotations

import pytest

from jethr1_plan.errors import RobotModelError
from jethr1_plan.robot.load import load_robot
from jethr1_plan.robot.sensors import LAW_SENSORS, declared_sensors, sensor_names

FRAMES = {"trunk", "left_sole", "right_sole"}


def test_jethr1_declares_an_imu_and_encoders_and_runs_the_imu_law(robot) -> None:
    s = robot.sensors
    assert s.names == ("imu", "encoders") and s.soles is None
    assert s.imu is not None and s.imu.frame == robot.trunk
    assert robot.feedback_law == "imu_tilt_pid"
    assert set(LAW_SENSORS["imu_tilt_pid"]) <= set(s.names)
    assert s.describe()["perception"] == {"landing_error_m": s.perception_error_m}


def test_sole_force_sensors_give_the_cop_law() -> None:
    robot = load_robot("jethr1_ft")
    assert "soles" in robot.sensors.names
    law = robot.feedback_law
    assert law is not None and set(LAW_SENSORS[law]) <= set(robot.sensors.names)


def test_the_declaration_read_with_its_defaults() -> None:
    doc = {"sensors": {"imu": {"delay_s": 0.004}, "encoders": {"noise_rad": 0.001}, "soles": None}}
    assert sensor_names(doc) == ["imu", "encoders"]
    s = declared_sensors(doc, "trunk", FRAMES, "robot.yaml")
    assert s.imu is not None and s.imu.frame == "trunk" and s.imu.delay_s == 0.004 and s.imu.rate_noise_rad_s == 0.0
    assert s.encoders is not None and s.encoders.noise_rad == 0.001
    assert s.perception_error_m == 0.0
    assert declared_sensors({}, "trunk", FRAMES, "robot.yaml").names == ()


@pytest.mark.parametrize("frame, problem", [("left_sole", "modelled on the trunk"), ("nowhere", "not in the URDF")])
def test_an_imu_off_the_trunk_is_refused(frame, problem) -> None:
    with pytest.raises(RobotModelError, match=problem) as info:
        declared_sensors({"sensors": {"imu": {"frame": frame}}}, "trunk", FRAMES, "robot.yaml")
    assert "sensors.imu.frame" in str(info.value)
