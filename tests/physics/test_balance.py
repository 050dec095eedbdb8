"""The balance model (A-1)..(A-4), (A-10) and the thrust window (robust policy) on cases solvable by hand,
by brute force and by its properties."""

from __future__ import annotations

import numpy as np
import pytest

from jethr1_plan.geometry import inside_polygon, polygon_margin, sole_polygon, wrap_angle
from jethr1_plan.physics.balance import (
    Tolerance,
    balance_slack,
    body_yaw_eq4,
    edge_angle_error,
    minimal_thrust,
    thrust_window,
    zmp_with_thrust,
)

M, G = 6.8, 9.81
W = M * G
SOLE = sole_polygon(np.zeros(2), 0.0, 0.16, 0.09)  # x in [-0.08, 0.08], y in [-0.045, 0.045]


def test_com_inside_the_sole_needs_no_thrust():
    f, zmp = minimal_thrust(np.array([0.03, -0.01]), np.array([0.5, 0.0]), SOLE, M)
    assert f == 0.0
    np.testing.assert_allclose(zmp, [0.03, -0.01])


def test_symmetric_case_by_hand():
    # CoM 0.1 m ahead of the toe edge (x = 0.08), fan 0.3 m further on the same line:
    # the moment about the toe edge balances when F·(0.48 − 0.08) = W·(0.18 − 0.08) + ... exactly:
    # ZMP = (W·c − F·p)/(W − F) = 0.08  →  F = W·(c − 0.08)/(p − 0.08)
    c, p = 0.18, 0.48
    f, zmp = minimal_thrust(np.array([c, 0.0]), np.array([p, 0.0]), SOLE, M)
    assert f == pytest.approx(W * (c - 0.08) / (p - 0.08), rel=1e-12)
    np.testing.assert_allclose(zmp, [0.08, 0.0], atol=1e-12)


def test_moment_balance_about_the_zmp():
    # with the returned thrust, gravity and thrust have no moment about the ZMP
    rng = np.random.default_rng(0)
    com = rng.uniform([0.1, -0.2], [0.4, 0.2], (200, 2))
    fan = com + rng.uniform([0.1, -0.2], [0.5, 0.2], (200, 2))
    f, zmp = minimal_thrust(com, fan, SOLE, M)
    ok = np.isfinite(f)
    assert ok.sum() > 50
    moment = W * (com[ok] - zmp[ok]) - f[ok, None] * (fan[ok] - zmp[ok])
    np.testing.assert_allclose(moment, 0.0, atol=1e-9)
    np.testing.assert_allclose(zmp_with_thrust(com[ok], fan[ok], f[ok], M), zmp[ok], atol=1e-12)


def test_ray_that_misses_the_sole_cannot_be_balanced():
    # CoM beside the sole, fan straight behind it: the ZMP moves further away from the sole
    f, zmp = minimal_thrust(np.array([0.3, 0.2]), np.array([0.3, 0.5]), SOLE, M)
    assert np.isinf(f) and np.all(np.isnan(zmp))


def test_minimal_thrust_is_minimal_property():
    rng = np.random.default_rng(1)
    com = rng.uniform([-0.3, -0.3], [0.5, 0.3], (2000, 2))
    fan = com + rng.normal(0, 0.3, (2000, 2))
    f, zmp = minimal_thrust(com, fan, SOLE, M)
    ok = np.isfinite(f) & (f > 1e-6)
    assert ok.sum() > 200
    # with F*: on the boundary (or inside) of the sole
    assert np.all(inside_polygon(zmp[ok], SOLE, tol_m=1e-9))
    on_edge = np.abs(np.abs(zmp[ok]) - [0.08, 0.045]).min(axis=1)
    assert np.all(on_edge < 1e-9)
    # with any smaller thrust: outside
    for frac in (0.999, 0.9, 0.5, 0.0):
        smaller = zmp_with_thrust(com[ok], fan[ok], f[ok] * frac, M)
        assert not np.any(inside_polygon(smaller, SOLE, tol_m=-1e-12))


def test_margin_shrinks_the_sole():
    f0, _ = minimal_thrust(np.array([0.18, 0.0]), np.array([0.48, 0.0]), SOLE, M)
    f1, zmp = minimal_thrust(np.array([0.18, 0.0]), np.array([0.48, 0.0]),
                             sole_polygon(np.zeros(2), 0.0, 0.16, 0.09, margin_m=0.01), M)
    assert f1 > f0 and zmp[0] == pytest.approx(0.07)
    with pytest.raises(ValueError):
        sole_polygon(np.zeros(2), 0.0, 0.16, 0.09, margin_m=0.05)


