"""The command columns as ``verify`` recomputes them from written rows, restated from docs/rehearsal.md ("what to
send", the ``_cmd`` columns of docs/contract.md) and not from the planner's code (``control/commands.py``):

* a position servo of stiffness k sags by τ/k under a torque τ, so it is sent q + τ_f/k, τ_f the
  written torque through a first-order low-pass of time constant ``filter_s`` that starts at the first
  row (a plan: :data:`PLAN_SAG_FILTER_S`; a walk, whose torques are continuous: none), k the robot
  YAML's stiffness times :data:`PLAN_SAG_STIFFNESS_SCALE` for a plan (the sag of the stiffest servo
  within ±25 %, so that no leg stands taller than planned), times 1 for a walk;
* a fan of first-order lag τ_fan is sent F + τ_fan·dF/dt, dF/dt by central differences between the
  rows around (one-sided at the ends), within [0, F_max].

The low-pass is run by SciPy's ``lfilter`` (the planner steps its own loop), the differences written
out (the planner calls ``numpy.gradient``). Units SI.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["PLAN_SAG_FILTER_S", "PLAN_SAG_STIFFNESS_SCALE", "WALK_SAG_FILTER_S", "fan_commands", "servo_commands"]

#: a plan's sag compensation is low-passed with this time constant [s]
PLAN_SAG_FILTER_S = 0.2
#: a walk's is not filtered [s]
WALK_SAG_FILTER_S = 0.0
#: a plan's commands undo the sag of servos this many times the robot YAML's stiffness
PLAN_SAG_STIFFNESS_SCALE = 1.25


def servo_commands(q_rad: np.ndarray, tau_nm: np.ndarray, stiffness_nm_per_rad: np.ndarray, rate_hz: float,
                   filter_s: float) -> np.ndarray:
    """(N, J) [rad]: the rows ``q_rad`` (N, J) plus the sag of servos of ``stiffness_nm_per_rad`` (J,) under
    the torques ``tau_nm`` (N, J) low-passed by y_i = y_{i−1} + α·(τ_i − y_{i−1}), y_0 = τ_0,
    α = 1 − exp(−1/(rate·filter_s)) (α = 1 without a filter)."""
    from scipy.signal import lfilter

    tau = np.asarray(tau_nm, dtype=float)
    if filter_s > 0 and len(tau):
        alpha = 1.0 - math.exp(-1.0 / (rate_hz * filter_s))
        # y_i − (1 − α)·y_{i−1} = α·τ_i, with the state that makes y_0 = τ_0
        tau, _ = lfilter([alpha], [1.0, alpha - 1.0], tau, axis=0, zi=(1.0 - alpha) * tau[:1])
    return np.asarray(q_rad, dtype=float) + tau / np.asarray(stiffness_nm_per_rad, dtype=float)


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
