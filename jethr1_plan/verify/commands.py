"""The command columns as ``verify`` recomputes them from written rows, restated from docs/rehearsal.md ("what to
send", the ``_cmd`` columns of docs/contract.md) and not from the planner's code (``control/commands.py``):

* a position servo of stiffness k sags by τ/k under a torque τ, so it is sent q + τ_f/k, τ_f the
  written torque through a first-order low-pass of time constant ``filter_s`` that starts at the first
  row (a plan: :data:`PLAN_SAG_FILTER_S`; a walk, whose torques are continuous: none), k the robot
  YAML's stiffness times :data:`PLAN_SAG_STIFFNESS_SCALE` for a plan (the sag of the stiffest servo
  within ±25 %, so that no leg stands taller than planned), times 1 for a walk;
* a fan of first-order lag τ_fan is sent F + τ_fan·dF/dt, dF/dt by central differences between the
  rows around (one-sided at the ends), within [0, F_max].

The low-pass is evaluated in its closed form, the sum of the torques weighted by the filter's impulse
response, block by block (the planner steps its own loop); the differences are written out (the planner
calls ``numpy.gradient``). Units SI.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["PLAN_SAG_FILTER_S", "PLAN_SAG_STIFFNESS_SCALE", "WALK_SAG_FILTER_S", "fan_commands", "low_pass",
           "servo_commands"]

#: a plan's sag compensation is low-passed with this time constant [s]
PLAN_SAG_FILTER_S = 0.2
#: a walk's is not filtered [s]
WALK_SAG_FILTER_S = 0.0
#: a plan's commands undo the sag of servos this many times the robot YAML's stiffness
PLAN_SAG_STIFFNESS_SCALE = 1.25
#: rows per block of :func:`low_pass`'s closed form (r^B stays far from underflow for any α)
_BLOCK_ROWS = 256


def servo_commands(q_rad: np.ndarray, tau_nm: np.ndarray, stiffness_nm_per_rad: np.ndarray, rate_hz: float,
                   filter_s: float) -> np.ndarray:
    """(N, J) [rad]: the rows ``q_rad`` (N, J) plus the sag of servos of ``stiffness_nm_per_rad`` (J,) under
    the torques ``tau_nm`` (N, J) low-passed by y_i = y_{i−1} + α·(τ_i − y_{i−1}), y_0 = τ_0,
    α = 1 − exp(−1/(rate·filter_s)) (α = 1 without a filter)."""
    tau = np.asarray(tau_nm, dtype=float)
    if filter_s > 0 and len(tau):
        tau = low_pass(tau, 1.0 - math.exp(-1.0 / (rate_hz * filter_s)))
    return np.asarray(q_rad, dtype=float) + tau / np.asarray(stiffness_nm_per_rad, dtype=float)


def low_pass(x: np.ndarray, alpha: float, block: int = _BLOCK_ROWS) -> np.ndarray:
    """(N, …): y_i = r·y_{i−1} + α·x_i with r = 1 − α and y_{−1} = x_0 (so that y_0 = x_0), in closed form:
    over a block of rows s … s+B−1, y_{s+j} = r^{j+1}·y_{s−1} + α·Σ_{k≤j} r^{j−k}·x_{s+k}, the sum as the
    product with the lower-triangular matrix of the impulse response r^{j−k}."""
    x = np.asarray(x, dtype=float)
    r = 1.0 - alpha
    lag = np.arange(block)[:, None] - np.arange(block)[None, :]
    response = np.where(lag >= 0, r ** np.maximum(lag, 0), 0.0)
    decay = r ** np.arange(1, block + 1)
    y = np.empty_like(x)
    before = x[0]
    for s in range(0, len(x), block):
        n = min(block, len(x) - s)
        y[s:s + n] = (np.multiply.outer(decay[:n], before)
                      + alpha * np.tensordot(response[:n, :n], x[s:s + n], axes=1))
        before = y[s + n - 1]
    return y


def fan_commands(thrust_n: np.ndarray, rate_hz: float, lag_s: np.ndarray, max_n: np.ndarray) -> np.ndarray:
    """(N, F) [N]: the thrusts ``thrust_n`` (N, F) led by each fan's lag ``lag_s`` (F,) [s], F + τ·dF/dt, within
    [0, ``max_n``] (F,); rows ``rate_hz`` apart. One row is sent as it is."""
    f = np.asarray(thrust_n, dtype=float)
    if len(f) < 2:
        return f.copy()
    dt = 1.0 / rate_hz
    rate = np.empty_like(f)
    rate[0] = (f[1] - f[0]) / dt
    rate[-1] = (f[-1] - f[-2]) / dt
    rate[1:-1] = (f[2:] - f[:-2]) / (2.0 * dt)
    return np.minimum(np.maximum(f + np.asarray(lag_s, dtype=float) * rate, 0.0), np.asarray(max_n, dtype=float))
