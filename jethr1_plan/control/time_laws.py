"""Time laws: how a motion is spread over its duration."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["Pace", "min_jerk", "min_jerk_segment_times", "pace_accelerations", "paced_row_positions", "paced_time_law",
           "swing_row_positions"]


def min_jerk(t: ArrayLike) -> np.ndarray:
    """Minimum-jerk time law s(t) = 10t³ − 15t⁴ + 6t⁵ on [0, 1]."""
    t = np.clip(t, 0.0, 1.0)
    return t**3 * (10 - 15 * t + 6 * t * t)


def swing_row_positions(samples: int, duration_s: float, rate_hz: float) -> np.ndarray:
    """Where the rows of a swing fall along its path: (rows,) fractional sample indices in [0, N − 1],
    row k at min_jerk(k / n) · (N − 1) with n = round(duration · rate) rows (the landing sample itself
    starts the next transfer)."""
    n = max(1, round(duration_s * rate_hz))
    return min_jerk(np.arange(n) / n) * (samples - 1)


def min_jerk_segment_times(segments: int, duration_s: float) -> np.ndarray:
    """(segments,) the time [s] the minimum-jerk law of :func:`swing_row_positions` spends between
    consecutive samples (the parameter u from i to i + 1); they sum to ``duration_s``."""
    grid = np.linspace(0.0, 1.0, 20001)
    t = np.interp(np.arange(segments + 1) / segments, min_jerk(grid), grid) * duration_s
    return np.diff(t)


def _hermite_ends(tau: np.ndarray, r0: np.ndarray, r1: np.ndarray) -> np.ndarray:
    """(K,) the largest |u''| [1/s²] of the cubic u(t) on [0, τ] from (0, rate r0) to (1, rate r1): u'' is
    linear in t, so the larger of its two ends."""
    a0 = (6.0 - 4.0 * r0 * tau - 2.0 * r1 * tau) / tau**2
    a1 = (-6.0 + 2.0 * r0 * tau + 4.0 * r1 * tau) / tau**2
    return np.maximum(np.abs(a0), np.abs(a1))


@dataclass(frozen=True)
class Pace:
    """A swing's time law through its N samples: sample i at ``times_s[i]`` [s] passed at ``rates[i]``
    [samples/s], u(t) the cubic Hermite between them; ``accel`` the trunk's largest acceleration
    [m/s²] by :func:`pace_accelerations`."""

    times_s: np.ndarray
    rates: np.ndarray
    accel: float

    def positions(self, t: np.ndarray) -> np.ndarray:
        """(rows,) u at times ``t`` [s] (fractional sample indices)."""
        k = np.clip(np.searchsorted(self.times_s, t, side="right") - 1, 0, len(self.times_s) - 2)
        tau = self.times_s[k + 1] - self.times_s[k]
        s = np.clip((t - self.times_s[k]) / tau, 0.0, 1.0)
        h10, h01, h11 = s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        return k + h01 + tau * (h10 * self.rates[k] + h11 * self.rates[k + 1])


def pace_accelerations(p_samples: np.ndarray, tau: np.ndarray, rates: np.ndarray, row_s: float) -> np.ndarray:
    """(2N − 1,) the trunk's acceleration [m/s²] with P_body linear between samples along u(t): within
    each segment |ΔP_i|·max|u''|, and at each sample the one-row kink |ΔP_i − ΔP_i−1|·u'/``row_s``."""
    d = np.diff(np.asarray(p_samples, dtype=float), axis=0)
    seg = np.linalg.norm(d, axis=1) * _hermite_ends(tau, rates[:-1], rates[1:])
    zero = np.zeros((1, d.shape[1]))
    turn = np.linalg.norm(np.diff(np.vstack([zero, d, zero]), axis=0), axis=1)
    return np.concatenate([seg, turn * rates / row_s])


def paced_time_law(p_samples: np.ndarray, duration_s: float, rate_hz: float, accel_max: float,
                   rounds: int = 400) -> Pace:
    """A time law for a swing whose trunk (P_body linear between the N samples) must not accelerate
    faster than ``accel_max`` [m/s²] where that can be had in ``duration_s``: each sample is passed
    at the rate at which its kink (the change of ΔP from one segment to the next) costs at most
    ``accel_max`` in one row (so the trunk all but stops where it turns sharply), at most the mean of
    its segments' rates and never faster than a monotone cubic allows (3/τ); each segment lasts the
    minimum-jerk law's time, lengthened where the cubic's |ΔP|·|u''| exceeds ``accel_max`` (the others
    shortened to keep ``duration_s``). At rest at both ends. Returns the best of ``rounds``."""
    p = np.asarray(p_samples, dtype=float)
    d = np.diff(p, axis=0)
    zero = np.zeros((1, d.shape[1]))
    turn = np.linalg.norm(np.diff(np.vstack([zero, d, zero]), axis=0), axis=1)
    row_s = 1.0 / rate_hz
    cap = np.where(turn > 0, accel_max * row_s / np.maximum(turn, 1e-12), np.inf)
    tau = min_jerk_segment_times(len(p) - 1, duration_s)
    best: Pace | None = None
    # Where no law holds accel_max, the segments that need no time shrink round by round until |u''| ~ 1/τ²
    # overflows: such a round's acceleration is inf or NaN and never the best, and once a τ is not finite no
    # later round is either, so the search ends there.
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        for _ in range(rounds):
            if not np.all(np.isfinite(tau)):
                break
            mean = np.concatenate([[0.0], 0.5 * (1.0 / tau[:-1] + 1.0 / tau[1:]), [0.0]])
            mono = np.concatenate([[0.0], np.minimum(3.0 / tau[:-1], 3.0 / tau[1:]), [0.0]])
            rates = np.minimum(np.minimum(mean, mono), cap)
            a = pace_accelerations(p, tau, rates, row_s)
            worst = float(np.max(a))
            if best is None or worst < best.accel:
                best = Pace(np.concatenate([[0.0], np.cumsum(tau)]), rates, worst)
            if worst <= accel_max:
                break
            seg = a[:len(tau)]
            tau = tau * np.maximum(seg / accel_max, 1.0) ** 0.25
            tau *= duration_s / tau.sum()
    assert best is not None
    times = np.minimum(best.times_s, duration_s)  # (the sum's rounding kept off the end)
    times[-1] = duration_s
    return Pace(times, best.rates, best.accel)


def paced_row_positions(p_samples: np.ndarray, duration_s: float, rate_hz: float, accel_max: float) -> np.ndarray:
    """The swing's rows as :func:`swing_row_positions` places them (the same count), timed by
    :func:`paced_time_law`."""
    n = max(1, round(duration_s * rate_hz))
    pace = paced_time_law(p_samples, duration_s, rate_hz, accel_max)
    return np.clip(pace.positions(np.arange(n) / rate_hz), 0.0, len(p_samples) - 1.0)
