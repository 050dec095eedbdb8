"""Robot variants (``robot.variant``): the folder a design writes loads through every robot check, and its mass,
centre of mass, fans and legs are what the design says, checked against sums over the base robot's own links."""

from __future__ import annotations

import numpy as np
import pytest

from jethr1_plan.errors import RobotModelError
from jethr1_plan.robot.load import ROBOTS_DIR, forget_robots, load_robot
from jethr1_plan.robot.variant import FanDesign, VariantDesign, fan_inertia, variant_files

BASE = ROBOTS_DIR / "jethr1" / "jethr1.yaml"
FAN_KG = 0.232  # Jet-HR1's fan (Table 1)


def jethr1_fans(thrust=23.0, mass=FAN_KG, fore=0.0, outboard=0.095) -> tuple[FanDesign, ...]:
    return (FanDesign("left", "left_foot", (fore, outboard, 0.035), thrust, mass),
            FanDesign("right", "right_foot", (fore, -outboard, 0.035), thrust, mass))


def written(tmp_path, design: VariantDesign, name: str = "v"):
    folder = tmp_path / name
    folder.mkdir()
    for fname, data in variant_files(BASE, design, name).items():
        (folder / fname).write_bytes(data)
    forget_robots()
    return load_robot(folder)


def com_at(robot, q: np.ndarray) -> np.ndarray:
    w = robot.wrapper()
    w.state.q[7:] = q
    w.update_kinematics()
    return np.asarray(w.com_world(), dtype=float)


def frame_at(robot, frame: str, q: np.ndarray) -> np.ndarray:
    w = robot.wrapper()
    w.state.q[7:] = q
    w.update_kinematics()
    return np.asarray(w.get_T_world_frame(frame)[:3, 3], dtype=float)


def postures(robot, n: int = 4) -> list[np.ndarray]:
    rng = np.random.default_rng(7)
    return [rng.uniform(robot.lower_rad, robot.upper_rad) for _ in range(n)]


def test_the_base_fans_as_a_design_give_the_base_robot(tmp_path):
    """Jet-HR1's own fans (23 N, 0.232 kg, 95 mm outboard, 35 mm up) as a design: the same mass, fans and CoM in
    any posture (to 1e-12 m), though the URDF is rewritten."""
    base = load_robot("jethr1")
    v = written(tmp_path, VariantDesign(jethr1_fans()))
    assert v.mass_kg == pytest.approx(base.mass_kg, abs=1e-12)
    assert [(f.name, f.mount, f.thrust_max_n) for f in v.fans] == [(f.name, f.mount, f.thrust_max_n) for f in base.fans]
    np.testing.assert_allclose([f.offset_m for f in v.fans], [f.offset_m for f in base.fans], atol=1e-12)
    assert (v.leg_length_m, v.thigh_m, v.hip_offset_m) == pytest.approx((base.leg_length_m, base.thigh_m,
                                                                         base.hip_offset_m), abs=1e-12)
    for q in postures(base):
        np.testing.assert_allclose(com_at(v, q), com_at(base, q), atol=1e-12)


def test_a_fan_s_mass_moves_the_com_as_a_point_mass_at_its_mount(tmp_path):
    """Heavier fans, mounted further forward and outboard: in any posture the CoM is the base's with each base fan's
    0.232 kg taken away at its frame and the new fan's mass added at its thrust point (moment balance of point
    masses; a fan's own inertia does not move the CoM)."""
    base = load_robot("jethr1")
    mass, fore, outboard = 0.41, 0.04, 0.12
    v = written(tmp_path, VariantDesign(jethr1_fans(40.0, mass, fore, outboard)))
    assert v.mass_kg == pytest.approx(base.mass_kg + 2 * (mass - FAN_KG), abs=1e-12)
    assert v.fans[0].offset_m == pytest.approx((fore, outboard, 0.035), abs=1e-12)
    assert v.fans[1].thrust_max_n == 40.0
    for q in postures(base):
        moment = base.mass_kg * com_at(base, q)
        for f_base, f_new in zip(base.fans, v.fans, strict=True):
            moment += mass * frame_at(v, f_new.frame, q) - FAN_KG * frame_at(base, f_base.frame, q)
        np.testing.assert_allclose(com_at(v, q), moment / v.mass_kg, atol=1e-12)


