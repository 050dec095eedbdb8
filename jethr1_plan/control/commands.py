"""What to send to the robot: servo and fan commands that realise the planned posture and thrust.

The plan's joint columns are the posture the robot should reach; a position servo reaches it only if
it is stiff. Servos of stiffness k sag by τ/k under a torque τ, and fans follow their command with
a first-order lag. The commands undo both, from the plan's own rows:

* servos: q_cmd = q + τ_f/k, with τ the row's static torque (``statics``: gravity, thrust, support
  reaction), τ_f τ through a first-order low-pass of ``SAG_FILTER_S`` (it smooths the commands where
  the torques change fast: a transfer moves the load from one sole to the other with the ZMP,
  ``physics.statics``), and k the stiffness the caller gives: each joint's from the robot YAML
  (``servos.stiffness_nm_per_rad`` × servos × gear²), a plan's scaled to the stiffest servo within
  ±25 % (``planning.plan.SAG_STIFFNESS_SCALE``);
* fans: F_cmd = F + τ_fan·dF/dt (the lag's inverse; dF/dt by central differences), within
  [0, F_max], τ_fan the fan's ``lag_s``.

Pure functions over arrays; units SI.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["SAG_FILTER_S", "fan_commands", "low_pass", "servo_commands"]

SAG_FILTER_S = 0.2  # time constant of the low-pass on the sag compensation [s]


def low_pass(x: np.ndarray, rate_hz: float, tau_s: float) -> np.ndarray:
    """First-order low-pass of rows ``x`` (N, ...) sampled at ``rate_hz``, starting at x[0]."""
    alpha = 1.0 - math.exp(-1.0 / (rate_hz * tau_s)) if tau_s > 0 else 1.0
    out = np.empty_like(np.asarray(x, dtype=float))
    out[0] = x[0]
    for i in range(1, len(out)):
        out[i] = out[i - 1] + alpha * (x[i] - out[i - 1])
    return out


def servo_commands(q: np.ndarray, tau_nm: np.ndarray, stiffness_nm_per_rad: np.ndarray, rate_hz: float,
                   filter_s: float = SAG_FILTER_S) -> np.ndarray:
    """Servo commands (N, J) [rad] that hold posture ``q`` (N, J) [rad] against the sag of servos of
    ``stiffness_nm_per_rad`` (J,) under the static torques ``tau_nm`` (N, J)."""
    return np.asarray(q, dtype=float) + low_pass(tau_nm, rate_hz, filter_s) / np.asarray(stiffness_nm_per_rad)


def fan_commands(thrust_n: np.ndarray, rate_hz: float, lag_s: np.ndarray, max_n: np.ndarray) -> np.ndarray:
    """Fan commands (N, F) [N] that make fans with a first-order lag ``lag_s`` (F,) [s] give the planned
    thrust ``thrust_n`` (N, F) [N] at rows ``rate_hz`` apart, within [0, ``max_n``]."""
    thrust = np.asarray(thrust_n, dtype=float)
    if len(thrust) < 2:
        return thrust.copy()
    rate = np.gradient(thrust, 1.0 / rate_hz, axis=0)
    return np.clip(thrust + np.asarray(lag_s) * rate, 0.0, np.asarray(max_n))
