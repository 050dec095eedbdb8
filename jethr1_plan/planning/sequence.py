"""Sequences: optimised swing samples and double-support transfers, resampled at the output rate.

Every output row is a real posture: P_body and the body yaw are interpolated, the legs are solved
by IK, and the thrust and ZMP are recomputed exactly from the resulting CoM. Rows that break a
constraint are marked infeasible with their reason; nothing is patched.

* Swing rows: the swing sole moves along the sampled path with a minimum-jerk time law; P_body
  is interpolated linearly between the optimised samples; the thrust is the least thrust of the
  swing fan that balances within the scenario's tolerance (``balance.thrust_window``; the exact
  minimal thrust of (A-5) under the ``minimal`` policy).
* Transfer rows (both feet down): P_body and yaw follow a minimum-jerk blend between the two
  postures; the previous swing fan's thrust ramps to zero over the first half and the next one
  ramps up over the second half; the ZMP of (A-1, A-2) must lie in the convex hull of both soles,
  under every error within the tolerance.

Every row also carries the thrust window of its posture (the nominal balancing interval of the
fan that carries it, capped by the fan's maximum) and the ZMP's margin: its distance to the
nearest edge of the real sole (the hull of both soles in double support).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from jethr1_plan.kinematics import PostureSolver, Stance
from jethr1_plan.physics.balance import (
    NOMINAL,
    Tolerance,
    balance_slack,
    edge_angle_excess,
    polygon_margin,
    sole_polygon,
    thrust_window,
    wrap_angle,
    zmp_with_thrust,
)
from jethr1_plan.reasons import Reason, message
from jethr1_plan.robot.model import GRAVITY, RobotModel

__all__ = ["Rows", "SequenceBuilder", "convex_hull", "min_jerk", "swing_row_positions"]


def min_jerk(t: np.ndarray) -> np.ndarray:
    """Minimum-jerk time law s(t) = 10t³ − 15t⁴ + 6t⁵ on [0, 1]."""
    t = np.clip(t, 0.0, 1.0)
    return t**3 * (10 - 15 * t + 6 * t * t)


def swing_row_positions(samples: int, duration_s: float, rate_hz: float) -> np.ndarray:
    """Where the rows of a swing fall along its path: (rows,) fractional sample indices in [0, N − 1],
    row k at min_jerk(k / n) · (N − 1) with n = round(duration · rate) rows (the landing sample itself
    starts the next transfer)."""
    n = max(1, round(duration_s * rate_hz))
    return min_jerk(np.arange(n) / n) * (samples - 1)


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull (K, 2) of 2-D points (monotone chain)."""
    pts = np.unique(np.round(points, 12), axis=0)
    pts = pts[np.lexsort((pts[:, 1], pts[:, 0]))]

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in pts[::-1]:
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])


@dataclass
class Rows:
    """Output rows (column arrays). Lengths grow as rows are appended."""

    columns: dict[str, list] = field(default_factory=dict)
    analysis: dict = field(default_factory=dict)  # whole-trajectory figures (energy, torque ratios)

    def append(self, **values) -> None:
        for k, v in values.items():
            self.columns.setdefault(k, []).append(v)

    def __len__(self) -> int:
        return len(next(iter(self.columns.values()), []))

    def array(self, key: str) -> np.ndarray:
        return np.asarray(self.columns[key])


