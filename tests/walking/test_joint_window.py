"""A joint's window of rates (issue 26): within the rate and acceleration limits, never past its angle
limits, never empty once entered; the braking bound stops the joint at its limit."""

from __future__ import annotations

import numpy as np
import pytest

from jethr1_plan.walking.joint_window import rate_window


def test_a_joint_driven_anyhow_within_its_window_keeps_every_limit():
    """Random joints (limits, rate limits, accelerations) driven by random wishes clipped to their
    window for 3000 periods: the rate never beyond its limit, its change per period never beyond
    a_max·Δt, the angle never beyond its limits, the window never empty."""
    rng = np.random.default_rng(7)
    n, dt = 40, 0.01
    lower, upper = -rng.uniform(0.05, 2, n), rng.uniform(0.05, 2, n)
    vmax, amax = rng.uniform(0.5, 5, n), 100.0
    q, rate = rng.uniform(lower, upper), np.zeros(n)
    for _ in range(3000):
        lo, hi = rate_window(q, rate, lower, upper, vmax, amax, dt)
        assert np.all(lo <= hi + 1e-12)
        wish = rng.uniform(-2 * vmax, 2 * vmax) * (rng.random(n) < 0.3) + rate * (rng.random(n) >= 0.3)
        new = np.clip(wish, lo, hi)
        assert np.all(np.abs(new) <= vmax + 1e-12) and np.all(np.abs(new - rate) <= amax * dt + 1e-9)
        q, rate = q + dt * new, new
        assert np.all(q <= upper + 1e-12) and np.all(q >= lower - 1e-12)


def test_braking_bound_stops_at_the_limit_with_at_most_one_period_to_spare():
    """Heading for the upper limit at the window's top rate, then braking at a_max period by period,
    the joint stops within its limit, and no more than one period's travel (r·Δt) short of it."""
    dt, amax, upper = 0.01, 100.0, 0.5

    def stop(q0: float, r0: float) -> float:
        q, r = q0 + dt * r0, r0
        while r > 0:
            r = max(0.0, r - amax * dt)
            q += dt * r
        return q

    for room in (0.001, 0.02, 0.3, 1.2):
        q = upper - room
        _, hi = rate_window(np.array([q]), np.array([50.0]), np.array([-1.0]), np.array([upper]),
                            np.array([100.0]), amax, dt)
        r = float(hi[0])
        assert 0 < r < 50.0 and upper - r * dt - 1e-12 <= stop(q, r) <= upper + 1e-12


def test_a_joint_too_fast_for_its_limit_has_an_empty_window():
    """At 3.5 rad/s, 10 mm of angle short of its limit, 100 rad/s² cannot stop it: the window is empty
    (lo > hi), which the generator reports as the walk's infeasible instant."""
    lo, hi = rate_window(np.array([0.49]), np.array([3.5]), np.array([-1.0]), np.array([0.5]), np.array([3.5]),
                         100.0, 0.01)
    assert lo[0] == pytest.approx(2.5) and hi[0] < lo[0]