def test_a_trunk_fan_added_and_a_sole_fan_removed(tmp_path):
    """One sole fan and a fan on a boom beside the trunk: two fans, the trunk's mounted on the trunk, the robot
    heavier by the boom fan less the removed one."""
    base = load_robot("jethr1")
    fans = (jethr1_fans()[0], FanDesign("boom", "trunk", (0.0, 0.16, 0.0), 20.0, 0.282))
    v = written(tmp_path, VariantDesign(fans))
    assert [f.name for f in v.fans] == ["left", "boom"] and v.fans[1].on_trunk and v.fans[0].leg == "left"
    assert v.mass_kg == pytest.approx(base.mass_kg - FAN_KG + 0.282, abs=1e-12)
    assert v.fans_on("right") == ()


def test_trunk_mass_and_leg_length_scales(tmp_path):
    """Trunk × 1.5: the 2 kg trunk weighs 3 kg. Legs × 1.1: thigh and shank 0.209 m, the leg 0.08 + 1.1 × 0.38 m,
    hips and soles where they were; the thigh's and shank's masses unchanged."""
    base = load_robot("jethr1")
    v = written(tmp_path, VariantDesign(jethr1_fans(), trunk_mass_scale=1.5, leg_length_scale=1.1))
    assert v.mass_kg == pytest.approx(base.mass_kg + 1.0, abs=1e-12)
    assert (v.thigh_m, v.shank_m) == pytest.approx((0.209, 0.209), abs=1e-12)
    assert v.leg_length_m == pytest.approx(0.08 + 1.1 * 0.38, abs=1e-12)
    assert v.ankle_height_m == pytest.approx(base.ankle_height_m, abs=1e-12)
    assert v.hip_offset_m == pytest.approx(base.hip_offset_m, abs=1e-12)


def test_the_same_design_gives_the_same_bytes():
    d = VariantDesign(jethr1_fans(31.5, 0.318, 0.01, 0.1), 1.2, 0.95)
    assert variant_files(BASE, d, "x") == variant_files(BASE, d, "x")
    assert variant_files(BASE, d, "x") != variant_files(BASE, VariantDesign(jethr1_fans(31.5, 0.319)), "x")


def test_fan_inertia_is_a_solid_cylinder():
    """Ixx = Iyy = m(3r² + L²)/12 with L = 2r, Izz = m r²/2; the principal moments obey the triangle inequality."""
    ixx, iyy, izz = fan_inertia(0.3, 0.04)
    assert ixx == iyy == pytest.approx(0.3 * (3 * 0.04**2 + 0.08**2) / 12)
    assert izz == pytest.approx(0.3 * 0.04**2 / 2)
    assert izz <= ixx + iyy


def test_what_a_design_cannot_do(tmp_path):
    """A fan mounted on a frame that is neither a sole nor the trunk, two fans of one name, a fan without mass: one
    RobotModelError naming the key."""
    with pytest.raises(RobotModelError, match=r"fans\[0\]\.mount"):
        variant_files(BASE, VariantDesign((FanDesign("x", "left_thigh", (0, 0, 0), 10.0, 0.1),)), "v")
    twice = FanDesign("x", "trunk", (0, 0, 0), 10.0, 0.1)
    with pytest.raises(RobotModelError, match=r"fans\[1\]\.name"):
        variant_files(BASE, VariantDesign((twice, twice)), "v")
    with pytest.raises(RobotModelError, match=r"fans\[0\]\.mass"):
        variant_files(BASE, VariantDesign((FanDesign("x", "trunk", (0, 0, 0), 10.0, 0.0),)), "v")
