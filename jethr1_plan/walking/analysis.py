"""What a walk is judged by (Paper B, VI), from its written rows alone by the strictest stencil: what a
replay, or a robot's servos, would see.

* **Motion and the ground's wrench** (``physics.row_dynamics``): each row's velocity and acceleration by
  second central differences of the rows, no wider stencil (a one-row spike stays a one-row spike); the
  floating base's rows of M(q)·a + h(q, v) are the wrench the floor must supply, giving the multibody
  ZMP and the friction ratio |f_xy|/f_z against the soles' μ (the robot YAML's ``twin.sole_friction``).
  The first and last rows (``EDGE_ROWS``) have no row beyond them: their motion is the one-sided
  stencil's of the rows (a walk ends still moving: its CoM has not settled over the final stance, and
  a stop within one row beyond the last row would write a deceleration no row asks for into its
  torques, ZMP and servo commands); they are written and not judged.
* **Torques**: τ = M(q)·a + h(q, v) − J_cᵀ·w, the support wrench w from the base's six rows (one sole:
  exact; both: the least-norm split); E_con = Σ_i ∫ max(τ_i·q̇_i, 0) dt over two steps (B-44).
* **Singularity**: κ(J_low) = σ_max/σ_min of the lower body's Jacobian (B-9, B-45): each sole's
  twist (world-aligned) against its own leg's six joints (B-8), and, when the walk turns the pelvis,
  the pelvic rotation (the waist yaw, or on a robot without a waist the trunk's yaw about its
  origin); per leg, κ of the 6 × 6 sole Jacobian w.r.t. that leg's joints; each knee's bend and the
  leg's reach left (``knees``). Without pelvic rotation J_low has no yaw column: a column for a joint
  the walk never moves would keep κ finite while a leg is straight.
* **Tracking**: each sole against its target; the posture's CoM against the LIPM's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jethr1_plan.geometry import SIDES, polygon_margin, quaternion_from_matrix
from jethr1_plan.physics.row_dynamics import ground_wrench, row_derivatives
from jethr1_plan.walking.generator import Walk
from jethr1_plan.walking.knees import knee_bend_rad, leg_points
from jethr1_plan.walking.timeline import polygon_of

__all__ = ["ACCELERATION_TOL", "EDGE_ROWS", "SuccessCriteria", "Verdict", "WalkAnalysis", "analyse",
           "energy_two_steps", "judge"]


EDGE_ROWS = 1  # rows at each end whose stencil reaches beyond the walk: not judged
ACCELERATION_TOL = 1e-3  # a joint's row acceleration may exceed its limit by this (the QP's round-off) [rad/s²]


@dataclass
class WalkAnalysis:
    """Per row (N,) unless stated (SI units)."""

    v: np.ndarray  # (N, 6 + J) generalised velocity by central differences of the rows (base in its own frame)
    a: np.ndarray  # (N, 6 + J) generalised acceleration by second central differences of the rows
    kappa: np.ndarray  # κ of J_low (B-45)
    kappa_leg: np.ndarray  # (N, 2) κ of each leg's sole Jacobian (left, right)
    knee_bend_rad: np.ndarray  # (N, 2) each knee's bend from straight (left, right) [rad]
    reach_left_m: np.ndarray  # (N, 2) each leg's thigh + shank − hip–ankle distance [m]
    tau: np.ndarray  # (N, J) joint torques by inverse dynamics [N·m]
    zmp: np.ndarray  # (N, 2) the multibody ZMP [m]
    zmp_margin: np.ndarray  # its distance inside the real support polygon [m] (negative: outside)
    friction_ratio: np.ndarray  # |f_xy|/f_z of the ground's force
    energy_two_steps_j: float  # (B-44) [J]
    foot_error_m: np.ndarray  # the worst sole's distance from its target [m]
    foot_error_rad: np.ndarray  # the worst sole's tilt or turn from flat, facing +x [rad]
    com_error_m: np.ndarray  # the posture's CoM from the LIPM's [m]

    @property
    def judged(self) -> slice:
        """The rows whose stencil stays within the walk."""
        return slice(EDGE_ROWS, len(self.kappa) - EDGE_ROWS)

    def _least(self, x: np.ndarray) -> float | None:
        inner = x[self.judged]
        return float(np.min(inner)) if len(inner) else None

    def _peak(self, x: np.ndarray) -> float | None:
        inner = x[self.judged]
        return float(np.max(inner)) if len(inner) else None

    @property
    def least_zmp_margin_m(self) -> float | None:
        """The least ZMP margin of the judged rows [m] (None: too few rows)."""
        return self._least(self.zmp_margin)

    @property
    def peak_friction_ratio(self) -> float | None:
        return self._peak(self.friction_ratio)

    @property
    def joint_acceleration(self) -> np.ndarray:
        """(N, J) the joints' accelerations [rad/s²]."""
        return self.a[:, 6:]

    @property
    def peak_joint_acceleration_rad_s2(self) -> float | None:
        return self._peak(np.max(np.abs(self.joint_acceleration), axis=1)) if self.a.shape[1] > 6 else None


