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

from dataclasses import dataclass, field

import numpy as np

from jethr1_plan.control.time_laws import min_jerk, paced_row_positions, swing_row_positions
from jethr1_plan.geometry import GRAVITY, convex_hull, other_side, polygon_margin, sole_polygon, wrap_angle
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
from jethr1_plan.physics.row_dynamics import RowDynamics, row_dynamics
from jethr1_plan.physics.share import row_shares
from jethr1_plan.reasons import Reason, message
from jethr1_plan.robot.model import RobotModel, fan_ground_xy

__all__ = ["FanThrust", "Rows", "SequenceBuilder"]


@dataclass
class Rows:
    """Output rows (column arrays). Lengths grow as rows are appended."""

    columns: dict[str, list] = field(default_factory=dict)
    analysis: dict = field(default_factory=dict)  # whole-trajectory figures (energy, torque ratios)
    paced: list[dict] = field(default_factory=list)  # the swings re-timed by :func:`pace_swing`, in order
    timed: list[dict] = field(default_factory=list)  # the phases timed fastest (``planning.fast_timing``), in order

    def append(self, **values) -> None:
        for k, v in values.items():
            self.columns.setdefault(k, []).append(v)

    def __len__(self) -> int:
        return len(next(iter(self.columns.values()), []))

    def array(self, key: str) -> np.ndarray:
        return np.asarray(self.columns[key])


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
        self.rows = Rows()
        self.t = 0.0
        self.q_prev: np.ndarray | None = None
        self.first_infeasible: dict | None = None
        #: when set, the body yaw of row i (a smoothed schedule, e.g. the yaw MPC) instead of the blends
        self.yaw_of_row = None
        #: P_body through the swing samples by a monotone cubic (PCHIP: C¹, no overshoot between samples)
        #: instead of linearly (a fastest timing: the trunk's path has no corner at a sample for the rows to feel)
        self.smooth_trunk = False
        self.linear_segments: set[int] = set()  # segments (i → i + 1) kept linear where the smooth trunk fails
        self.names = [f.name for f in robot.fans]
        self.caps = np.array([min(f.max_thrust_n, thrust_max_n) for f in robot.fans])  # per fan [N]

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
            lo, hi = float(w_lo), min(float(w_hi), self.robot.fans[k].max_thrust_n)
        else:
            w_lo, w_hi = shared_window(com_xy, fans_xy[carry], share[carry], polygon, self.robot.mass_kg)
            fmax = np.array([self.robot.fans[k].max_thrust_n for k in carry])
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

    def _row_share(self, com_xy: np.ndarray, fans_xy: np.ndarray, thrust: np.ndarray, region: np.ndarray) -> float:
        """The row's tolerance share (NaN under the minimal policy)."""
        if self.tolerance == NOMINAL:
            return float("nan")
        return float(row_shares(com_xy, fans_xy, thrust, region, self.robot.mass_kg, self.tolerance))

    def _solve(self, stance: Stance, p_body: np.ndarray):
        batch = self.solver.solve_batch(stance, p_body[None], warm=self.q_prev)
        if batch.status[0] == Reason.OK:
            self.q_prev = batch.q[0]
        return batch.q[0], batch.com[0], int(batch.status[0])

    def _solve_swing(self, support: str, support_xyz: np.ndarray, swings: np.ndarray, p_body: np.ndarray,
                     yaws: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Every row of a swing at once where the solver is the closed form (each row is its own
        closed-form posture: the same as row by row, to the bit); None for an iterative solver (its
        warm start goes row to row)."""
        from jethr1_plan.kinematics.closed_form import ClosedFormPostureSolver, solve_postures

        if not isinstance(self.solver, ClosedFormPostureSolver) or not len(p_body):
            return None
        q, com, status = solve_postures(self.robot, p_body, yaws, {support: (support_xyz, 0.0),
                                                                   other_side(support): (swings, 0.0)})
        com[status == Reason.UNREACHABLE] = np.nan
        self.solver.evaluations += len(p_body)
        ok = np.flatnonzero(status == Reason.OK)
        if len(ok):
            self.q_prev = q[ok[-1]]
        return q, com, status

    def _mark(self, step: int, phase: str, sample: int, reason: str, detail: dict) -> None:
        if self.first_infeasible is None:
            self.first_infeasible = {"time_s": self.t, "step": step, "phase": phase, "sample": sample,
                                     "reason": reason, **detail}

    def snapshot(self) -> tuple:
        """The builder's state (rows written, clock, warm start, first infeasible row), for :meth:`restore`."""
        return (len(self.rows), self.t, None if self.q_prev is None else self.q_prev.copy(), self.first_infeasible)

    def restore(self, snap: tuple) -> None:
        """Back to a :meth:`snapshot`: the rows written since are dropped."""
        n, self.t, q_prev, self.first_infeasible = snap
        self.q_prev = None if q_prev is None else q_prev.copy()
        for col in self.rows.columns.values():
            del col[n:]

    def _emit(self, thrust: np.ndarray, **row) -> None:
        self.rows.append(time_s=self.t, **row, **{f"thrust_{n}": float(f) for n, f in zip(self.names, thrust,
                                                                                            strict=True)})
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
        for k in range(n + 1 if include_end else n):
            if positions is None:
                u = k / n
                s = float(min_jerk(u))
            else:
                u = s = float(positions[k])
            p = p0 + s * (p1 - p0)
            yaw = float(wrap_angle(yaw0 + s * dyaw)) if self.yaw_of_row is None else self.yaw_of_row(len(self.rows))
            stance = Stance("right", feet["right"], 0.0, feet["left"], 0.0, yaw)
            q, com, status = self._solve(stance, p)
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
            if reason:
                self._mark(step, "transfer", k, reason, {"p_body_m": p.tolist()})
            self._emit(thrust, step=step, phase="transfer", sample=k, support="both", feasible=reason is None,
                       ground_z=min(feet["left"][2], feet["right"][2]),
                       p_body=p, yaw=yaw, q=q, swing=np.full(3, np.nan), com=com, zmp=zmp, window=window,
                       zmp_margin=float(polygon_margin(zmp, real_hull)),
                       tolerance_share=self._row_share(com[:2], fans, thrust, hull), reason=reason or "")

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
        m = self.robot.mass_kg
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
        for k, u in enumerate(positions):
            swing, p, yaw = swings[k], p_rows[k], float(yaws[k])
            if solved is None:
                q, com, status = self._solve(Stance(support, feet[support], 0.0, swing, 0.0, yaw), p)
            else:
                q, com, status = solved[0][k], solved[1][k], int(solved[2][k])
            fans = self._fans_xy({support: feet[support], swing_side: swing}, p, yaw)
            share = 1.0 if shares is None else float(np.interp(u, idx, shares))
            tol = self.tolerance.scaled(share)
            thrust_all = np.zeros(len(self.names))
            if one:  # Paper A: one fan, its window in closed form
                fan = fans[active[0]]
                total = float(thrust_window(com[:2], fan, poly, m, tol)[0])
                over = total > self.thrust_max_n
                unbalanced = not np.isfinite(total)
                if not unbalanced:
                    thrust_all[active[0]] = total
            else:
                caps = self.caps[active]
                total_b, split = least_thrust(com[:2], fans[active], poly, m, caps, tol)
                total_f, split_f = least_thrust(com[:2], fans[active], poly, m, None, tol)
                over = not np.isfinite(total_b) and np.isfinite(total_f)
                unbalanced = not np.isfinite(total_f)
                total = float(total_f if over else total_b)
                if not unbalanced:
                    thrust_all[active] = split_f if over else split
            edge = float(edge_angle_excess(feet[support][:2], com[:2], swing[:2], self.rho_rad))
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
            if reason:
                self._mark(step, "swing", k, reason, {"p_body_m": p.tolist(), "swing_m": swing.tolist()})
            if one:
                f = total if np.isfinite(total) else 0.0
                zmp = zmp_with_thrust(com[:2], fans[active[0]], f, m)
                fan_share = np.zeros(len(self.names))
                fan_share[active[0]] = 1.0
            else:
                zmp = zmp_with_thrusts(com[:2], fans, thrust_all, m)
                t = float(np.sum(thrust_all))
                fan_share = (thrust_all / t if t > 0 else
                             np.isin(np.arange(len(self.names)), active[:1]).astype(float))
            self._emit(thrust_all, step=step, phase="swing", sample=k, support=support, feasible=reason is None,
                       p_body=p, ground_z=feet[support][2], yaw=yaw, q=q, swing=swing, com=com, zmp=zmp,
                       window=self._window(com[:2], fans, fan_share, sole), zmp_margin=float(polygon_margin(zmp, sole)),
                       tolerance_share=self._row_share(com[:2], fans, thrust_all, poly), reason=reason or "")


def rows_dynamics(rows: Rows, robot: RobotModel, dt: float, start: int = 0, stop: int | None = None) -> RowDynamics:
    """The multibody ZMP rows ``start:stop`` need (``physics.row_dynamics``; the robot held still beyond
    them): Paper A's balance is quasistatic, and this is how far the rows' own motion moves the ZMP from it."""
    c = rows.columns
    p = np.asarray(c["p_body"][start:stop], dtype=float)
    yaw = np.asarray(c["yaw"][start:stop], dtype=float)
    base = np.zeros((len(p), 4, 4))
    base[:, 0, 0], base[:, 0, 1], base[:, 1, 0], base[:, 1, 1] = np.cos(yaw), -np.sin(yaw), np.sin(yaw), np.cos(yaw)
    base[:, 2, 2] = base[:, 3, 3] = 1.0
    base[:, :3, 3] = p
    thrust = np.column_stack([np.asarray(c[f"thrust_{f.name}"][start:stop]) for f in robot.fans]).astype(float)
    return row_dynamics(robot, base, np.asarray(c["q"][start:stop], dtype=float), thrust,
                        np.asarray(c["support"][start:stop]), dt)


#: the trunk accelerations [m/s²] a paced swing is tried with, in order (:func:`pace_swing`)
PACE_ACCEL = (0.4, 0.2, 0.1, 0.05)
GRIP_SAFETY = 2.0  # the rows' motion may need at most μ / this of friction


def _note_pace(seq: SequenceBuilder, start: int, accel: float | None, least: float, held: bool) -> None:
    """summary.json's record of a paced swing (``dynamics.paced_swings``): its step, the trunk acceleration
    [m/s²] of its time law (None: the minimum-jerk law was kept, no pace doing better), the least multibody ZMP
    margin [m] of its rows, and whether that margin reaches ``balance.sole_margin_m``."""
    seq.rows.paced.append({"step": int(seq.rows.columns["step"][start]), "trunk_accel_m_s2": accel,
                           "least_zmp_margin_m": least, "margin_held": held})


def swing_dynamic_margin(seq: SequenceBuilder, start: int) -> np.ndarray:
    """(rows,) the multibody ZMP's margin in the support [m] of the swing rows written from row ``start``
    on (the row before them in the stencil; the last held)."""
    return _swing_dynamics(seq, start)[0]


def _swing_dynamics(seq: SequenceBuilder, start: int) -> tuple[np.ndarray, np.ndarray]:
    """(margin [m], friction ratio [1]) per swing row written from row ``start`` on (as
    :func:`swing_dynamic_margin`)."""
    lo = max(start - 1, 0)
    dyn = rows_dynamics(seq.rows, seq.robot, seq.dt, lo)
    return dyn.margin[start - lo:], dyn.friction_ratio[start - lo:]


def _holds(seq: SequenceBuilder, start: int, margin_m: float) -> tuple[bool, float]:
    """Whether the swing rows from ``start`` keep the multibody ZMP ``margin_m`` inside the support and need
    at most μ / :data:`GRIP_SAFETY` of friction; and their least margin [m]."""
    margin, friction = _swing_dynamics(seq, start)
    least = float(np.min(margin))
    grip = float(np.max(friction[:-1], initial=0.0))  # (the last row's stencil holds: the transfer judges it)
    return least >= margin_m and grip <= seq.robot.sole_friction / GRIP_SAFETY, least


def pace_swing(seq: SequenceBuilder, snap: tuple, build, p_samples: np.ndarray, duration_s: float,
               margin_m: float, strict: bool = True) -> float | None:
    """Re-time a swing whose rows' own motion moves the multibody ZMP to within ``margin_m`` [m] of the
    support sole's edge (or beyond), or needs more than μ / :data:`GRIP_SAFETY` of the soles' friction.
    ``build(positions)`` writes the swing (``positions`` None: the minimum-jerk law) after ``snap``; it is
    rebuilt paced (:func:`paced_row_positions` of ``p_samples`` (N, 3) over ``duration_s``) for each trunk
    acceleration of :data:`PACE_ACCEL` in turn, and the first whose rows all hold quasistatically, with the
    multibody ZMP ``margin_m`` inside and the friction within its bound, is kept. Where none is, the swing
    of the largest multibody margin is kept and, if ``strict``, its rows that leave the margin are marked
    infeasible (the friction is judged with every row, ``plan.add_analysis``). A swing looked at again is
    noted in ``seq.rows.paced`` (:func:`_note_pace`).
    Returns the kept swing's least multibody margin [m] (None: the swing was infeasible already, or needed no
    pacing)."""
    start, before = snap[0], snap[3]
    if seq.first_infeasible is not before:
        return None
    held, least = _holds(seq, start, margin_m)
    if held:
        return None
    best: tuple[float, np.ndarray | None, float | None] = (least, None, None)
    rate = 1.0 / seq.dt
    for accel in PACE_ACCEL:
        seq.restore(snap)
        positions = paced_row_positions(p_samples, duration_s, rate, accel)
        build(positions)
        if seq.first_infeasible is not before:
            continue
        held, least = _holds(seq, start, margin_m)
        if held:
            _note_pace(seq, start, accel, least, True)
            return least
        if least > best[0]:
            best = (least, positions, accel)
    seq.restore(snap)
    build(best[1])
    margins = swing_dynamic_margin(seq, start)
    _note_pace(seq, start, best[2], float(np.min(margins)), False)
    if not strict:
        return float(np.min(margins))
    c = seq.rows.columns
    for i in np.flatnonzero(margins < margin_m).tolist():
        r = start + i
        reason = (f"the rows' motion moves the ZMP to {1000 * margins[i]:.1f} mm from the sole's edge (multibody "
                  f"ZMP by central differences; {1000 * margin_m:g} mm wanted, the quasistatic ZMP "
                  f"{1000 * float(c['zmp_margin'][r]):.1f} mm inside), paced or not")
        c["feasible"][r] = False
        c["reason"][r] = c["reason"][r] or reason
        seq._mark(int(c["step"][r]), "swing", int(c["sample"][r]), reason, {"p_body_m": list(c["p_body"][r])})
    return float(np.min(margins))