class SequenceBuilder:
    """Builds output rows for one plan with one PostureSolver (warm-started row to row)."""

    def __init__(self, robot: RobotModel, solver: PostureSolver, rate_hz: float, thrust_max_n: float,
                 rho_rad: float, sole_margin_m: float, tolerance: Tolerance = NOMINAL):
        self.robot, self.solver = robot, solver
        self.dt = 1.0 / rate_hz
        self.thrust_max_n, self.rho_rad, self.margin = thrust_max_n, rho_rad, sole_margin_m
        self.tolerance = tolerance
        self.rows = Rows()
        self.t = 0.0
        self.q_prev: np.ndarray | None = None
        self.first_infeasible: dict | None = None
        #: when set, the body yaw of row i (a smoothed schedule, e.g. the yaw MPC) instead of the blends
        self.yaw_of_row = None

    def _sole(self, xyz: np.ndarray, margin_m: float = 0.0) -> np.ndarray:
        return sole_polygon(xyz[:2], 0.0, self.robot.sole_length_m, self.robot.sole_width_m, margin_m)

    def _window(self, com_xy: np.ndarray, fan_xy: np.ndarray, polygon: np.ndarray, side: str) -> tuple[float, float]:
        """The nominal balancing interval [N] of the ``side`` fan, capped by the fan's maximum (the
        scenario's limit is a constraint on the plan, not on the window) (NaN, NaN: none)."""
        lo, hi = thrust_window(com_xy, fan_xy, polygon, self.robot.mass_kg)
        lo, hi = float(lo), float(min(hi, self.robot.fan_for(side).max_thrust_n))
        return (lo, hi) if lo <= hi else (np.nan, np.nan)

    def _describe_tolerance(self) -> str:
        t = self.tolerance
        if t == NOMINAL:
            return ""
        return (f" within ±{100 * t.thrust:g} % thrust, ±{100 * t.mass:g} % mass and "
                f"{1000 * t.com_m:g} mm of CoM error")

    def _fan_xy(self, side: str, sole_xyz: np.ndarray) -> np.ndarray:
        return sole_xyz[:2] + np.asarray(self.robot.fan_for(side).offset_in_foot_m[:2])

    def _solve(self, stance: Stance, p_body: np.ndarray):
        batch = self.solver.solve_batch(stance, p_body[None], warm=self.q_prev)
        if batch.status[0] == Reason.OK:
            self.q_prev = batch.q[0]
        return batch.q[0], batch.com[0], int(batch.status[0])

    def _mark(self, step: int, phase: str, sample: int, reason: str, detail: dict) -> None:
        if self.first_infeasible is None:
            self.first_infeasible = {"time_s": self.t, "step": step, "phase": phase, "sample": sample,
                                     "reason": reason, **detail}

    def _emit(self, **row) -> None:
        self.rows.append(time_s=self.t, **row)
        self.t += self.dt

    def transfer(self, step: int, feet: dict[str, np.ndarray], p0: np.ndarray, yaw0: float, p1: np.ndarray,
                 yaw1: float, duration_s: float, thrust_out: tuple[str, float] | None,
                 thrust_in: tuple[str, float] | None, include_end: bool = False) -> None:
        """Double-support rows from (p0, yaw0) to (p1, yaw1), both soles on ``feet``.

        ``thrust_out``/``thrust_in``: (fan side, thrust [N]) ramped down over the first half and up
        over the second half. The end posture itself is written only with ``include_end``.
        """
        n = max(1, round(duration_s / self.dt))
        hull = convex_hull(np.vstack([self._sole(feet[s], self.margin) for s in ("left", "right")]))
        real_hull = convex_hull(np.vstack([self._sole(feet[s]) for s in ("left", "right")]))
        dyaw = float(wrap_angle(yaw1 - yaw0))
        w = self.robot.mass_kg * GRAVITY
        fans = {sd: self._fan_xy(sd, feet[sd]) for sd in ("left", "right")}
        for k in range(n + 1 if include_end else n):
            u = k / n
            s = float(min_jerk(u))
            p = p0 + s * (p1 - p0)
            yaw = float(wrap_angle(yaw0 + s * dyaw)) if self.yaw_of_row is None else self.yaw_of_row(len(self.rows))
            stance = Stance("right", feet["right"], 0.0, feet["left"], 0.0, yaw)
            q, com, status = self._solve(stance, p)
            thrust = {"left": 0.0, "right": 0.0}
            if thrust_out is not None:
                thrust[thrust_out[0]] += thrust_out[1] * max(0.0, 1.0 - 2.0 * u)
            if thrust_in is not None:
                thrust[thrust_in[0]] += thrust_in[1] * max(0.0, 2.0 * u - 1.0)
            thrust = {sd: (f if np.isfinite(f) else 0.0) for sd, f in thrust.items()}
            total = thrust["left"] + thrust["right"]
            moment = sum(thrust[sd] * fans[sd] for sd in ("left", "right"))
            zmp = (w * com[:2] - moment) / (w - total)
            # the window of the fan that carries (or is about to carry) the thrust
            active = max(thrust, key=thrust.get) if total > 0 else (
                thrust_in[0] if thrust_in is not None else (thrust_out[0] if thrust_out is not None else None))
            window = self._window(com[:2], fans[active], real_hull, active) if active else (np.nan, np.nan)
            slack = float(balance_slack(com[:2], np.stack([fans["left"], fans["right"]]),
                                        np.array([thrust["left"], thrust["right"]]), hull, self.robot.mass_kg,
                                        self.tolerance))
            reason = None
            if status != Reason.OK:
                reason = message(status)
            elif max(thrust.values()) > self.thrust_max_n:
                reason = f"thrust {max(thrust.values()):.3f} N above its maximum {self.thrust_max_n} N"
            elif slack < -1e-9:
                reason = "ZMP outside the hull of both soles" + self._describe_tolerance()
            if reason:
                self._mark(step, "transfer", k, reason, {"p_body_m": p.tolist()})
            self._emit(step=step, phase="transfer", sample=k, support="both", feasible=reason is None,
                       ground_z=min(feet["left"][2], feet["right"][2]),
                       p_body=p, yaw=yaw, q=q, swing=np.full(3, np.nan), thrust_left=thrust["left"],
                       thrust_right=thrust["right"], com=com, zmp=zmp, window=window,
                       zmp_margin=float(polygon_margin(zmp, real_hull)), reason=reason or "")

    def swing(self, step: int, support: str, feet: dict[str, np.ndarray], path: np.ndarray, p_samples: np.ndarray,
              yaw_fn, duration_s: float) -> None:
        """Single-support rows along ``path`` (N, 3) with optimised P_body ``p_samples`` (N, 3).

        ``yaw_fn(swing_xyz) -> body yaw [rad]`` gives the trunk yaw at any swing position.
        """
        swing_side = "left" if support == "right" else "right"
        poly = self._sole(feet[support], self.margin)
        sole = self._sole(feet[support])
        idx = np.arange(len(path))
        for k, u in enumerate(swing_row_positions(len(path), duration_s, 1.0 / self.dt)):
            swing = np.array([np.interp(u, idx, path[:, j]) for j in range(3)])
            p = np.array([np.interp(u, idx, p_samples[:, j]) for j in range(3)])
            yaw = float(yaw_fn(swing)) if self.yaw_of_row is None else self.yaw_of_row(len(self.rows))
            stance = Stance(support, feet[support], 0.0, swing, 0.0, yaw)
            q, com, status = self._solve(stance, p)
            fan = self._fan_xy(swing_side, swing)
            thrust = float(thrust_window(com[:2], fan, poly, self.robot.mass_kg, self.tolerance)[0])
            edge = float(edge_angle_excess(feet[support][:2], com[:2], swing[:2], self.rho_rad))
            reason = None
            if status != Reason.OK:
                reason = message(status)
            elif not np.isfinite(thrust):
                reason = "no thrust can balance" + self._describe_tolerance()
            elif thrust > self.thrust_max_n:
                reason = f"thrust {thrust:.3f} N above its maximum {self.thrust_max_n} N" + self._describe_tolerance()
            elif edge > 0:
                reason = f"edge angle {np.degrees(edge + self.rho_rad):.2f} deg above rho"
            if reason:
                self._mark(step, "swing", k, reason, {"p_body_m": p.tolist(), "swing_m": swing.tolist()})
            f = thrust if np.isfinite(thrust) else 0.0
            zmp = zmp_with_thrust(com[:2], fan, f, self.robot.mass_kg)
            self._emit(step=step, phase="swing", sample=k, support=support, feasible=reason is None, p_body=p,
                       ground_z=feet[support][2],
                       yaw=yaw, q=q, swing=swing, thrust_left=f if swing_side == "left" else 0.0,
                       thrust_right=f if swing_side == "right" else 0.0, com=com, zmp=zmp,
                       window=self._window(com[:2], fan, sole, swing_side),
                       zmp_margin=float(polygon_margin(zmp, sole)),
                       reason=reason or "")