def _yaw_column(T_sole: np.ndarray, axis_point: np.ndarray) -> np.ndarray:
    """The twist (linear, angular; world-aligned) of a sole turned about the vertical axis through ``axis_point``."""
    r = T_sole[:3, 3] - axis_point
    return np.array([-r[1], r[0], 0.0, 0.0, 0.0, 1.0])  # (z × r, z)


def _condition(J: np.ndarray) -> float:
    s = np.linalg.svd(J, compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0 else np.inf


def analyse(walk: Walk) -> WalkAnalysis:
    """κ, torques, the multibody ZMP and friction, E_con and the tracking of a generated walk."""
    robot = walk.robot
    w = robot.wrapper()
    n, nj = walk.q.shape
    dt = float(walk.t[1] - walk.t[0]) if n > 1 else 1.0
    v, a = row_derivatives(walk.base, walk.q, dt, ends="rows")
    waist = robot.walking.waist_yaw
    kappa, kappa_leg = np.zeros(n), np.zeros((n, 2))
    points = np.zeros((4, n, 2, 3))  # hip yaw, hip pitch, knee, ankle pitch joints' origins
    tau, zmp, friction = np.zeros((n, nj)), np.zeros((n, 2)), np.zeros(n)
    legs = [np.asarray(robot.legs[s].index) for s in SIDES]
    ncols = 13 if walk.pelvis_rotation else 12
    for i in range(n):
        T = walk.base[i]
        w.state.q[:3] = T[:3, 3]
        w.state.q[3:7] = quaternion_from_matrix(T[:3, :3])
        w.state.q[7:] = walk.q[i]
        w.state.qd = v[i]
        w.state.qdd = a[i]
        w.update_kinematics()
        axis_point = w.get_T_world_frame(waist)[:3, 3] if waist is not None else T[:3, 3]
        J_low = np.zeros((12, ncols))
        for k, side in enumerate(SIDES):
            sole = robot.legs[side].sole
            J_leg = w.frame_jacobian(sole, "local_world_aligned")[:, 6 + legs[k]]
            kappa_leg[i, k] = _condition(J_leg)
            J_low[6 * k:6 * k + 6, ncols - 12 + 6 * k:ncols - 6 + 6 * k] = J_leg
            if walk.pelvis_rotation:
                J_low[6 * k:6 * k + 6, 0] = _yaw_column(w.get_T_world_frame(sole), axis_point)
            points[1:, i, k] = leg_points(w, robot, side)
            points[0, i, k] = w.get_T_world_frame(robot.legs[side].joints[0])[:3, 3]
        kappa[i] = _condition(J_low)
        full = w.mass_matrix() @ a[i] + w.non_linear_effects()
        f, moment = ground_wrench(T, full[:6])
        zmp[i] = (-moment[1] / f[2], moment[0] / f[2])
        friction[i] = np.hypot(f[0], f[1]) / f[2] if f[2] > 0 else np.inf
        supports = SIDES if walk.support[i] == "both" else (walk.support[i],)
        Jc = np.vstack([w.frame_jacobian(robot.legs[sd].sole, "local") for sd in supports])
        wrench, *_ = np.linalg.lstsq(Jc[:, :6].T, full[:6], rcond=None)
        tau[i] = full[6:] - Jc[:, 6:].T @ wrench
    bend = knee_bend_rad(points[1], points[2], points[3])
    reach = robot.thigh_m + robot.shank_m - np.linalg.norm(points[3] - points[0], axis=-1)
    margin = np.zeros(n)
    polygons: dict[tuple, np.ndarray] = {}
    for i, key in enumerate(walk.timeline.support_keys(walk.t)):
        if key not in polygons:
            polygons[key] = polygon_of(key, robot.sole_length_m, robot.sole_width_m, 0.0)
        margin[i] = polygon_margin(zmp[i], polygons[key])
    err_m = np.max([np.linalg.norm(walk.feet[s][:, :3, 3] - walk.feet_target[s], axis=1) for s in SIDES], axis=0)
    err_rad = np.max([np.linalg.norm(walk.feet[s][:, :3, :3] - np.eye(3), axis=(1, 2)) / np.sqrt(2) for s in SIDES],
                     axis=0)
    com_err = np.linalg.norm(walk.com - walk.com_ref, axis=1)
    return WalkAnalysis(v, a, kappa, kappa_leg, bend, reach, tau, zmp, margin, friction,
                        energy_two_steps(walk, tau, v[:, 6:]), err_m, err_rad, com_err)


def energy_two_steps(walk: Walk, tau: np.ndarray, qd: np.ndarray) -> float:
    """(B-44) over the second and third steps (a full left-right cycle in the walk's steady part) [J]."""
    steps = walk.timeline.steps
    if len(steps) < 4:
        t0, t1 = walk.t[0], walk.t[-1]
    else:
        t0, t1 = steps[1].t_lift, steps[3].t_lift
    window = (walk.t >= t0) & (walk.t <= t1)
    power = np.maximum(tau[window] * qd[window], 0.0).sum(axis=1)
    dt = float(walk.t[1] - walk.t[0]) if len(walk.t) > 1 else 0.0
    return float(np.sum(power) * dt)


@dataclass(frozen=True)
class SuccessCriteria:
    """What a walk must hold to count (``jethr1 walk`` exit 3 otherwise; a failed length in ``walk-sweep``)."""

    foot_tolerance_m: float = 1e-3  # each sole within this of its planned position [m]
    foot_tolerance_rad: float = 0.01  # and this of flat, facing the walk [rad]
    knee_margin_rad: float = 0.1  # each knee bent at least this from straight (the leg's singularity; the IK's floor)
    com_tolerance_m: float = 1e-4  # the posture's CoM within this of the LIPM's [m]
    zmp_margin_m: float = 0.0  # the multibody ZMP at least this far inside the support polygon [m]
    rehearse: bool = True  # and the walk rehearsed in the MuJoCo twin without a fall,
    landing_tolerance_m: float = 0.02  # its soles ending within this of their last footholds [m]


@dataclass(frozen=True)
class Verdict:
    """Whether a walk is one the robot can take, and the first reason it is not."""

    ok: bool
    reason: str
    time_s: float | None = None


def _over_torque(robot, tau: np.ndarray) -> str:
    k = int(np.argmax(np.abs(tau) / robot.servo_limit_nm))
    return f"{robot.joint_names[k]} needs {abs(tau[k]):.2f} N·m, beyond its {robot.servo_limit_nm[k]:g} N·m"


def _over_acceleration(walk: Walk, a: WalkAnalysis, i: int) -> str:
    acc = a.joint_acceleration[i]
    k = int(np.argmax(np.abs(acc)))
    return (f"{walk.robot.joint_names[k]} accelerates at {acc[k]:+.0f} rad/s² (limit "
            f"{walk.ik.max_joint_acceleration_rad_s2:g} rad/s²)")


def _held_back(walk: Walk, a: WalkAnalysis, i: int, rows: int = 10) -> str:
    """The joints that sat on an edge of their window of rates at row ``i`` or just before it (what kept
    the leg from following its sole), with their rates."""
    if walk.window_bound is None:
        return ""
    lo = max(1, i - rows)
    for r in range(i, lo - 1, -1):
        held = np.flatnonzero(walk.window_bound[r])
        if len(held):
            dt = float(walk.t[1] - walk.t[0])
            rates = (walk.q[r] - walk.q[r - 1]) / dt
            names = ", ".join(f"{walk.robot.joint_names[j]} at {rates[j]:+.2f} rad/s" for j in held[:3])
            when = "" if r == i else f" at t = {walk.t[r]:.2f} s"
            return f" ({names}, on the edge of its window of rates{when})"
    return ""


def _zmp_short(margin_m: float, wanted_m: float) -> str:
    if margin_m < 0:
        return f"the ZMP {1000 * -margin_m:.1f} mm outside the support"
    return f"the ZMP {1000 * margin_m:.1f} mm inside the support, less than the margin {1000 * wanted_m:g} mm"


def judge(walk: Walk, a: WalkAnalysis, criteria: SuccessCriteria = SuccessCriteria()) -> Verdict:
    """The first row that breaks one of ``criteria`` the planner's own model can judge (the twin's are
    the rehearsal's): no posture within the limits (the generator's), a sole off its target, a knee
    bent less than the margin (near the straight-leg singularity), the CoM off the LIPM's, a joint
    beyond its limits, a joint's acceleration beyond the IK's limit, a torque beyond its servo's, the
    friction ratio above the soles' μ, the multibody ZMP outside the support (the first and last
    ``EDGE_ROWS`` rows excepted from the ones the second differences judge)."""
    c = criteria
    robot = walk.robot
    n = len(walk.t)
    inner = np.zeros(n, dtype=bool)
    inner[a.judged] = True
    mu = robot.sole_friction
    bend = np.min(a.knee_bend_rad, axis=1)
    acc_limit = walk.ik.max_joint_acceleration_rad_s2 + ACCELERATION_TOL
    checks = [
        (a.foot_error_m > c.foot_tolerance_m,
         lambda i: f"a sole {1000 * a.foot_error_m[i]:.2f} mm off its target{_held_back(walk, a, i)}"),
        (a.foot_error_rad > c.foot_tolerance_rad,
         lambda i: f"a sole {a.foot_error_rad[i]:.3f} rad off flat{_held_back(walk, a, i)}"),
        (bend < c.knee_margin_rad, lambda i: f"a knee bent {bend[i]:.3f} rad from straight, the straight-leg "
                                             f"singularity (margin {c.knee_margin_rad:g} rad)"),
        (a.com_error_m > c.com_tolerance_m, lambda i: f"the CoM {1000 * a.com_error_m[i]:.2f} mm off the LIPM's"),
        (np.any((walk.q < robot.lower_rad - 1e-6) | (walk.q > robot.upper_rad + 1e-6), axis=1),
         lambda i: "a joint beyond its limits"),
        (inner & np.any(np.abs(a.joint_acceleration) > acc_limit, axis=1), lambda i: _over_acceleration(walk, a, i)),
        (inner & np.any(np.abs(a.tau) > robot.servo_limit_nm, axis=1), lambda i: _over_torque(robot, a.tau[i])),
        (inner & (a.friction_ratio > mu), lambda i: f"the ground's force {a.friction_ratio[i]:.2f} of its "
                                                    f"normal force sideways, beyond the soles' friction {mu:g}"),
        (inner & (a.zmp_margin < c.zmp_margin_m), lambda i: _zmp_short(float(a.zmp_margin[i]), c.zmp_margin_m)),
    ]
    first, why = None, ""
    if walk.infeasible is not None:
        first, why = walk.infeasible
    for bad, describe in checks:
        idx = np.flatnonzero(bad)
        if len(idx) and (first is None or idx[0] < first):
            first, why = int(idx[0]), describe(int(idx[0]))
    if first is None:
        return Verdict(True, "")
    return Verdict(False, why, float(walk.t[first]))
