"""The walk generator without impulses (issue 26): every joint within its rate and acceleration limits
by construction, the CoM on the LIPM's, the arms cancelling the momentum of the same period; where the
leg cannot follow, exit 3 naming the instant and the joint, not a snap."""

from __future__ import annotations

import json

import numpy as np
import pytest

from jethr1_plan.cli import run
from tests.conftest import ROOT
from tests.oracles.walk_audit import audit_walk

DYROS_WALK = ROOT / "configs" / "walks" / "dyros_walk.yaml"


@pytest.fixture(scope="module")
def default_walk():
    from jethr1_plan.walking.result import generate_walk
    from jethr1_plan.walking.spec import load_walk

    spec = load_walk(DYROS_WALK)
    return spec, generate_walk(spec)


def test_rows_keep_every_joint_within_its_rate_and_acceleration_limits(default_walk):
    """The shipped walk: every joint's rate over each period within the URDF's limit, every second
    central difference within the walk's acceleration limit, the knees bent at least the margin."""
    spec, walk = default_walk
    dt = 1.0 / spec.timing.control_hz
    rate = np.diff(walk.q, axis=0) / dt
    acc = np.diff(walk.q, 2, axis=0) / dt**2
    vmax = np.array(walk.robot.wrapper().model.velocityLimit[6:])
    assert np.all(np.abs(rate) <= vmax + 1e-6)
    assert np.max(np.abs(acc)) <= spec.ik.max_joint_acceleration_rad_s2 + 1e-3
    knees = [walk.robot.legs[s].index[3] for s in ("left", "right")]
    assert np.min(walk.q[:, knees]) >= spec.success.knee_margin_rad
    assert walk.infeasible is None


def test_com_is_the_lipms_and_the_arms_cancel_the_same_periods_momentum(default_walk):
    """The posture's CoM within 0.01 mm of the LIPM's on every row (a hard constraint, not a weight the
    floating base can trade); the arms' yaw momentum cancels the lower body's of the same period to
    within 2 % of its peak (one period late it left 5.5 %)."""
    _, walk = default_walk
    assert np.max(np.linalg.norm(walk.com - walk.com_ref, axis=1)) < 1e-5
    assert np.max(np.abs(walk.h_low + walk.h_up)) <= 0.02 * np.max(np.abs(walk.h_low))
    assert np.max(np.abs(walk.h_low)) > 0.5  # the lower body's momentum is there to cancel


def test_issue_walk_of_043_m_exits_3_naming_the_knee_and_writes_no_snap(tmp_path, capsys):
    """Issue 26's walk: 0.43 m steps with pelvic rotation on the Dyros-Jet-like robot (once called a
    success with a 682 rad/s² knee reversal before each landing). It exits 3 naming the instant, the
    sole the leg could not follow and the knee that held it back at its rate limit; its rows, written
    anyway, have no joint beyond 100 rad/s² by second central differences (pinocchio's)."""
    text = DYROS_WALK.read_text().replace("step_length_m: 0.30", "step_length_m: 0.43")
    f = tmp_path / "long.yaml"
    f.write_text(text)
    assert run(["walk", str(f), "-o", str(tmp_path / "out"), "--no-rehearse", "--write-infeasible"]) == 3
    err = capsys.readouterr().err
    assert "the walk fails at t = " in err and "off its target" in err and "KneePitch at -3.50 rad/s" in err
    audit = audit_walk(tmp_path / "out" / "long")
    assert np.nanmax(np.abs(audit.qdd)) <= 100.0 + 1e-3
    assert json.loads((tmp_path / "out" / "long" / "summary.json").read_text())["ok"] is False
