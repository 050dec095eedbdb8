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
fan that carries it, capped by the fan's maximum), the ZMP's margin: its distance to the
nearest edge of the real sole (the hull of both soles in double support), and, under the robust
policy, its tolerance share: the largest share of the scenario's tolerance under which the row's
posture and thrust keep the ZMP in the support (``physics.share.row_shares``).

Under the robust policy each swing sample holds a share of the tolerance (1 where a posture reaches
all of it; ``optimisers``): a swing row is held to the share interpolated between its samples, a
transfer to the smaller share of the swings at its two ends.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jethr1_plan.control.time_laws import min_jerk, swing_row_positions
from jethr1_plan.geometry import GRAVITY, SIDES, convex_hull, other_side, polygon_margin, sole_polygon, wrap_angle
from jethr1_plan.kinematics import PostureSolver, Stance
from jethr1_plan.physics.balance import (
    NOMINAL,
    Tolerance,
    balance_slack,
    edge_angle_excess,
    least_thrust,
    shared_window,
    thrust_window,
    zmp_with_thrust,
    zmp_with_thrusts,
)
from jethr1_plan.physics.share import row_shares
from jethr1_plan.reasons import Reason, message
from jethr1_plan.records.infeasible import Infeasible
from jethr1_plan.records.plan_rows import Rows
from jethr1_plan.robot.model import RobotModel, fan_ground_xy

__all__ = ["FanThrust", "SequenceBuilder"]


@dataclass(frozen=True)
class FanThrust:
    """Thrust per fan of the robot at one end of a swing [N], and the fans that swing uses
    (its sole's, then the trunk's: ``RobotModel.swing_fans``)."""

    values: np.ndarray  # (F,) [N], 0 for the fans not in use
    fans: tuple[int, ...]