def test_edge_angle():
    # CoM on the line from Z to the ankle: 0; CoM off it by 10 deg seen from Z: about 10 deg + bend
    assert edge_angle_error(np.zeros(2), np.array([0.1, 0.1]), np.array([0.3, 0.3])) == pytest.approx(0.0, abs=1e-12)
    bend = edge_angle_error(np.zeros(2), np.array([0.0, 0.1]), np.array([0.1, 0.2]))
    assert bend == pytest.approx(np.pi / 4)
    assert edge_angle_error(np.zeros(2), np.zeros(2), np.array([0.1, 0.2])) == 0.0


def test_body_yaw_eq4_turns_the_hip_line_towards_the_fan():
    z = np.array([0.0, -0.1125])
    # fan straight to the left of a right support foot: normal stance, yaw 0
    assert body_yaw_eq4(z, np.array([0.0, 0.3]), "right") == pytest.approx(0.0)
    # fan straight ahead: the trunk turns -90 deg so that the left hip leads
    assert body_yaw_eq4(z, np.array([0.6, -0.1125]), "right") == pytest.approx(-np.pi / 2)
    # left support, fan to the right: yaw 0; fan ahead: +90 deg
    zl = np.array([0.0, 0.1125])
    assert body_yaw_eq4(zl, np.array([0.0, -0.3]), "left") == pytest.approx(0.0)
    assert body_yaw_eq4(zl, np.array([0.6, 0.1125]), "left") == pytest.approx(np.pi / 2)


def test_edge_excess():
    from jethr1_plan.physics.balance import edge_angle_excess

    z, com, ankle = np.zeros(2), np.array([0.0, 0.1]), np.array([0.1, 0.2])  # a 45 deg bend
    rho = np.radians(5)
    assert edge_angle_excess(z, com, ankle, rho) == pytest.approx(np.pi / 4 - rho)
    assert edge_angle_excess(z, com, np.array([0.005, 0.2]), rho) == 0.0


# --- the thrust window and its robust version (balance.thrust_window) -----------------------------


def test_window_by_hand():
    # CoM 0.1 m beyond the toe (x = 0.08), fan further along x: the ZMP enters at the toe and leaves
    # at the heel (x = -0.08); moment balance about each edge gives both ends
    c, p = 0.18, 0.48
    lo, hi = thrust_window(np.array([c, 0.0]), np.array([p, 0.0]), SOLE, M)
    assert lo == pytest.approx(W * (c - 0.08) / (p - 0.08), rel=1e-12)
    assert hi == pytest.approx(W * (c + 0.08) / (p + 0.08), rel=1e-12)
    for f, x in ((lo, 0.08), (hi, -0.08)):
        np.testing.assert_allclose(zmp_with_thrust(np.array([c, 0.0]), np.array([p, 0.0]), f, M), [x, 0.0], atol=1e-12)


def test_minimal_thrust_is_the_window_lower_end():
    rng = np.random.default_rng(3)
    com = rng.uniform([-0.3, -0.3], [0.5, 0.3], (5000, 2))
    fan = com + rng.normal(0, 0.3, (5000, 2))
    f, _ = minimal_thrust(com, fan, SOLE, M)
    lo, hi = thrust_window(com, fan, SOLE, M)
    np.testing.assert_array_equal(np.isfinite(f), np.isfinite(lo))
    ok = np.isfinite(lo)
    np.testing.assert_allclose(lo[ok], f[ok], atol=1e-12)
    # inside the window the ZMP is in the sole, just outside it is not
    z_in = zmp_with_thrust(com[ok], fan[ok], 0.5 * (lo[ok] + hi[ok]), M)
    assert np.all(polygon_margin(z_in, SOLE) >= -1e-12)
    grow = hi[ok] < 0.99 * W
    z_out = zmp_with_thrust(com[ok][grow], fan[ok][grow], hi[ok][grow] * (1 + 1e-6), M)
    assert np.all(polygon_margin(z_out, SOLE) < 0)


