"""The walk's analysis and judge (issue 26): the strictest stencil against pinocchio, a one-row
excursion and a one-period knee reversal caught, κ without a column that hides the straight leg, the
knee bend by geometry, the soles' friction."""

from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np
import pytest

from tests.conftest import ROOT
from tests.oracles.walk_audit import audit_rows

DYROS_WALK = ROOT / "configs" / "walks" / "dyros_walk.yaml"


def audit_of(walk, spec):
    """The pinocchio audit of a walk's rows (its trunk's rotations as quaternions by pinocchio)."""
    import pinocchio as pin

    quat = np.array([pin.Quaternion(T[:3, :3]).coeffs() for T in walk.base])  # x, y, z, w
    joints = {name: walk.q[:, k] for k, name in enumerate(walk.robot.joint_names)}
    return audit_rows(walk.robot.yaml_path, walk.t, list(walk.support), walk.base[:, :3, 3], quat, joints,
                      1.0 / spec.timing.control_hz, spec.ik.max_joint_acceleration_rad_s2,
                      spec.success.knee_margin_rad)


@pytest.fixture(scope="module")
def straight_walk():
    """A clean walk: Dyros-Jet-like, 0.30 m steps without pelvic rotation, arms held."""
    from jethr1_plan.walking.analysis import analyse
    from jethr1_plan.walking.result import generate_walk
    from jethr1_plan.walking.spec import load_walk

    spec = load_walk(DYROS_WALK).varied(step_length_m=0.30, mode="none", arms=False)
    walk = generate_walk(spec)
    return spec, walk, analyse(walk)


def test_clean_walk_agrees_with_pinocchio_row_by_row(straight_walk):
    """Velocity, acceleration, ground wrench, ZMP, friction ratio, torques, each leg's κ and knee bend
    of every judged row against pinocchio's difference, RNEA and frame Jacobians on the same rows."""
    spec, walk, a = straight_walk
    o = audit_of(walk, spec)
    inner = slice(1, -1)
    assert np.max(np.abs(a.joint_acceleration[inner] - o.qdd[inner])) < 1e-6
    assert np.max(np.linalg.norm(a.zmp[inner] - o.zmp[inner], axis=1)) < 1e-9
    assert np.max(np.abs(a.friction_ratio[inner] - o.friction_ratio[inner])) < 1e-9
    assert np.max(np.abs(np.abs(a.tau[inner]) / walk.robot.effort_nm - o.torque_ratio[inner])) < 1e-9
    assert np.max(np.abs(a.kappa_leg / o.kappa_leg - 1)) < 1e-9
    assert np.max(np.abs(a.knee_bend_rad - o.knee_bend)) < 1e-12
    assert o.clean and a.least_zmp_margin_m > 0.05


def test_one_row_zmp_excursion_is_caught(straight_walk):
    """One single-support row's trunk 0.1 mm forward (the whole robot, feet included): its second
    central difference is a −2 m/s² jolt (the ZMP about 160 mm forward, beyond the toe); the
    analysis's ZMP follows pinocchio's within 1 mm on the three rows it touches, leaves the support
    at that row and fails the walk there."""
    from jethr1_plan.walking.analysis import analyse, judge

    spec, walk, clean = straight_walk
    w = copy.deepcopy(walk)
    rows = np.flatnonzero((w.t > 5.0) & (w.support == "left"))[:40]
    k = int(rows[np.argmax(clean.zmp[rows, 0] - w.feet_target["left"][rows, 0])])  # the ZMP the most forward
    w.base[k, 0, 3] += 1e-4
    for s in ("left", "right"):
        w.feet[s][k, 0, 3] += 1e-4
    a = analyse(w)
    o = audit_of(w, spec)
    rows = slice(k - 1, k + 2)
    assert np.max(np.linalg.norm(a.zmp[rows] - o.zmp[rows], axis=1)) < 1e-3
    assert a.zmp_margin[k] < 0 and o.zmp_margin[k] < 0
    verdict = judge(w, a, spec.success)
    assert not verdict.ok and verdict.time_s == pytest.approx(w.t[k], abs=1e-9) and "ZMP" in verdict.reason


