"""robot.load: a robot found by name, folder or YAML, loaded once, its servo figures computed from the YAML's table
(never copied), and its fans placed from the URDF."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
import yaml

from jethr1_plan.errors import RobotModelError
from jethr1_plan.robot.load import ROBOTS_DIR, forget_robots, load_robot
from jethr1_plan.robot.schema import LEG_ROLES


def test_servo_stiffness_and_damping_follow_the_gears(robot) -> None:
    """Per joint: stiffness × servos × gear² (the servo's stiffness reflected through its gearbox), damping ×
    the derivative time."""
    doc = yaml.safe_load((ROBOTS_DIR / "jethr1" / "jethr1.yaml").read_text())
    servos = doc["servos"]
    for side, leg in robot.legs.items():
        for role, i in zip(LEG_ROLES, leg.index, strict=True):
            entry = servos["joints"][role]
            k = servos["stiffness_nm_per_rad"] * entry["servos"] * entry["gear_ratio"] ** 2
            assert robot.servo_stiffness_nm_per_rad[i] == pytest.approx(k), (side, role)
            assert robot.servo_damping_nms_per_rad[i] == pytest.approx(k * servos["derivative_time_s"])


def test_each_fan_sits_where_the_urdf_puts_it_on_its_mount(robot) -> None:
    w = robot.wrapper()
    w.state.q[7:] = 0.0
    w.set_T_world_fbase(np.eye(4))
    w.update_kinematics()
    for fan in robot.fans:
        T_mount, T_fan = w.get_T_world_frame(fan.mount), w.get_T_world_frame(fan.frame)
        assert np.allclose(T_mount[:3, :3].T @ (T_fan[:3, 3] - T_mount[:3, 3]), fan.offset_m, atol=1e-12)


def test_a_forgotten_robot_is_read_afresh(tmp_path) -> None:
    folder = tmp_path / "copy"
    shutil.copytree(ROBOTS_DIR / "jethr1", folder)
    (folder / "jethr1.yaml").rename(folder / "copy.yaml")
    first = load_robot(folder)
    assert load_robot(folder / "copy.yaml") is first
    text = (folder / "copy.yaml").read_text().replace("stall_torque_nm: 7.8", "stall_torque_nm: 9.0")
    (folder / "copy.yaml").write_text(text)
    assert load_robot(folder) is first  # cached by its path
    forget_robots()
    again = load_robot(folder)
    assert again is not first
    assert np.allclose(again.servo_limit_nm / first.servo_limit_nm, 9.0 / 7.8)


@pytest.mark.parametrize("name, problem", [("", "empty"), ("no_such_robot", "unknown robot"),
                                           ("/no/such/robot", r"^/no/such/robot: no such file or folder"),
                                           ("gone.yaml", r"^gone\.yaml: no such file or folder"),
                                           ("/dev/null", r"^/dev/null: not a robot: expected a folder")])
def test_a_robot_that_is_not_there_is_named(name, problem) -> None:
    with pytest.raises(RobotModelError, match=problem):
        load_robot(name)


def test_a_folder_of_two_robot_yamls_is_ambiguous(tmp_path) -> None:
    (tmp_path / "a.yaml").write_text("{}")
    (tmp_path / "b.yaml").write_text("{}")
    with pytest.raises(RobotModelError, match="exactly one robot YAML"):
        load_robot(tmp_path)
