"""The robot YAML checked as strictly as a scenario: every key known, every number finite and in a
range, key paths in full, the same one line through every command that loads a robot."""

from __future__ import annotations

import pytest
import yaml

from jethr1_plan.cli import run
from jethr1_plan.errors import RobotModelError
from jethr1_plan.robot.load import load_robot
from jethr1_plan.robot.model import ControllerSettings, ImuLawSettings, TwinSettings
from tests.conftest import ROOT
from tests.oracles.robot_copies import tampered_jethr1

CASES = {
    "an unknown key": (lambda d: d.update(colour="red"), "colour: unknown key"),
    "an unknown key in a fan": (lambda d: d["fans"][1].update(colour="red"), r"fans\[1\]\.colour: unknown key"),
    "NaN fan thrust": (lambda d: d["fans"][0].update(thrust_max_n=float("nan")),
                       r"fans\[0\]\.thrust_max_n: nan is not a finite number"),
    "a negative lag": (lambda d: d["fans"][0].update(lag_s=-0.1), r"fans\[0\]\.lag_s: -0\.1 is below the smallest"),
    "a zero sole length": (lambda d: d["sole"].update(length_m=0.0), r"sole\.length_m: 0\.0: must be more than 0"),
    "servo stiffness 0": (lambda d: d["servos"].update(stiffness_nm_per_rad=0),
                          r"servos\.stiffness_nm_per_rad: 0: must be more than 0"),
    "zero servos on a joint": (lambda d: d["servos"]["joints"]["knee"].update(servos=0),
                               r"servos\.joints\.knee\.servos: 0 is below the smallest"),
    "a servo table for no joint": (lambda d: d["servos"]["joints"].update(elbow={"servos": 1, "gear_ratio": 1.0}),
                                   r"servos\.joints\.elbow: neither a leg role"),
    "a controller rate of 0": (lambda d: d["controller"].update(rate_hz=0),
                               r"controller\.rate_hz: 0 is below the smallest allowed, 10$"),
    # a loop this slow had the twin step 1e9 times in one call that Ctrl-C could not stop
    "a controller rate of 1 µHz": (lambda d: d["controller"].update(rate_hz=1e-6),
                                   r"controller\.rate_hz: 1e-06 is below the smallest allowed, 10$"),
    "a twin step of 0.1 µs": (lambda d: d["twin"].update(timestep_s=1e-7),
                              r"twin\.timestep_s: 1e-07 is below the smallest allowed, 0\.0001$"),
    "a text gain": (lambda d: d["controller"].update(kp_n_per_m="high"), r"controller\.kp_n_per_m: expected number"),
    "an unknown twin setting": (lambda d: d["twin"].update(gravity=9.81), r"twin\.gravity: unknown key"),
    "a leg without its knee": (lambda d: d["legs"]["left"]["joints"].pop("knee"),
                               r"legs\.left\.joints\.knee: missing"),
    "a frame that does not exist": (lambda d: d["fans"][0].update(frame="nowhere"),
                                    r"fans\[0\]\.frame: frame 'nowhere' not in the URDF"),
    "a sole frame that does not exist": (lambda d: d["legs"]["right"].update(sole="nowhere"),
                                         r"legs\.right\.sole: frame 'nowhere' not in the URDF"),
    "a stance narrower than the soles": (lambda d: d.update(stance_width_m=0.05), "stance_width_m: 0.05 m: the soles"),
    "an unknown law": (lambda d: d["controller"].update(law="magic"), r"controller\.law: .*magic"),
    "the CoP law without sole sensors": (
        lambda d: d["controller"].update(law="cop_edge_pi"),
        r"controller\.law: cop_edge_pi reads the soles; sensors: declares encoders, imu"),
    "the IMU law without an IMU": (lambda d: d["sensors"].update(imu=None),
                                   r"controller\.law: imu_tilt_pid reads the imu; sensors: declares encoders"),
    "a negative IMU noise": (lambda d: d["sensors"]["imu"].update(attitude_noise_rad=-0.001),
                             r"sensors\.imu\.attitude_noise_rad: -0\.001 is below the smallest"),
    "an unknown encoder setting": (lambda d: d["sensors"]["encoders"].update(backlash_rad=0.01),
                                   r"sensors\.encoders\.backlash_rad: unknown key"),
    "an IMU on a frame that does not exist": (lambda d: d["sensors"]["imu"].update(frame="nowhere"),
                                              r"sensors\.imu\.frame: frame 'nowhere' not in the URDF"),
    "an IMU off the trunk": (lambda d: d["sensors"]["imu"].update(frame="left_foot"),
                             r"sensors\.imu\.frame: 'left_foot': the IMU is modelled on the trunk"),
}


