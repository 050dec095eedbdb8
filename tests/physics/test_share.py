"""The share of a tolerance a posture (and its thrust) survives, against brute force over the errors."""

from __future__ import annotations

import numpy as np
import pytest

from jethr1_plan.geometry import polygon_margin, sole_polygon
from jethr1_plan.physics.balance import Tolerance, zmp_with_thrust
from jethr1_plan.physics.share import largest_shares, row_shares

SOLE = sole_polygon(np.zeros(2), 0.0, 0.16, 0.09)
M = 6.8
TOL = Tolerance(0.10, 0.05, 0.01)
RING = np.stack([np.cos(a := np.linspace(0, 2 * np.pi, 144, endpoint=False)), np.sin(a)], axis=1)


def _worst_margin(com, fan, thrust, s):
    """The least ZMP margin [m] over every corner of s × TOL for each thrust (scalar or (N,)): thrust
    ±sX, mass ±sY, the CoM sε away in any of 144 directions (the moment formula, not the slack rows)."""
    f = np.atleast_1d(np.asarray(thrust, dtype=float))[:, None]  # (N, 1)
    worst = np.full(len(f), np.inf)
    for e in (-TOL.thrust * s, TOL.thrust * s):
        for m in (-TOL.mass * s, TOL.mass * s):
            zmp = zmp_with_thrust(com + TOL.com_m * s * RING, fan, f * (1 + e), M * (1 + m))  # (N, 144, 2)
            worst = np.minimum(worst, polygon_margin(zmp, SOLE).min(axis=-1))
    return worst if np.ndim(thrust) else float(worst[0])


@pytest.mark.parametrize("com, fan, thrust", [
    ((0.07, 0.0), (0.45, 0.05), 12.0),   # the CoM near the toe, the fan far ahead: the thrust pulls it back
    ((0.06, 0.03), (0.30, 0.25), 8.0),   # diagonal
    ((0.02, -0.03), (0.0, 0.3), 3.0),    # little thrust: the CoM error matters most
    ((0.09, 0.0), (0.50, 0.0), 20.0),    # the CoM beyond the toe
])
def test_a_row_share_is_the_largest_share_every_corner_survives(com, fan, thrust):
    com, fan = np.array(com), np.array(fan)
    s = float(row_shares(com, fan[None], np.array([thrust]), SOLE, M, TOL))
    assert 0.0 <= s <= 1.0
    if s > 0:
        assert _worst_margin(com, fan, thrust, s) >= -1e-9
    if s < 1.0:
        assert _worst_margin(com, fan, thrust, min(1.0, s + 0.005)) < 0


def test_the_largest_share_of_a_posture_is_where_its_window_closes():
    """Scanned at 0.005 N over 0..F_max: some thrust survives every corner of (s − 0.002) × TOL, s the
    share ``largest_shares`` returns, and none survives every corner of (s + 0.002) × TOL."""
    # far beyond the toe with the fan far ahead: windows whose nominal width is a few newtons
    cases = [((0.40, 0.0), (1.2, 0.0), 23.0), ((0.38, 0.01), (1.1, 0.05), 23.0), ((0.30, 0.0), (0.9, 0.0), 18.5)]
    for com, fan, fmax in cases:
        com, fan = np.array(com), np.array(fan)
        s = float(largest_shares(com, fan[None], SOLE, M, TOL, np.array([fmax])))
        assert 0.0 < s < 1.0
        thrusts = np.arange(0.0, fmax + 1e-9, 0.005)
        assert _worst_margin(com, fan, thrusts, s - 0.002).max() >= 0
        assert _worst_margin(com, fan, thrusts, s + 0.002).max() < 0


def test_shares_fall_with_the_thrust_cap_and_are_minus_one_where_nothing_balances():
    com, fan = np.array([0.40, 0.0]), np.array([[1.2, 0.0]])  # nominal window [19.06, 25.02] N
    caps = np.array([23.0, 21.0, 20.0])
    s = [float(largest_shares(com, fan, SOLE, M, TOL, np.array([c]))) for c in caps]
    assert 1.0 > s[0] > s[1] > s[2] > 0.0
    assert float(largest_shares(com, fan, SOLE, M, TOL, np.array([19.0]))) == -1.0  # below the window
    assert float(largest_shares(np.array([0.3, 0.02]), np.array([[0.9, 0.3]]), SOLE, M, TOL, np.array([23.0]))) == -1.0
    # a CoM well inside needs no thrust and holds the whole tolerance
    assert float(largest_shares(np.zeros(2), fan, SOLE, M, TOL, np.array([23.0]))) == 1.0
    assert float(row_shares(np.zeros(2), fan, np.zeros(1), SOLE, M, TOL)) == 1.0
