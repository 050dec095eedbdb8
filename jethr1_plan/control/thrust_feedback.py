"""The thrust feedback law every plan exports: the planned thrust, corrected from the measured centre
of pressure (CoP) when it comes near an edge of the support sole.

A fan's thrust F moves the ZMP away from the fan's ground point P (A-1, A-2): with the CoM c and the
weight W, z = (W·c − F·P)/(W − F), so dz/dF = W·(c − P)/(W − F)², along u = (z − P)/‖z − P‖. The
CoP is the signal and the thrust the input of a one-dimensional loop; the sole's edges say which
way is safe. The law, at ``rate_hz`` in single support (double support: the planned thrust alone):

    u     = (CoP − P)/‖CoP − P‖                                   the way more thrust moves the CoP
    μ_k   = b_k − n_k·CoP,  g_k = n_k·u                           the CoP's margin to edge k [m]
    e     = 0 while min_k μ_k ≥ m; else the shortest move s along u with min_k(μ_k − s·g_k) ≥ m,
            or where none exists the s that maximises min_k(μ_k − s·g_k)           [m]
    I     ← I + e·dt   (while the command is not saturated against e);
            I ← I·(1 − dt/τ_leak) while e = 0
    F_cmd = clip(F_plan + k_p·e + k_i·I,  0,  F_top)

with F_plan from the plan's row, m the band margin and F_top the thrust the fans are given (the
plan's ``thrust_max_n``, each fan's own limit). The error is signed by the nearest edge the CoP is
about to cross: more thrust when the edge lies on the fan's side, less when beyond, and at a
corner the compromise between both (the edges the thrust cannot help are weighed with those it can).
Inside the band (every edge at least m away) the planned thrust is left alone: the plan is robust
there, and a loop that chased the planned ZMP would fight the servos' sag instead (it drives the thrust
below the plan as the swing leg moves out: docs/rehearsal.md). The integral removes a steady
error (a weak fan, a heavier robot) and leaks away once the CoP is back inside the band.

Why the error and the saturation are these (docs/rehearsal.md measures both on the twin): a law that
reads the CoP only along the fixed ray from the fan through the planned ZMP asks for more thrust where
more thrust moves the CoP towards another edge (at a corner), and one clipped to the row's thrust
window widened by the plan's tolerance holds a minimal plan (tolerance 0) at the planner's own bound
while the fan has thrust left: hence the nearest edge's signed error, the corner's compromise and F_top.

Signals a robot of this kind has: the CoP of the soles (force-sensing resistors under each sole, or
an ankle force-torque sensor; in double support the CoP of both), the fan's position from the joint
encoders, and the plan's columns ``thrust_*``. Gains are the robot's (its YAML's ``controller:``),
tuned on the twin (``bench/tune_controller.py``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from jethr1_plan.geometry import halfplanes

__all__ = ["Gains", "ThrustFeedback", "edge_error", "law", "step"]


@dataclass(frozen=True)
class Gains:
    """The law's settings (SI units)."""

    rate_hz: float = 500.0  # loop rate [Hz]
    band_margin_m: float = 0.02  # m: how close to any edge of the sole the CoP may come [m]
    kp_n_per_m: float = 600.0  # proportional gain [N/m]
    ki_n_per_m_s: float = 3000.0  # integral gain [N/(m·s)]
    leak_time_s: float = 0.3  # the integral's decay time inside the band [s]

    @classmethod
    def of(cls, robot) -> Gains:
        """The robot YAML's ``controller:`` settings over the defaults."""
        return cls(**robot.controller.given())


