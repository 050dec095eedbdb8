"""The rates a joint may take over the next control period without an impulse: within its rate limit,
within ``a_max·Δt`` of its rate over the last period (the acceleration limit, so that the second
central difference of the rows never exceeds ``a_max``), and slow enough to stop before its angle
limits at ``a_max`` (discrete braking).

Braking: from the angle q, a rate r over the next period leaves ``room − r·Δt`` to the upper limit;
decelerating by ``a_max·Δt`` per period afterwards covers at most ``r²/(2·a_max)`` more, so

    r·Δt + r²/(2·a_max) ≤ room   ⇔   r ≤ −a_max·Δt + √((a_max·Δt)² + 2·a_max·room)

and symmetrically towards the lower limit. The condition is invariant: once it holds, the rate
``r − a_max·Δt`` of the period after it satisfies it again, so a joint inside its window never
meets an empty one unless another bound (its rate limit) moves. An empty window (lo > hi) means the
joint cannot be kept within its limits at that instant.
"""

from __future__ import annotations

import numpy as np

__all__ = ["rate_window"]


def rate_window(q: np.ndarray, rate: np.ndarray, lower: np.ndarray, upper: np.ndarray, rate_max: np.ndarray,
                acc_max: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) (n,) the rates [rad/s] the joints may take over the next period.

    Args:
        q: (n,) the joints' angles now [rad]; rate: (n,) their rates over the last period [rad/s];
        lower, upper: (n,) their angle limits [rad] (±inf: none); rate_max: (n,) [rad/s];
        acc_max: the acceleration limit [rad/s²]; dt: the control period [s].
    """
    a_dt = acc_max * dt
    room_hi = np.maximum(np.asarray(upper, dtype=float) - q, 0.0)
    room_lo = np.maximum(q - np.asarray(lower, dtype=float), 0.0)
    brake_hi = -a_dt + np.sqrt(a_dt * a_dt + 2.0 * acc_max * room_hi)
    brake_lo = a_dt - np.sqrt(a_dt * a_dt + 2.0 * acc_max * room_lo)
    hi = np.minimum(np.minimum(rate + a_dt, rate_max), brake_hi)
    lo = np.maximum(np.maximum(rate - a_dt, -np.asarray(rate_max, dtype=float)), brake_lo)
    return lo, hi