def test_knee_reversal_within_one_period_is_caught(straight_walk):
    """A swing knee that runs down at 3 rad/s and turns back within one period (a 600 rad/s² corner,
    the snap of issue 26) fails the walk on its acceleration, named, at the corner."""
    from jethr1_plan.walking.analysis import analyse, judge

    spec, walk, before = straight_walk
    w = copy.deepcopy(walk)
    j = w.robot.legs["right"].index[3]
    k = int(np.flatnonzero((w.t > 5.2) & (w.support == "left"))[0])
    rows = np.arange(k - 6, k + 7)
    dip = 3.0 * 0.01 * np.abs(rows - k)
    w.q[rows, j] += dip - dip.max()
    a = analyse(w)
    added = a.joint_acceleration[:, j] - before.joint_acceleration[:, j]
    assert added[k] == pytest.approx(600.0, rel=1e-9) and added[k - 6] == pytest.approx(-300.0, rel=1e-9)
    verdict = judge(w, a, spec.success)
    corner = a.joint_acceleration[k - 6, j]
    assert not verdict.ok and f"R_KneePitch accelerates at {corner:+.0f} rad/s²" in verdict.reason
    assert verdict.time_s == pytest.approx(w.t[k - 6], abs=1e-9)  # the first corner, where the dip starts


def test_kappa_without_rotation_sees_the_straight_leg(straight_walk):
    """A straight knee (bend 0) makes the leg's own κ and, without pelvic rotation, κ(J_low) diverge;
    J_low with the pelvic-yaw column stays finite there (the column stands in for the lost direction),
    which is why it appears only when the walk turns the pelvis."""
    from jethr1_plan.walking.analysis import analyse

    _, walk, a = straight_walk
    w = copy.deepcopy(walk)
    k = int(np.flatnonzero((w.t > 5.0) & (w.support == "left"))[10])
    w.q[k, w.robot.legs["right"].index[3]] = 0.0
    w.q[k - 1, w.robot.legs["right"].index[3]] = 0.0
    straight = analyse(w)
    assert straight.knee_bend_rad[k, 1] < 1e-12
    assert straight.kappa_leg[k, 1] > 1e8 and straight.kappa[k] > 1e8
    turned = analyse(replace(w, pelvis_rotation=True))
    assert turned.kappa[k] < 1e3
    assert np.max(a.kappa) < 100  # the clean walk's


@pytest.mark.parametrize("robot", ["dyros_jet_like", "jethr1"])
def test_knee_bend_is_the_knee_angle_and_the_law_of_cosines(robot):
    """The bend by forward kinematics equals the knee angle (both robots are straight at 0) and the
    angle the law of cosines gives from the hip–ankle distance; the IK floor is the margin."""
    from jethr1_plan.robot.load import load_robot
    from jethr1_plan.walking.knees import knee_bend_rad, knee_limits_for_bend, leg_points, straight_knee_rad

    r = load_robot(robot)
    w = r.wrapper()
    rng = np.random.default_rng(2)
    for _ in range(20):
        q = rng.uniform(np.maximum(r.lower_rad, -1.0), np.minimum(r.upper_rad, 1.0))
        w.state.q[7:] = q
        w.update_kinematics()
        for side in ("left", "right"):
            hip, knee, ankle = leg_points(w, r, side)
            d = np.linalg.norm(ankle - hip)
            cos_bend = (d * d - r.thigh_m**2 - r.shank_m**2) / (2 * r.thigh_m * r.shank_m)
            bend = float(knee_bend_rad(hip, knee, ankle))
            assert bend == pytest.approx(np.arccos(np.clip(cos_bend, -1, 1)), abs=1e-6)
            assert bend == pytest.approx(abs(q[r.legs[side].index[3]]), abs=1e-9)
    for side in ("left", "right"):
        assert straight_knee_rad(r, side) == (pytest.approx(0.0, abs=1e-9), 1)
        lo, hi = knee_limits_for_bend(r, side, 0.1)
        assert lo == pytest.approx(0.1) and hi == r.upper_rad[r.legs[side].index[3]]


def test_friction_above_the_soles_mu_fails_the_walk(straight_walk):
    """The same clean walk on soles of μ below its peak friction ratio fails, naming the friction."""
    from jethr1_plan.walking.analysis import judge

    spec, walk, a = straight_walk
    peak = a.peak_friction_ratio
    assert 0 < peak < walk.robot.sole_friction and judge(walk, a, spec.success).ok
    slippery = replace(walk.robot, twin=replace(walk.robot.twin, sole_friction=0.9 * peak))
    w = copy.copy(walk)
    w.robot = slippery
    verdict = judge(w, a, spec.success)
    assert not verdict.ok and "beyond the soles' friction" in verdict.reason
