"""The thrust feedback law every plan exports: the planned thrust, corrected from the measured centre
of pressure (CoP) when it comes near the edge of the support sole.

The thrust moves the ZMP along one ray: away from the fan, through the CoM (A-1, A-2). Along that
ray the support sole spans [s_in, s_out] (s_in on the fan's side). More thrust moves the CoP towards
s_out, less towards s_in; so the CoP is the signal and the thrust the input of a one-dimensional
loop. The law, at ``rate_hz`` in single support (double support: the planned thrust alone):

    s     = u·(CoP − ZMP_ref),  u = (ZMP_ref − P_fan)/‖ZMP_ref − P_fan‖     where the CoP is [m]
    e     = max((s_in + m) − s, 0) − max(s − (s_out − m), 0)                the band's violation [m]
    I     ← I + e·dt   (while the command is not saturated against e);
            I ← I·(1 − dt/τ_leak) while e = 0
    F_cmd = clip(F_plan + k_p·e + k_i·I,  F_lo·(1 − Y)/(1 + X),  min(F_max, F_hi·(1 + Y)/(1 − X)))

with ZMP_ref, F_plan and the window [F_lo, F_hi] from the plan's row, m the band margin, and X, Y the
plan's thrust and mass tolerance: the command never leaves the window any model within the plan's
tolerance could need. Inside the band (the CoP at least m from both ends) the planned thrust is
left alone: the plan is robust there, and a loop that chased the planned ZMP would fight the servos'
sag instead (measured on the twin: it drove the thrust below the plan as the swing leg moved out).
The integral removes a steady error (a weak fan, a heavier robot) and leaks away once the CoP is
back inside the band, so it does not hold the thrust off the plan afterwards.

Signals a robot of this kind has: the CoP of the soles (force-sensing resistors under each sole, or
an ankle force-torque sensor; in double support the CoP of both), the fan's position from the joint
encoders, and the plan's columns ``zmp_*``, ``thrust_*``, ``thrust_window_*``. Gains are the robot's
(its YAML's ``controller:``), tuned on the twin (``bench/tune_controller.py``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from jethr1_plan.geometry import halfplanes

__all__ = ["Gains", "band_error", "law", "ray_extent", "step"]


@dataclass(frozen=True)
class Gains:
    """The law's settings (SI units)."""

    rate_hz: float = 500.0  # loop rate [Hz]
    band_margin_m: float = 0.01  # m: how close to the sole's edge (along the ray) the CoP may come [m]
    kp_n_per_m: float = 600.0  # proportional gain [N/m]
    ki_n_per_m_s: float = 3000.0  # integral gain [N/(m·s)]
    leak_time_s: float = 0.3  # the integral's decay time inside the band [s]

    @classmethod
    def of(cls, robot) -> Gains:
        """The robot YAML's ``controller:`` settings over the defaults."""
        return cls(**robot.controller.given())


def law(gains: Gains, thrust_error: float, mass_error: float, thrust_max_n: float) -> dict:
    """The law as ``summary.json`` states it: its signals, gains and saturation, with units."""
    return {
        "kind": "cop_band_pi",
        "signal": "centre of pressure of the soles in contact, world x y [m]",
        "reference": "the row's zmp_x_m, zmp_y_m; the ray from the fan's ground point through it",
        "feed_forward": "the row's thrust_cmd_left_n / thrust_cmd_right_n (the planned thrust led by the fans' "
                        "lag) and <joint>_cmd_rad (the posture plus the servos' sag under the row's static torque); "
                        "the thrust the law adds, ΔF, moves the swing leg's commands by J_fanᵀ·ΔF / stiffness",
        "gains": asdict(gains),
        "saturation": {"lower": f"thrust_window_lo_n * {1 - mass_error:g} / {1 + thrust_error:g}",
                       "upper": f"min({thrust_max_n:g}, thrust_window_hi_n * {1 + mass_error:g} / "
                                f"{1 - thrust_error:g})"},
        "active": "single support; in double support the planned thrust alone",
        "description": __doc__.split("\n\n")[2].strip(),
    }


def ray_extent(z_xy: np.ndarray, u: np.ndarray, polygon: np.ndarray) -> tuple[float, float]:
    """(s_in, s_out) [m]: the line z + s·u crosses the convex CCW ``polygon`` for s in that interval
    (s_in > s_out where it misses)."""
    n, b = halfplanes(polygon)
    nu = n @ u
    slack = b - n @ z_xy
    lo, hi = -math.inf, math.inf
    for k in range(len(b)):
        if nu[k] > 1e-15:
            hi = min(hi, slack[k] / nu[k])
        elif nu[k] < -1e-15:
            lo = max(lo, slack[k] / nu[k])
        elif slack[k] < 0:
            return math.inf, -math.inf
    return lo, hi


def band_error(cop_xy: np.ndarray, zmp_ref_xy: np.ndarray, fan_xy: np.ndarray, polygon: np.ndarray,
               margin_m: float) -> float:
    """e [m] of the law: how far the CoP lies outside the band [s_in + m, s_out − m] along the thrust
    ray, positive on the fan's side (more thrust needed), negative beyond the far side (less)."""
    u = np.asarray(zmp_ref_xy, dtype=float) - np.asarray(fan_xy, dtype=float)
    norm = float(np.hypot(u[0], u[1]))
    if norm < 1e-9:
        return 0.0
    u = u / norm
    s_in, s_out = ray_extent(np.asarray(zmp_ref_xy, dtype=float), u, polygon)
    if s_in > s_out:
        return 0.0
    lo, hi = s_in + margin_m, s_out - margin_m
    if lo > hi:  # a sole too short along the ray for both margins: its middle
        lo = hi = 0.5 * (s_in + s_out)
    s = float(u @ (np.asarray(cop_xy, dtype=float) - zmp_ref_xy))
    return max(lo - s, 0.0) - max(s - hi, 0.0)


def step(gains: Gains, integral: float, e: float, thrust_plan_n: float, lower_n: float, upper_n: float
         ) -> tuple[float, float]:
    """One tick of the law: (thrust command [N], the new integral [m·s])."""
    dt = 1.0 / gains.rate_hz
    if e == 0.0:
        integral *= max(0.0, 1.0 - dt / gains.leak_time_s) if gains.leak_time_s > 0 else 0.0
    raw = thrust_plan_n + gains.kp_n_per_m * e + gains.ki_n_per_m_s * integral
    out = min(max(raw, lower_n), upper_n)
    if e != 0.0 and (out == raw or (raw > upper_n and e < 0) or (raw < lower_n and e > 0)):
        integral += e * dt  # anti-windup: no integration against a saturated command
    return out, integral