@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
def test_a_bad_robot_yaml_is_one_line_naming_its_key(tmp_path, capsys, case):
    edit, words = CASES[case]
    path = tampered_jethr1(tmp_path / "bot", edit)
    assert run(["robot", "show", str(path)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert str(path) in err
    import re

    assert re.search(words, err), err


def test_a_key_given_twice_is_refused(tmp_path):
    path = tampered_jethr1(tmp_path / "bot")
    path.write_text(path.read_text().replace("trunk: trunk\n", "trunk: trunk\ntrunk: trunk\n"))
    with pytest.raises(RobotModelError, match="the key 'trunk' appears twice"):
        load_robot(path)


@pytest.mark.parametrize("command", ["plan", "reach", "walk", "balance-space"])
def test_every_command_says_the_same(tmp_path, capsys, command):
    """A bad robot is the same one line from every command that loads it (through a scenario or a
    walk file: under its key ``robot``), exit 2, nothing written."""
    path = tampered_jethr1(tmp_path / "bot", lambda d: d["fans"][0].update(thrust_max_n=-1.0))
    out = tmp_path / "out"
    if command in ("plan", "walk"):
        src = ROOT / "configs" / ("side_step.yaml" if command == "plan" else "walks/jethr1_walk.yaml")
        doc = yaml.safe_load(src.read_text())
        doc["robot"] = str(path)
        given = tmp_path / src.name
        given.write_text(yaml.safe_dump(doc))
        args = [command, str(given), "-o", str(out)]
    else:
        args = [command, "--robot", str(path)] + (["-o", str(out)] if command == "balance-space" else [])
    assert run(args) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and r"fans[0].thrust_max_n: -1.0 is below the smallest" in err
    assert not out.exists()


def test_controller_and_twin_are_typed():
    robot = load_robot("jethr1")
    doc = yaml.safe_load((ROOT / "robots" / "jethr1" / "jethr1.yaml").read_text())["controller"]
    assert robot.controller == ControllerSettings(rate_hz=500.0, band_margin_m=0.02, kp_n_per_m=600.0,
                                                  ki_n_per_m_s=3000.0, leak_time_s=0.3, law="imu_tilt_pid",
                                                  imu_tilt_pid=ImuLawSettings(**doc["imu_tilt_pid"]))
    assert robot.controller.given() == {"rate_hz": 500.0, "band_margin_m": 0.02, "kp_n_per_m": 600.0,
                                        "ki_n_per_m_s": 3000.0, "leak_time_s": 0.3}
    assert robot.twin == TwinSettings(sole_friction=0.8, sole_thickness_m=0.01)
    assert robot.twin.given() == {"sole_friction": 0.8, "sole_thickness_m": 0.01}
    assert load_robot("dyros_jet_like").controller.given() == {}


def test_sensors_are_typed_and_choose_the_law():
    """Jet-HR1 as published: a trunk IMU and encoders, no sole sensors, the IMU law; the variant with sensed
    soles runs the CoP law on the same URDF; a robot that declares none runs feed-forward only."""
    robot = load_robot("jethr1")
    doc = yaml.safe_load((ROOT / "robots" / "jethr1" / "jethr1.yaml").read_text())["sensors"]
    assert robot.sensors.names == ("imu", "encoders") and robot.feedback_law == "imu_tilt_pid"
    assert robot.sensors.imu.frame == robot.trunk
    assert robot.sensors.imu.attitude_bias_rad == doc["imu"]["attitude_bias_rad"]
    assert robot.sensors.encoders.resolution_rad == doc["encoders"]["resolution_rad"]
    assert robot.sensors.perception_error_m == doc["perception"]["landing_error_m"]
    ft = load_robot("jethr1_ft")
    assert ft.sensors.names == ("imu", "encoders", "soles") and ft.feedback_law == "cop_edge_pi"
    assert ft.urdf_path == robot.urdf_path and ft.mass_kg == robot.mass_kg
    assert load_robot("dyros_jet_like").feedback_law is None and load_robot("dyros_jet_like").sensors.names == ()
