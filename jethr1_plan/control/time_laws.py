"""Time laws: how a motion is spread over its duration."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["min_jerk", "swing_row_positions"]


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
