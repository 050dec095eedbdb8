"""The thrust feedback law (control/thrust_feedback.py) against moment balance: a static robot whose
ZMP is z(F) = (W·c − F·P)/(W − F) (A-1, A-2), its fan through a first-order lag, closed by the law."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from jethr1_plan.control import thrust_feedback as ctl
from jethr1_plan.geometry import GRAVITY, polygon_margin, sole_polygon

W = 6.8 * GRAVITY  # Jet-HR1's weight [N]
SOLE = sole_polygon(np.zeros(2), 0.0, 0.16, 0.09)  # x in ±0.08 (toe at +x), y in ±0.045
FAN = np.array([0.25, 0.20])  # ahead and beside, as over a ditch: more thrust moves the ZMP to −x and −y


def zmp(com: np.ndarray, thrust_n: float) -> np.ndarray:
    return (W * com - thrust_n * FAN) / (W - thrust_n)


def com_for(zmp_xy: tuple[float, float], thrust_n: float) -> np.ndarray:
    """The CoM whose ZMP at ``thrust_n`` is ``zmp_xy`` (moment balance solved for c)."""
    return (np.asarray(zmp_xy) * (W - thrust_n) + thrust_n * FAN) / W


def settle(gains: ctl.Gains, com: np.ndarray, plan_n: float, upper_n: float = 23.0, lag_s: float = 0.05,
           seconds: float = 5.0) -> float:
    """The fan's thrust [N] after ``seconds`` of the law closed on the static robot."""
    law, applied = ctl.ThrustFeedback(gains), plan_n
    dt = 1.0 / gains.rate_hz
    for _ in range(round(seconds / dt)):
        cmd = law.step(zmp(com, applied), FAN, SOLE, plan_n, upper_n)
        assert 0.0 <= cmd <= upper_n
        applied += (cmd - applied) * dt / lag_s
    return applied


def test_the_error_is_signed_by_the_edge_the_cop_nears():
    m = 0.02
    u = np.array([0.08, 0.0]) - FAN
    u /= np.hypot(*u)
    # on the toe (the fan's side along u): more thrust, by the move along u that puts it m inside
    assert ctl.edge_error(np.array([0.08, 0.0]), FAN, SOLE, m) == pytest.approx(m / -u[0])
    # near the heel (beyond, along u): less thrust
    e = ctl.edge_error(np.array([-0.075, 0.0]), FAN, SOLE, m)
    assert e < 0 and polygon_margin(np.array([-0.075, 0.0]) + e * (np.array([-0.075, 0.0]) - FAN)
                                    / np.hypot(*(np.array([-0.075, 0.0]) - FAN)), SOLE) == pytest.approx(m)
    # at least m inside every edge: nothing to do
    assert ctl.edge_error(np.array([0.0, 0.0]), FAN, SOLE, m) == 0.0


def test_the_loop_settles_where_moment_balance_puts_the_zmp_inside_the_toe():
    """The planned 12 N puts the ZMP on the toe edge (margin 0); the law raises the thrust until the
    ZMP is the band margin inside it: F* = W·(c_x − (0.08 − m))/(P_x − (0.08 − m)) by moment balance."""
    gains = ctl.Gains(band_margin_m=0.02, kp_n_per_m=600.0, ki_n_per_m_s=3000.0)
    com = com_for((0.08, 0.0), 12.0)
    edge = 0.08 - gains.band_margin_m
    f_star = W * (com[0] - edge) / (FAN[0] - edge)
    f = settle(gains, com, 12.0)
    assert f == pytest.approx(f_star, abs=0.01) and f_star > 17.0
    assert zmp(com, f)[0] == pytest.approx(edge, abs=1e-4)


def test_at_a_corner_the_law_balances_the_two_edges():
    """The CoP beyond the toe with the outer edge (−y) 45 mm away: the thrust that brings it m inside
    the toe (23.5 N) pushes it over the outer edge, so no thrust has both margins m. The law settles
    where the two margins are equal, the thrust moment balance gives for it."""
    gains = ctl.Gains(band_margin_m=0.02, kp_n_per_m=600.0, ki_n_per_m_s=3000.0)
    com = com_for((0.10, 0.0), 12.0)

    def toe_minus_outer(f: float) -> float:
        z = zmp(com, f)
        return (0.08 - z[0]) - (z[1] + 0.045)

    f_eq = brentq(toe_minus_outer, 12.0, 23.0)
    f = settle(gains, com, 12.0)
    assert f == pytest.approx(f_eq, abs=0.01)
    z = zmp(com, f)
    assert 0.0 < polygon_margin(z, SOLE) < gains.band_margin_m and 0.08 - z[0] == pytest.approx(z[1] + 0.045, abs=1e-4)


def test_the_law_goes_to_the_fans_limit_when_moment_balance_needs_more():
    """CoM so far forward that the toe needs more than the fans have: the command sits on the upper
    bound it is given (the whole thrust), not below it."""
    gains = ctl.Gains()
    com = com_for((0.10, 0.03), 12.0)  # the outer edge far enough for the thrust to help
    edge = 0.08 - gains.band_margin_m
    need = W * (com[0] - edge) / (FAN[0] - edge)
    assert need > 23.0
    assert settle(gains, com, 12.0, upper_n=23.0) == pytest.approx(23.0, abs=1e-3)


def test_the_step_does_not_wind_up_and_leaks():
    g = ctl.Gains(rate_hz=100.0, kp_n_per_m=400.0, ki_n_per_m_s=1000.0, leak_time_s=0.1)
    out, integral = ctl.step(g, 0.0, 0.01, 5.0, 0.0, 23.0)
    assert out == pytest.approx(5.0 + 4.0) and integral == pytest.approx(1e-4)
    out, integral2 = ctl.step(g, integral, 0.01, 20.0, 0.0, 23.0)  # saturated upwards: no wind-up
    assert out == 23.0 and integral2 == integral
    _, leaked = ctl.step(g, integral, 0.0, 5.0, 0.0, 23.0)  # inside the band the integral leaks
    assert leaked == pytest.approx(integral * 0.9)
    law = ctl.ThrustFeedback(g)
    law.step(np.array([0.08, 0.0]), FAN, SOLE, 5.0, 23.0)
    assert law.integral > 0 and not math.isclose(law.last_error_m, 0.0)
    law.reset()
    assert law.integral == 0.0 and law.last_error_m == 0.0