class SequenceBuilder:
    """Builds output rows for one plan with one PostureSolver (warm-started row to row).

    Thrust is kept per fan of the robot (columns ``thrust_<fan name>``); fans that may not thrust
    in a phase carry 0.
    """

    def __init__(self, robot: RobotModel, solver: PostureSolver, rate_hz: float, thrust_max_n: float,
                 rho_rad: float, sole_margin_m: float, tolerance: Tolerance = NOMINAL):
        self.robot, self.solver = robot, solver
        self.dt = 1.0 / rate_hz
        self.thrust_max_n, self.rho_rad, self.margin = thrust_max_n, rho_rad, sole_margin_m
        self.tolerance = tolerance
        self.names = [f.name for f in robot.fans]
        self.rows = Rows(fans=tuple(self.names))
        self.t = 0.0
        self.q_prev: np.ndarray | None = None
        self.first_infeasible: Infeasible | None = None
        #: when set, the body yaw of row i (a smoothed schedule, e.g. the yaw MPC) instead of the blends
        self.yaw_of_row = None
        #: P_body through the swing samples by a monotone cubic (PCHIP: C¹, no overshoot between samples)
        #: instead of linearly (a fastest timing: the trunk's path has no corner at a sample for the rows to feel)
        self.smooth_trunk = False
        self.linear_segments: set[int] = set()  # segments (i → i + 1) kept linear where the smooth trunk fails
        #: a swing's rows end at its first infeasible row (the plan is refused there: the rows after it would be
        #: discarded; set by ``phases.Sequence`` when it stops at the first infeasible row)
        self.stop_at_infeasible = False
        self.caps = np.array([min(f.thrust_max_n, thrust_max_n) for f in robot.fans])  # per fan [N]

    def _sole(self, xyz: np.ndarray, margin_m: float = 0.0) -> np.ndarray:
        return sole_polygon(xyz[:2], 0.0, self.robot.sole_length_m, self.robot.sole_width_m, margin_m)

    def _window(self, com_xy: np.ndarray, fans_xy: np.ndarray, share: np.ndarray, polygon: np.ndarray
                ) -> tuple[float, float]:
        """The nominal balancing interval [N] of the total thrust split as ``share`` (F,) among the
        robot's fans at ``fans_xy`` (F, 2), capped where a fan reaches its maximum (the scenario's
        limit is a constraint on the plan, not on the window) (NaN, NaN: none)."""
        carry = np.flatnonzero(share > 0)
        if len(carry) == 1:  # one fan: its own window (Paper A)
            k = int(carry[0])
            w_lo, w_hi = thrust_window(com_xy, fans_xy[k], polygon, self.robot.mass_kg)
            lo, hi = float(w_lo), min(float(w_hi), self.robot.fans[k].thrust_max_n)
        else:
            w_lo, w_hi = shared_window(com_xy, fans_xy[carry], share[carry], polygon, self.robot.mass_kg)
            fmax = np.array([self.robot.fans[k].thrust_max_n for k in carry])
            lo, hi = float(w_lo), min(float(w_hi), float(np.min(fmax / share[carry])))
        return (lo, hi) if lo <= hi else (np.nan, np.nan)

    def _describe_tolerance(self, share: float = 1.0) -> str:
        t = self.tolerance.scaled(share)
        if self.tolerance == NOMINAL:
            return ""
        return (f" within ±{100 * t.thrust:g} % thrust, ±{100 * t.mass:g} % mass and "
                f"{1000 * t.com_m:g} mm of CoM error")

    def _fans_xy(self, soles: dict[str, np.ndarray], p_body: np.ndarray, yaw: float) -> np.ndarray:
        """(F, 2) every fan's ground point [m] with the soles and the trunk there."""
        return np.array([fan_ground_xy(f, soles, p_body, yaw) for f in self.robot.fans]).reshape(-1, 2)

    def _row_shares(self, com_xy: np.ndarray, fans_xy: np.ndarray, thrust: np.ndarray, region: np.ndarray
                    ) -> np.ndarray:
        """Each row's tolerance share (N,) (NaN under the minimal policy): CoM (N, 2) [m], fans (N, F, 2) [m],
        thrust (N, F) [N] on ``region`` (``physics.share.row_shares`` solves each row on its own: the same as
        row by row, to the bit)."""
        if self.tolerance == NOMINAL:
            return np.full(len(com_xy), np.nan)
        return row_shares(com_xy, fans_xy, thrust, region, self.robot.mass_kg, self.tolerance)

    def _emit_all(self, step: int, phase: str, pending: list[tuple], region: np.ndarray) -> None:
        """Write a phase's rows, each ``(sample, reason, P_body, swing or None, CoM, fans (F, 2), thrust (F,),
        the other columns)``, with their tolerance shares on ``region``; the infeasible ones marked."""
        if not pending:
            return
        shares = self._row_shares(np.array([r[4][:2] for r in pending]), np.array([r[5] for r in pending]),
                                  np.array([r[6] for r in pending]), region)
        for (k, reason, p, swing, _, _, thrust, row), share in zip(pending, shares, strict=True):
            if reason:
                self.mark(step, phase, k, reason, p.tolist(), None if swing is None else swing.tolist())
            self._emit(thrust, **row, tolerance_share=float(share), reason=reason or "")

    def _solve(self, stance: Stance, p_body: np.ndarray):
        batch = self.solver.solve_batch(stance, p_body[None], warm=self.q_prev)
        if batch.status[0] == Reason.OK:
            self.q_prev = batch.q[0]
        return batch.q[0], batch.com[0], int(batch.status[0])

    def _solve_rows(self, soles: dict[str, np.ndarray], p_body: np.ndarray, yaws: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Every row of a phase at once where the solver is the closed form: ``soles`` (side → (3,) or (N, 3)
        [m], both unturned), P_body (N, 3) [m] and the body yaws (N,) [rad] (each row is its own closed-form
        posture: the same as row by row, to the bit); None for an iterative solver (its warm start goes row
        to row)."""
        from jethr1_plan.kinematics.closed_form import ClosedFormPostureSolver, solve_postures

        if not isinstance(self.solver, ClosedFormPostureSolver) or not len(p_body):
            return None
        q, com, status = solve_postures(self.robot, p_body, yaws, {s: (soles[s], 0.0) for s in SIDES})
        com[status == Reason.UNREACHABLE] = np.nan
        self.solver.evaluations += len(p_body)
        ok = np.flatnonzero(status == Reason.OK)
        if len(ok):
            self.q_prev = q[ok[-1]]
        return q, com, status

    def _solve_swing(self, support: str, support_xyz: np.ndarray, swings: np.ndarray, p_body: np.ndarray,
                     yaws: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """:meth:`_solve_rows` of a swing: the support sole at ``support_xyz``, the swing sole at ``swings`` (N, 3)."""
        return self._solve_rows({support: support_xyz, other_side(support): swings}, p_body, yaws)

    def mark(self, step: int, phase: str, sample: int, reason: str, p_body_m=None, swing_m=None) -> None:
        """The row about to be written is infeasible: the first such row is kept (``first_infeasible``)."""
        if self.first_infeasible is None:
            self.first_infeasible = Infeasible(step, phase, sample, reason, self.t,
                                               None if p_body_m is None else tuple(p_body_m),
                                               None if swing_m is None else tuple(swing_m))

    def snapshot(self) -> tuple:
        """The builder's state (rows written, clock, warm start, first infeasible row), for :meth:`restore`."""
        return (len(self.rows), self.t, None if self.q_prev is None else self.q_prev.copy(), self.first_infeasible)

    def restore(self, snap: tuple) -> None:
        """Back to a :meth:`snapshot`: the rows written since are dropped."""
        n, self.t, q_prev, self.first_infeasible = snap
        self.q_prev = None if q_prev is None else q_prev.copy()
        self.rows.truncate(n)

    def _emit(self, thrust: np.ndarray, **row) -> None:
        self.rows.append(time_s=self.t, **row, thrust_n=np.array([float(f) for f in thrust]))
        self.t += self.dt

    def transfer(self, step: int, feet: dict[str, np.ndarray], p0: np.ndarray, yaw0: float, p1: np.ndarray,
                 yaw1: float, duration_s: float, thrust_out: FanThrust | None,
                 thrust_in: FanThrust | None, include_end: bool = False, share: float = 1.0,
                 positions: np.ndarray | None = None) -> None:
        """Double-support rows from (p0, yaw0) to (p1, yaw1), both soles on ``feet``.

        ``thrust_out``/``thrust_in``: the thrust per fan [N] of the swing before and after, ramped
        down over the first half and up over the second half. The end posture itself is written
        only with ``include_end``. ``share``: the share of the tolerance every row must hold.
        ``positions``: the rows' places s ∈ [0, 1] along the blend (a time-optimal law: one row each,
        the thrust ramped along s); default the minimum-jerk law over ``duration_s``, the thrust ramped
        in time.
        """
        tol = self.tolerance.scaled(share)
        n = max(1, round(duration_s / self.dt)) if positions is None else max(1, len(positions) - int(include_end))
        hull = convex_hull(np.vstack([self._sole(feet[s], self.margin) for s in ("left", "right")]))
        real_hull = convex_hull(np.vstack([self._sole(feet[s]) for s in ("left", "right")]))
        dyaw = float(wrap_angle(yaw1 - yaw0))
        w = self.robot.mass_kg * GRAVITY
        nf = len(self.names)
        zero = np.zeros(nf)
        out = zero if thrust_out is None else np.where(np.isfinite(thrust_out.values), thrust_out.values, 0.0)
        into = zero if thrust_in is None else np.where(np.isfinite(thrust_in.values), thrust_in.values, 0.0)
        # the shares of the fans about to carry thrust (or that just did) where none is carried
        coming = thrust_in if thrust_in is not None else thrust_out
        idle_share = None
        if coming is not None:
            v = into if thrust_in is not None else out
            idle_share = v / v.sum() if v.sum() > 0 else np.isin(np.arange(nf), coming.fans[:1]).astype(float)
        rows: list[tuple[float, np.ndarray, float]] = []  # (u, P_body, yaw) of each row
        for k in range(n + 1 if include_end else n):
            if positions is None:
                u = k / n
                s = float(min_jerk(u))
            else:
                u = s = float(positions[k])
            p = p0 + s * (p1 - p0)
            rows.append((u, p, float(wrap_angle(yaw0 + s * dyaw)) if self.yaw_of_row is None
                         else self.yaw_of_row(len(self.rows) + k)))
        solved = self._solve_rows(feet, np.array([p for _, p, _ in rows]), np.array([y for _, _, y in rows]))
        pending: list[tuple] = []  # the rows, written once their shares are known (_emit_all)
        for k, (u, p, yaw) in enumerate(rows):
            if solved is None:
                q, com, status = self._solve(Stance("right", feet["right"], 0.0, feet["left"], 0.0, yaw), p)
            else:
                q, com, status = solved[0][k], solved[1][k], int(solved[2][k])
            thrust = zero.copy()
            if thrust_out is not None:
                thrust += out * max(0.0, 1.0 - 2.0 * u)
            if thrust_in is not None:
                thrust += into * max(0.0, 2.0 * u - 1.0)
            fans = self._fans_xy(feet, p, yaw)
            total = float(np.sum(thrust))
            moment = sum(thrust[j] * fans[j] for j in range(nf))
            zmp = (w * com[:2] - moment) / (w - total)
            # the window of the fans that carry (or are about to carry) the thrust, in their shares
            fan_share = thrust / total if total > 0 else idle_share
            window = (self._window(com[:2], fans, fan_share, real_hull) if fan_share is not None
                      else (np.nan, np.nan))
            slack = float(balance_slack(com[:2], fans, thrust, hull, self.robot.mass_kg, tol))
            reason = None
            over = thrust > self.caps
            if status != Reason.OK:
                reason = message(status)
            elif over.any():
                j = int(np.argmax(thrust - self.caps))
                reason = f"thrust {thrust[j]:.3f} N of fan {self.names[j]} above its maximum {self.caps[j]:g} N"
            elif slack < -1e-9:
                reason = "ZMP outside the hull of both soles" + self._describe_tolerance(share)
            pending.append((k, reason, p, None, com, fans, thrust, dict(
                step=step, phase="transfer", sample=k, support="both", feasible=reason is None,
                ground_z_m=min(feet["left"][2], feet["right"][2]), p_body_m=p, yaw_rad=yaw, q_rad=q,
                swing_m=np.full(3, np.nan), com_m=com, zmp_m=zmp, window_n=window,
                zmp_margin_m=float(polygon_margin(zmp, real_hull)))))
        self._emit_all(step, "transfer", pending, hull)

    def _swing_thrust(self, com: np.ndarray, fans: np.ndarray, active: np.ndarray, one: bool, poly: np.ndarray,
                      share: float) -> tuple[np.ndarray, float, bool, bool]:
        """A swing row's thrust: per fan of the robot [N], the total [N], whether it is above the limit and
        whether none balances: the least thrust of the ``active`` fans at ``fans`` (F, 2) that balances the CoM
        ``com`` on the support ``poly`` within the tolerance scaled by ``share`` (one fan: Paper A's window in
        closed form, ``balance.thrust_window``; several: ``balance.least_thrust``)."""
        m = self.robot.mass_kg
        tol = self.tolerance.scaled(share)
        thrust_all = np.zeros(len(self.names))
        if one:  # Paper A: one fan, its window in closed form
            total = float(thrust_window(com[:2], fans[active[0]], poly, m, tol)[0])
            over = total > self.thrust_max_n
            unbalanced = not np.isfinite(total)
            if not unbalanced:
                thrust_all[active[0]] = total
            return thrust_all, total, over, unbalanced
        caps = self.caps[active]
        total_b, split = least_thrust(com[:2], fans[active], poly, m, caps, tol)
        total_f, split_f = least_thrust(com[:2], fans[active], poly, m, None, tol)
        over = not np.isfinite(total_b) and np.isfinite(total_f)
        unbalanced = not np.isfinite(total_f)
        total = float(total_f if over else total_b)
        if not unbalanced:
            thrust_all[active] = split_f if over else split
        return thrust_all, total, over, unbalanced

    def _swing_zmp(self, com: np.ndarray, fans: np.ndarray, active: np.ndarray, one: bool, thrust_all: np.ndarray,
                   total: float) -> tuple[np.ndarray, np.ndarray]:
        """A swing row's ZMP [m] under its thrust, and the shares of the fans that carry it (or are about to)."""
        m = self.robot.mass_kg
        if one:
            f = total if np.isfinite(total) else 0.0
            fan_share = np.zeros(len(self.names))
            fan_share[active[0]] = 1.0
            return zmp_with_thrust(com[:2], fans[active[0]], f, m), fan_share
        t = float(np.sum(thrust_all))
        fan_share = thrust_all / t if t > 0 else np.isin(np.arange(len(self.names)), active[:1]).astype(float)
        return zmp_with_thrusts(com[:2], fans, thrust_all, m), fan_share

    def swing(self, step: int, support: str, feet: dict[str, np.ndarray], path: np.ndarray, p_samples: np.ndarray,
              yaw_fn, duration_s: float, shares: np.ndarray | None = None, positions: np.ndarray | None = None
              ) -> None:
        """Single-support rows along ``path`` (N, 3) with optimised P_body ``p_samples`` (N, 3).

        ``positions``: the rows' places along the samples (fractional indices; default the minimum-jerk
        law, :func:`swing_row_positions`; a paced swing: :func:`paced_row_positions`); the swing sole and
        P_body are linear between samples along them.

        ``yaw_fn(swing_xyz) -> body yaw [rad]`` gives the trunk yaw at any swing position. The fans of
        the swing sole and the trunk carry the least thrust that balances the row's posture within
        the tolerance (``balance.thrust_window``; several fans: ``balance.least_thrust``), scaled by
        the share ``shares`` (N,) of the samples interpolated at the row (all of it without).
        """
        swing_side = other_side(support)
        active = np.array(self.robot.swing_fans(swing_side), dtype=np.int64)
        poly = self._sole(feet[support], self.margin)
        sole = self._sole(feet[support])
        idx = np.arange(len(path))
        one = len(active) == 1 and not self.robot.fans[active[0]].on_trunk
        if positions is None:
            positions = swing_row_positions(len(path), duration_s, 1.0 / self.dt)
        if self.smooth_trunk and len(p_samples) > 2:  # a time-optimal swing: P_body C¹ through the samples
            from scipy.interpolate import PchipInterpolator

            p_rows = PchipInterpolator(idx, p_samples, axis=0)(np.clip(positions, 0.0, idx[-1]))
            straight = np.isin(np.floor(positions).astype(int), sorted(self.linear_segments))
            p_rows[straight] = np.column_stack([np.interp(positions[straight], idx, p_samples[:, j])
                                                for j in range(3)])
        else:
            p_rows = np.column_stack([np.interp(positions, idx, p_samples[:, j]) for j in range(3)])
        swings = np.column_stack([np.interp(positions, idx, path[:, j]) for j in range(3)])
        yaws = np.array([float(yaw_fn(swings[k])) if self.yaw_of_row is None else self.yaw_of_row(len(self.rows) + k)
                         for k in range(len(positions))])
        solved = self._solve_swing(support, feet[support], swings, p_rows, yaws)
        # of every row at once where the postures are (physics.compiled.edge_errors, row by row inside)
        edges = (None if solved is None else
                 edge_angle_excess(feet[support][:2], solved[1][:, :2], swings[:, :2], self.rho_rad))
        pending: list[tuple] = []  # the rows, written once their shares are known (_emit_all)
        for k, u in enumerate(positions):
            swing, p, yaw = swings[k], p_rows[k], float(yaws[k])
            if solved is None:
                q, com, status = self._solve(Stance(support, feet[support], 0.0, swing, 0.0, yaw), p)
            else:
                q, com, status = solved[0][k], solved[1][k], int(solved[2][k])
            fans = self._fans_xy({support: feet[support], swing_side: swing}, p, yaw)
            share = 1.0 if shares is None else float(np.interp(u, idx, shares))
            thrust_all, total, over, unbalanced = self._swing_thrust(com, fans, active, one, poly, share)
            edge = float(edge_angle_excess(feet[support][:2], com[:2], swing[:2], self.rho_rad) if edges is None
                         else edges[k])
            reason = None
            if status != Reason.OK:
                reason = message(status)
            elif unbalanced:
                reason = "no thrust can balance" + self._describe_tolerance(share)
            elif over:
                reason = (f"thrust {total:.3f} N above its maximum {self.thrust_max_n} N"
                          + self._describe_tolerance(share))
            elif edge > 0:
                reason = f"edge angle {np.degrees(edge + self.rho_rad):.2f} deg above rho"
            zmp, fan_share = self._swing_zmp(com, fans, active, one, thrust_all, total)
            pending.append((k, reason, p, swing, com, fans, thrust_all, dict(
                step=step, phase="swing", sample=k, support=support, feasible=reason is None, p_body_m=p,
                ground_z_m=feet[support][2], yaw_rad=yaw, q_rad=q, swing_m=swing, com_m=com, zmp_m=zmp,
                window_n=self._window(com[:2], fans, fan_share, sole), zmp_margin_m=float(polygon_margin(zmp, sole)))))
            if reason is not None and self.stop_at_infeasible:
                break
        self._emit_all(step, "swing", pending, poly)