def test_robust_scaling_by_hand():
    """CoM beyond one edge only, no CoM tolerance: the worst case is the weak fan and the heavy robot,
    F·(1 − X) ≥ M·g·(1 + Y)·d/a, so the lower end is the nominal one times (1 + Y)/(1 − X)."""
    com, fan = np.array([0.18, 0.0]), np.array([0.48, 0.0])
    lo0, hi0 = thrust_window(com, fan, SOLE, M)
    lo, hi = thrust_window(com, fan, SOLE, M, Tolerance(0.1, 0.05, 0.0))
    assert lo == pytest.approx(lo0 * 1.05 / 0.9, rel=1e-12)
    assert hi == pytest.approx(hi0 * 0.95 / 1.1, rel=1e-12)


@pytest.mark.parametrize("tol", [Tolerance(0.1, 0.05, 0.01), Tolerance(0.2, 0.0, 0.0), Tolerance(0.0, 0.1, 0.005)])
def test_robust_window_holds_every_error_and_is_tight(tol):
    """Brute force over the errors: every thrust in the window keeps the ZMP in the sole for every
    corner of thrust and mass error and every CoM offset on the tolerance's circle; just below the
    lower end some error puts it outside (the window is exact, not conservative)."""
    rng = np.random.default_rng(4)
    com = rng.uniform([0.05, -0.1], [0.3, 0.1], (400, 2))
    fan = com + rng.uniform([0.1, -0.2], [0.5, 0.2], (400, 2))
    lo, hi = thrust_window(com, fan, SOLE, M, tol)
    ok = np.flatnonzero(np.isfinite(lo) & (lo > 0.5))
    assert len(ok) > 40
    angles = np.linspace(0, 2 * np.pi, 72, endpoint=False)
    offsets = tol.com_m * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    errors = [(e, m) for e in (-tol.thrust, tol.thrust) for m in (-tol.mass, tol.mass)]

    def worst_margin(i, f):
        c = com[i] + offsets
        return min(float(polygon_margin(zmp_with_thrust(c, fan[i], f * (1 + e), M * (1 + m)), SOLE).min())
                   for e, m in errors)

    for i in ok[:80]:
        for f in (lo[i], 0.5 * (lo[i] + hi[i]), hi[i]):
            assert worst_margin(i, f) >= -1e-9
        assert worst_margin(i, lo[i] * (1 - 1e-4)) < 0


def test_balance_slack_agrees_with_the_window():
    rng = np.random.default_rng(5)
    tol = Tolerance(0.1, 0.05, 0.01)
    com = rng.uniform([0.0, -0.1], [0.3, 0.1], (500, 2))
    fan = com + rng.uniform([0.1, -0.2], [0.5, 0.2], (500, 2))
    lo, hi = thrust_window(com, fan, SOLE, M, tol)
    ok = np.isfinite(lo)
    mid = 0.5 * (lo + np.where(ok, hi, 0))
    slack = balance_slack(com[ok], fan[ok, None], mid[ok, None], SOLE, M, tol)
    assert np.all(slack >= -1e-9)
    below = ok & (lo > 1.0)
    slack = balance_slack(com[below], fan[below, None], 0.99 * lo[below, None], SOLE, M, tol)
    assert np.all(slack < 0)


def test_the_yaw_of_a_left_support_is_the_mirror_of_a_right_one_to_the_bit():
    """(A-4) for a left support at the mirror image (y → −y) of a right support and its fan: the opposite yaw,
    to the bit (the left balance space is computed as the exact mirror of the right one), and wrap_angle is
    odd and leaves angles within (−π, π] as they are."""
    rng = np.random.default_rng(2)
    sup = np.array([0.03, -0.1125])
    fan = np.column_stack([rng.uniform(-1, 1, 5000), rng.uniform(-1, 1, 5000)])
    flip = np.array([1.0, -1.0])
    right = body_yaw_eq4(sup, fan, "right")
    left = body_yaw_eq4(sup * flip, fan * flip, "left")
    np.testing.assert_array_equal(left, -right)
    a = rng.uniform(-20, 20, 10000)
    w = wrap_angle(a)
    np.testing.assert_array_equal(wrap_angle(-a), -w)
    assert np.all((w > -np.pi) & (w <= np.pi)) and wrap_angle(-np.pi) == np.pi
    np.testing.assert_allclose(np.exp(1j * w), np.exp(1j * a), atol=1e-12)
    inside = rng.uniform(-np.pi, np.pi, 1000)
    np.testing.assert_array_equal(wrap_angle(inside), inside)
