"""The Jet-HR1 model against Paper A's Table 1 and an independent URDF computation."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from jethr1_plan.cli import run
from jethr1_plan.robot.load import load_robot
from jethr1_plan.robot.summary import robot_summary
from tests.conftest import JOINT_NAMES, ROOT


def test_table1_figures_from_the_loaded_model(robot):
    s = robot_summary(robot)
    assert s["mass_kg"] == pytest.approx(6.8, abs=0.01)
    assert s["height_m"] == pytest.approx(0.608, abs=0.005)
    assert s["leg_length_m"] == pytest.approx(0.460, abs=0.003)
    assert [j["name"] for j in s["joints"]] == list(JOINT_NAMES)
    assert [(f["frame"], f["thrust_max_n"]) for f in s["fans"]] == [("left_fan", 23.0), ("right_fan", 23.0)]


def test_fans_sit_outboard_of_their_feet(robot):
    left, right = robot.fan_for("left").offset_m, robot.fan_for("right").offset_m
    assert left[1] > robot.sole_width_m / 2 and right[1] < -robot.sole_width_m / 2


def test_effort_limits_match_the_servo_table(robot):
    # 7.8 N·m per B3M1117; two servos on pitch joints and knees, one on hip yaw, 1:2.43 on rolls
    expect = {"hip_yaw": 7.8, "hip_roll": 7.8 * 2.43, "hip_pitch": 15.6, "knee": 15.6, "ankle_pitch": 15.6,
              "ankle_roll": 7.8 * 2.43}
    for name, effort, servo in zip(robot.joint_names, robot.effort_nm, robot.servo_limit_nm, strict=True):
        assert effort == pytest.approx(expect[name.split("_", 1)[1]])
        assert servo == pytest.approx(effort)


def test_mirrored_roll_limits(robot):
    i, j = JOINT_NAMES.index("left_hip_roll"), JOINT_NAMES.index("right_hip_roll")
    assert robot.lower_rad[i] == -robot.upper_rad[j] and robot.upper_rad[i] == -robot.lower_rad[j]


def test_hip_yaw_allows_a_quarter_turn_of_the_trunk(robot):
    i = JOINT_NAMES.index("left_hip_yaw")
    assert robot.upper_rad[i] > np.pi / 2 * 0.95 and robot.lower_rad[i] < -np.pi / 2 * 0.95


def test_com_matches_an_independent_sum_over_urdf_links(robot, reference):
    wrapper = robot.wrapper()
    rng = np.random.default_rng(3)
    for _ in range(20):
        q = rng.uniform(robot.lower_rad, robot.upper_rad)
        p, yaw = rng.uniform(-0.2, 0.2, 3), rng.uniform(-np.pi, np.pi)
        T = np.eye(4)
        T[:3, :3] = [[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]]
        T[:3, 3] = p
        wrapper.set_T_world_fbase(T)
        wrapper.state.q[7:] = q
        wrapper.update_kinematics()
        mass, com = reference.com(p, yaw, dict(zip(JOINT_NAMES, q, strict=True)))
        assert mass == pytest.approx(robot.mass_kg)
        np.testing.assert_allclose(wrapper.com_world(), com, atol=1e-12)


@pytest.mark.parametrize("name", ["jethr1", "dyros_jet_like"])
def test_urdf_is_in_step_with_its_generator(name):
    out = subprocess.run([sys.executable, "-c", "import build_urdf, sys; sys.stdout.write(build_urdf.build())"],
                         cwd=ROOT / "robots" / name, capture_output=True, text=True, check=True)
    assert out.stdout == (ROOT / "robots" / name / f"{name}.urdf").read_text()


def test_robot_show_json(capsys):
    assert run(["robot", "show", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["mass_kg"] == pytest.approx(6.8, abs=0.01)
    assert len(doc["joints"]) == 12 and {"name", "lower_rad", "upper_rad", "effort_nm"} <= set(doc["joints"][0])
    assert doc["sole"] == {"length_m": 0.16, "width_m": 0.09}


def test_unknown_robot_is_exit_2(capsys):
    assert run(["robot", "show", "nosuchbot"]) == 2
    err = capsys.readouterr().err
    assert "nosuchbot" in err and len(err.strip().splitlines()) == 1


def test_a_robot_yaml_missing_a_key_is_rejected(tmp_path):
    src = (ROOT / "robots" / "jethr1" / "jethr1.yaml").read_text().replace("stall_torque_nm: 7.8", "")
    d = tmp_path / "bad"
    d.mkdir()
    (d / "bad.yaml").write_text(src.replace("urdf: jethr1.urdf", f"urdf: {ROOT / 'robots/jethr1/jethr1.urdf'}"))
    from jethr1_plan.errors import RobotModelError

    with pytest.raises(RobotModelError, match=r"servos\.stall_torque_nm"):
        load_robot(str(d))


def test_a_robot_named_and_the_same_robot_by_its_yaml_path_are_loaded_once():
    from jethr1_plan.robot.load import ROBOTS_DIR, load_robot

    by_name = load_robot("jethr1")
    assert load_robot(ROBOTS_DIR / "jethr1" / "jethr1.yaml") is by_name  # (a plan folder names its robot so)
    assert load_robot(str(ROBOTS_DIR / "jethr1")) is by_name
