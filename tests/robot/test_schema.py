"""The robot YAML checked as strictly as a scenario: every key known, every number finite and in a
range, key paths in full, the same one line through every command that loads a robot."""

from __future__ import annotations

import pytest
import yaml

from jethr1_plan.cli import run
from jethr1_plan.errors import RobotModelError
from jethr1_plan.robot.model import ControllerSettings, TwinSettings, load_robot
from tests.conftest import ROOT
from tests.oracles.robot_copies import tampered_jethr1

CASES = {
    "an unknown key": (lambda d: d.update(colour="red"), "colour: unknown key"),
    "an unknown key in a fan": (lambda d: d["fans"][1].update(colour="red"), r"fans\[1\]\.colour: unknown key"),
    "NaN fan thrust": (lambda d: d["fans"][0].update(max_thrust_n=float("nan")),
                       r"fans\[0\]\.max_thrust_n: nan is not a finite number"),
    "a negative lag": (lambda d: d["fans"][0].update(lag_s=-0.1), r"fans\[0\]\.lag_s: -0\.1 is below the smallest"),
    "a zero sole length": (lambda d: d["sole"].update(length_m=0.0), r"sole\.length_m: 0\.0: must be more than 0"),
    "servo stiffness 0": (lambda d: d["servos"].update(stiffness_nm_per_rad=0),
                          r"servos\.stiffness_nm_per_rad: 0: must be more than 0"),
    "zero servos on a joint": (lambda d: d["servos"]["joints"]["knee"].update(servos=0),
                               r"servos\.joints\.knee\.servos: 0 is below the smallest"),
    "a servo table for no joint": (lambda d: d["servos"]["joints"].update(elbow={"servos": 1, "gear_ratio": 1.0}),
                                   r"servos\.joints\.elbow: neither a leg role"),
    "a controller rate of 0": (lambda d: d["controller"].update(rate_hz=0), r"controller\.rate_hz: 0: must be more"),
    "a text gain": (lambda d: d["controller"].update(kp_n_per_m="high"), r"controller\.kp_n_per_m: expected number"),
    "an unknown twin setting": (lambda d: d["twin"].update(gravity=9.81), r"twin\.gravity: unknown key"),
    "a leg without its knee": (lambda d: d["legs"]["left"]["joints"].pop("knee"),
                               r"legs\.left\.joints\.knee: missing"),
    "a frame that does not exist": (lambda d: d["fans"][0].update(frame="nowhere"),
                                    r"fans\[0\]\.frame: frame 'nowhere' not in the URDF"),
    "a sole frame that does not exist": (lambda d: d["legs"]["right"].update(sole="nowhere"),
                                         r"legs\.right\.sole: frame 'nowhere' not in the URDF"),
    "a stance narrower than the soles": (lambda d: d.update(stance_width_m=0.05), "stance_width_m: 0.05 m: the soles"),
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
    path = tampered_jethr1(tmp_path / "bot", lambda d: d["fans"][0].update(max_thrust_n=-1.0))
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
    assert len(err.strip().splitlines()) == 1 and r"fans[0].max_thrust_n: -1.0 is below the smallest" in err
    assert not out.exists()


def test_controller_and_twin_are_typed():
    robot = load_robot("jethr1")
    assert robot.controller == ControllerSettings(rate_hz=500.0, band_margin_m=0.02, kp_n_per_m=600.0,
                                                  ki_n_per_m_s=3000.0, leak_time_s=0.3)
    assert robot.twin == TwinSettings(sole_friction=0.8, sole_thickness_m=0.01)
    assert robot.twin.given() == {"sole_friction": 0.8, "sole_thickness_m": 0.01}
    assert load_robot("dyros_jet_like").controller.given() == {}
