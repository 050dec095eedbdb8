"""The swing's time laws: the minimum-jerk law and the paced law that bounds the trunk's acceleration."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from jethr1_plan.control.time_laws import (
    min_jerk,
    min_jerk_segment_times,
    paced_row_positions,
    paced_time_law,
    swing_row_positions,
)

RATE_HZ, SWING_S = 50.0, 8.0


def _jump_path() -> np.ndarray:
    """25 P_body samples [m]: 12 mm steps forward, and between samples 5 and 6 a jump of 131 mm (forward,
    sideways and up), as the optimiser's trunk made on seed 91 of the route bench (docs/route.md)."""
    d = np.tile([0.012, 0.0, 0.002], (24, 1))
    d[5] = [0.055, -0.085, 0.08]
    start = np.array([0.0, 0.0, 0.30])
    return np.vstack([start, start + np.cumsum(d, axis=0)])


def _row_accelerations(p_samples: np.ndarray, u: np.ndarray) -> np.ndarray:
    """|second difference| [m/s²] of the rows' P_body, linear between samples at the rows' ``u``, the trunk
    held at the first and last sample beyond the rows (computed here from the rows alone)."""
    idx = np.arange(len(p_samples))
    p = np.column_stack([np.interp(u, idx, p_samples[:, j]) for j in range(3)])
    p = np.vstack([p[:1], p, p_samples[-1:]])
    return np.linalg.norm(p[2:] - 2 * p[1:-1] + p[:-2], axis=1) * RATE_HZ**2


def test_min_jerk_segment_times_are_the_laws_own():
    tau = min_jerk_segment_times(24, SWING_S)
    assert tau.sum() == pytest.approx(SWING_S)
    t = np.concatenate([[0.0], np.cumsum(tau)]) / SWING_S
    np.testing.assert_allclose(min_jerk(t) * 24, np.arange(25), atol=1e-3)  # sample i reached at t_i


def test_the_paced_law_bounds_the_trunks_acceleration_where_min_jerk_does_not():
    p = _jump_path()
    default = swing_row_positions(len(p), SWING_S, RATE_HZ)
    assert _row_accelerations(p, default).max() > 5.0  # a 131 mm jump in ~0.2 s: m/s² of trunk acceleration
    for accel in (0.4, 0.2):
        u = paced_row_positions(p, SWING_S, RATE_HZ, accel)
        assert len(u) == len(default)  # the same rows: the swing keeps its duration
        assert u[0] == 0.0 and np.all(np.diff(u) >= -1e-12) and u[-1] <= len(p) - 1
        assert u[-1] > len(p) - 1 - 1e-3  # it arrives
        # the pace bounds each segment and each turn; a row straddling a sample sees both sides at once
        assert _row_accelerations(p, u).max() <= 1.5 * accel


def test_the_paced_law_passes_sharp_turns_slowly_and_is_at_rest_at_both_ends():
    p = _jump_path()
    pace = paced_time_law(p, SWING_S, RATE_HZ, 0.4)
    assert pace.rates[0] == pace.rates[-1] == 0.0
    assert pace.times_s[-1] == SWING_S and np.all(np.diff(pace.times_s) > 0)
    turn = np.linalg.norm(np.diff(np.diff(p, axis=0), axis=0), axis=1)  # the change of ΔP at samples 1..N-2
    # the kink's one-row velocity change |ΔP_i − ΔP_i−1|·u' stays within 0.4 m/s² × one row
    assert np.all(turn * pace.rates[1:-1] <= 0.4 / RATE_HZ + 1e-12)
    assert pace.times_s[6] - pace.times_s[5] > 1.0  # the jump's segment takes over a second (min-jerk: 0.23 s)
    assert pace.accel <= 0.4 + 1e-12


def test_a_swing_no_pace_can_hold_ends_with_its_best_law_finite_and_silent():
    """A trunk that moves along one segment of 24 only, by 0.6-1.2 m in 3 s under 0.01 m/s²: no law holds the
    bound, the still segments shrink towards nothing round by round, and the search used to print numpy's overflow
    warnings (they reached a design sweep's terminal). It ends with the best law it found: finite, at rest at both
    ends, its segments summing to the duration, the moving segment given nearly all of it, and no warning."""
    for metres in (0.6, 0.8, 1.2):
        p = np.zeros((25, 3))
        p[12:, 0] = metres
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            pace = paced_time_law(p, 3.0, 50.0, 0.01)
        assert np.isfinite(pace.accel) and pace.accel > 0.01
        assert np.all(np.isfinite(pace.times_s)) and np.all(np.diff(pace.times_s) >= 0)
        assert pace.times_s[0] == 0.0 and pace.times_s[-1] == 3.0
        assert pace.rates[0] == 0.0 and pace.rates[-1] == 0.0
        assert pace.times_s[12] - pace.times_s[11] > 0.99 * 3.0
