"""The swing-foot placement law: the swing leg turned back about the support sole by its yaw slip."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jethr1_plan.control.swing_placement import PlacementGains, SwingPlacement, wrap, yaw_of


def _rz(psi: float) -> np.ndarray:
    c, s = math.cos(psi), math.sin(psi)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_yaw_of_and_wrap():
    assert yaw_of(_rz(0.3)) == pytest.approx(0.3)
    assert yaw_of(_rz(0.3).ravel()) == pytest.approx(0.3)
    assert wrap(2 * math.pi + 0.1) == pytest.approx(0.1) and wrap(-math.pi - 0.1) == pytest.approx(math.pi - 0.1)


def test_the_offset_turns_the_landing_back_about_the_support_sole():
    """With a leg whose joints move the sole's pose one to one (J = I), the offset is the move that
    turns the planned landing back by the slip: the landing, rotated about the support sole by δψ
    and then moved by the offset, lies where the plan put it (to the rotation's second order)."""
    law = SwingPlacement(PlacementGains(damping=1e-6), 12)
    joints = np.arange(6, 12)
    slip, lever = math.radians(1.6), np.array([0.515, 0.0])
    out = law.step(slip, 0.0, lever, np.eye(6), joints, 0.002)
    assert np.all(out[:6] == 0.0)  # the support leg is left alone
    turned = _rz(slip)[:2, :2] @ lever  # where the plan's commands would put the landing
    np.testing.assert_allclose(turned + out[6:8], lever, atol=lever[0] * slip**2)
    assert out[6 + 5] == pytest.approx(-slip) and np.allclose(out[8:11], 0.0)
    # 14 mm of the 515 mm step's landing at 1.6° (the trial's worst draw): the sideways move
    assert out[7] == pytest.approx(-0.0144, abs=2e-4)


def test_the_slip_is_low_passed_and_the_offset_clipped():
    gains = PlacementGains(filter_s=0.05, max_offset_rad=0.01)
    law = SwingPlacement(gains, 6)
    joints = np.arange(6)
    law.step(0.0, 0.0, np.array([0.5, 0.0]), np.eye(6), joints, 0.002)
    law.step(0.1, 0.0, np.array([0.5, 0.0]), np.eye(6), joints, 0.002)
    assert law.slip_rad == pytest.approx(0.1 * 0.002 / 0.05)  # one tick of the filter
    for _ in range(500):
        out = law.step(0.1, 0.0, np.array([0.5, 0.0]), np.eye(6), joints, 0.002)
    assert law.slip_rad == pytest.approx(0.1, rel=1e-6) and np.max(np.abs(out)) == pytest.approx(0.01)
