"""The URDF checked before PlaCo parses it: one line naming the element for every problem, nothing
of the C++ parser on the terminal, and the same from every command."""

from __future__ import annotations

import os
import re

import pytest

from jethr1_plan.cli import run
from jethr1_plan.robot.urdf import check_urdf, quiet_stderr
from tests.conftest import ROOT
from tests.oracles.robot_copies import tampered_jethr1, urdf_attribute


def _swap_knee(urdf: str) -> str:
    lo = re.search(r'<joint name="left_knee".*?lower="([^"]+)"', urdf, re.S).group(1)
    hi = re.search(r'<joint name="left_knee".*?upper="([^"]+)"', urdf, re.S).group(1)
    urdf = urdf_attribute(urdf, "joint", "left_knee", "limit", "lower", hi)
    return urdf_attribute(urdf, "joint", "left_knee", "limit", "upper", lo)


CASES = {
    "knee limits swapped": (_swap_knee, r"joint left_knee limit: lower 2\.4 is not below upper 0 \(swapped\?\)"),
    "a NaN in an inertial origin": (lambda u: urdf_attribute(u, "link", "left_thigh", "origin", "xyz", "nan 0 0"),
                                    r"link left_thigh inertial origin: xyz='nan 0 0': not a finite number"),
    "a NaN in a joint origin": (lambda u: urdf_attribute(u, "joint", "right_knee", "origin", "xyz", "0 0 nan"),
                                r"joint right_knee origin: xyz='0 0 nan': not a finite number"),
    "a negative link mass": (lambda u: urdf_attribute(u, "link", "left_thigh", "mass", "value", "-0.5"),
                             r"link left_thigh inertial mass: -0\.5 kg: a mass is not negative"),
    "a zero trunk mass": (lambda u: urdf_attribute(u, "link", "trunk", "mass", "value", "0"),
                          r"link trunk inertial mass: 0 kg: a link with an <inertial> weighs between"),
    "a trunk of 1e-30 kg": (lambda u: urdf_attribute(u, "link", "trunk", "mass", "value", "1e-30"),
                            r"link trunk inertial mass: 1e-30 kg: a link with an <inertial> weighs between 1e-06"),
    "a shank of 1e30 kg": (lambda u: urdf_attribute(u, "link", "left_shank", "mass", "value", "1e30"),
                           r"link left_shank inertial mass: 1e\+30 kg: .* and 10000 kg"),
    "a shank of no inertia": (lambda u: urdf_attribute(urdf_attribute(urdf_attribute(
        u, "link", "left_shank", "inertia", "ixx", "0"), "link", "left_shank", "inertia", "iyy", "0"),
        "link", "left_shank", "inertia", "izz", "0"), r"link left_shank inertial inertia: .*positive definite"),
    "a continuous knee": (lambda u: u.replace('<joint name="left_knee" type="revolute">',
                                              '<joint name="left_knee" type="continuous">'),
                          r"joint left_knee: type 'continuous': jethr1's robot model takes revolute joints"),
    "an entity": (lambda u: u.replace("<robot", '<!DOCTYPE robot [<!ENTITY m "0.35">]>\n<robot', 1),
                  r"a document type or entity declaration"),
    "a mesh by URI": (lambda u: u.replace("<visual>", '<visual><geometry><mesh filename="package://x/m.stl"/>'
                                          "</geometry></visual><visual>", 1),
                      r"mesh: filename='package://x/m.stl': a URI"),
    "a missing mesh": (lambda u: u.replace("<visual>", '<visual><geometry><mesh filename="m.stl"/></geometry></visual>'
                                           "<visual>", 1), r"visual 0 mesh: m\.stl: no such file"),
    "an inertia no body has": (lambda u: urdf_attribute(u, "link", "left_thigh", "inertia", "izz", "0.01"),
                               r"link left_thigh inertial inertia: principal moments .* break the triangle"),
    "a negative moment": (lambda u: urdf_attribute(u, "link", "trunk", "inertia", "ixx", "-0.01"),
                          r"link trunk inertial inertia: not positive semi-definite"),
    "a zero effort": (lambda u: urdf_attribute(u, "joint", "left_hip_roll", "limit", "effort", "0"),
                      r"joint left_hip_roll limit: effort 0: a joint's effort limit is positive"),
    "a text number": (lambda u: urdf_attribute(u, "joint", "left_hip_roll", "limit", "lower", "low"),
                      r"joint left_hip_roll limit: lower='low': expected 1 numbers"),
    "a child of no joint": (lambda u: u.replace('<child link="left_hip_yaw_link"/>', '<child link="nowhere"/>'),
                            r"joint left_hip_yaw child: no link 'nowhere' in the URDF"),
    "two roots": (lambda u: u.replace("</robot>", '<link name="floating"/></robot>'),
                  r"expected one root link, found 2 \(trunk, floating\)"),
    "cut in half": (lambda u: u[: len(u) // 2], r"line \d+: not valid XML \(unclosed token"),
    "not a robot": (lambda u: "<xml/>", r"the root element is <xml>, expected <robot>"),
}


@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
def test_a_bad_urdf_is_one_line_and_no_parser_noise(tmp_path, capfd, case):
    edit, words = CASES[case]
    path = tampered_jethr1(tmp_path / "bot", urdf_edit=edit)
    assert run(["robot", "show", str(path)]) == 2
    out, err = capfd.readouterr()  # file descriptors: what C++ prints is caught here too
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err and out == "", err
    assert str(tmp_path / "bot" / "jethr1.urdf") in err
    assert re.search(words, err), err


def test_the_knee_limits_swapped_plan_and_reach_say_it_too(tmp_path, capfd):
    """Once a traceback (QPError) with an empty output folder left behind, and a TypeError."""
    path = tampered_jethr1(tmp_path / "bot", urdf_edit=_swap_knee)
    scenario = tmp_path / "side_step.yaml"
    scenario.write_text((ROOT / "configs" / "side_step.yaml").read_text().replace("robot: jethr1", f"robot: {path}"))
    for args in (["plan", str(scenario), "-o", str(tmp_path / "out")], ["reach", "--robot", str(path)]):
        assert run(args) == 2
        err = capfd.readouterr().err
        assert len(err.strip().splitlines()) == 1 and "left_knee limit: lower 2.4 is not below" in err
    assert not (tmp_path / "out").exists()


def test_the_shipped_robots_pass_and_their_masses_add_up():
    for name, kg in (("jethr1", 6.8), ("jethr1_trunk_fan", 7.082), ("dyros_jet_like", 50.358)):
        model = check_urdf(ROOT / "robots" / name / f"{name}.urdf")
        assert model.total_mass_kg == pytest.approx(kg, abs=1e-9)
        assert model.root in ("trunk", "base_link")


def test_what_c_code_prints_stays_off_the_terminal(capfd):
    with quiet_stderr() as said:
        os.write(2, b"Error: from the C++ parser\n at line 435\n")
    assert said == ["Error: from the C++ parser", " at line 435"]
    assert capfd.readouterr().err == ""