def law(gains: Gains, thrust_error: float, mass_error: float, thrust_max_n: float) -> dict:
    """The law as ``summary.json`` states it: its signals, gains and saturation, with units.
    ``thrust_error``, ``mass_error``: the plan's tolerance (what the plan alone absorbs; the law's
    saturation does not depend on it)."""
    return {
        "kind": "cop_edge_pi",
        "signal": "centre of pressure of the soles in contact, world x y [m]",
        "reference": "the support sole's edges; the direction from the fan's ground point through the CoP",
        "feed_forward": "the row's thrust_cmd_left_n / thrust_cmd_right_n (the planned thrust led by the fans' "
                        "lag) and <joint>_cmd_rad (the posture plus the servos' sag under the row's static torque); "
                        "the thrust the law adds, ΔF, moves the swing leg's commands by J_fanᵀ·ΔF / stiffness",
        "gains": asdict(gains),
        "saturation": {"lower": "0", "upper": f"min({thrust_max_n:g}, each carrying fan's thrust_max_n / its share)"},
        "plan_tolerance": {"thrust_error": thrust_error, "mass_error": mass_error},
        "active": "single support; in double support the planned thrust alone",
        "description": __doc__.split("\n\n")[1].strip(),
    }


def edge_error(cop_xy: np.ndarray, fan_xy: np.ndarray, polygon: np.ndarray, margin_m: float) -> float:
    """e [m] of the law: how far the CoP must move along u = (CoP − fan)/‖CoP − fan‖ (the way more
    thrust moves it) to come at least ``margin_m`` inside every edge of the convex CCW ``polygon``;
    positive: more thrust, negative: less, 0 while it is that far inside already. Where no point of
    the line is that far inside, the move to the point of the line farthest inside the polygon."""
    cop = np.asarray(cop_xy, dtype=float)
    u = cop - np.asarray(fan_xy, dtype=float)
    norm = math.hypot(float(u[0]), float(u[1]))
    if norm < 1e-9:
        return 0.0
    u = u / norm
    n, b = halfplanes(np.asarray(polygon, dtype=float))
    mu = b - n @ cop  # margins now [m]
    if float(mu.min()) >= margin_m:
        return 0.0
    g = n @ u  # each margin shrinks by g_k per metre moved along u
    lo, hi = -math.inf, math.inf  # moves s that keep every margin ≥ margin_m
    for k in range(len(b)):
        slack = float(mu[k]) - margin_m
        if g[k] > 1e-12:
            hi = min(hi, slack / g[k])
        elif g[k] < -1e-12:
            lo = max(lo, slack / g[k])
        elif slack < 0:
            lo, hi = math.inf, -math.inf
    if lo <= hi:
        return lo if lo > 0 else (hi if hi < 0 else 0.0)
    # the band is not reachable along u: the move that maximises the least margin (a concave
    # piecewise-linear function of s; its maximum lies where an edge it gains on meets one it loses to)
    cands = [(float(mu[i] - mu[j]) / float(g[i] - g[j])) for i in range(len(b)) for j in range(len(b))
             if g[i] > 1e-12 and g[j] < -1e-12]
    if not cands:
        return 0.0
    return max(cands, key=lambda s: (float((mu - s * g).min()), -abs(s)))


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


class ThrustFeedback:
    """The law with its state (the integral), as a robot's loop runs it: :meth:`reset` at the start,
    :meth:`step` every tick of single support, :meth:`idle` every tick of double support."""

    def __init__(self, gains: Gains) -> None:
        self.gains = gains
        self.integral = 0.0  # ∫e dt [m·s]
        self.last_error_m = 0.0

    def reset(self) -> None:
        self.integral, self.last_error_m = 0.0, 0.0

    def idle(self) -> None:
        """A tick without the law (double support): the integral leaks away."""
        _, self.integral = step(self.gains, self.integral, 0.0, 0.0, 0.0, 0.0)
        self.last_error_m = 0.0

    def step(self, cop_xy: np.ndarray, fan_xy: np.ndarray, polygon: np.ndarray, thrust_plan_n: float,
             upper_n: float, lower_n: float = 0.0) -> float:
        """The total thrust command [N] of the fans that carry it, from the measured CoP, their
        thrust-weighted ground point ``fan_xy`` [m] and the support sole ``polygon``."""
        e = edge_error(cop_xy, fan_xy, polygon, self.gains.band_margin_m)
        self.last_error_m = e
        out, self.integral = step(self.gains, self.integral, e, thrust_plan_n, lower_n, upper_n)
        return out
