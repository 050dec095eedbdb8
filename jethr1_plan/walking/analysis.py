"""What a walk is judged by (Paper B, VI): the lower body's condition number κ (B-45), the yaw
angular momentum with and without the arms (B-41, B-42), the joint torques by inverse dynamics and
the energy over two steps (B-44), and the multibody ZMP recomputed from the posture's motion.

* κ(J_low) = σ_max/σ_min of the 12 × 13 lower-body Jacobian (B-9): each sole's twist against the
  pelvic rotation (the waist yaw, or on a robot without a waist the trunk's own yaw about its
  origin) and its own leg's six joints (B-8), world-aligned.
* Torques: τ = M(q)·q̈ + h(q, q̇) − J_cᵀ·w with the support wrench w from the floating base's six
  rows (one sole: exact; both: the least-norm split), q̇ and q̈ by central differences of the rows.
* E_con = Σ_i ∫ max(τ_i·q̇_i, 0) dt over two steps (B-44), the second and the third.
* The ZMP from the centroidal momentum h = (p, L) = A_G(q)·q̇ (PlaCo's centroidal map) and its rate:
  x = c_x − (c_z·ṗ_x + L̇_y)/(ṗ_z + m·g), y = c_y − (c_z·ṗ_y − L̇_x)/(ṗ_z + m·g): independent of the LIPM.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jethr1_plan.geometry import GRAVITY, SIDES, polygon_margin, quaternion_from_matrix
from jethr1_plan.walking.generator import Walk
from jethr1_plan.walking.timeline import polygon_of

__all__ = ["EDGE_ROWS", "SuccessCriteria", "Verdict", "WalkAnalysis", "analyse", "energy_two_steps", "judge",
           "zmp_from_momentum"]


EDGE_ROWS = 2  # rows at each end whose ZMP comes from one-sided differences: not judged


@dataclass
class WalkAnalysis:
    """Per row (N,) unless stated (SI units)."""

    kappa: np.ndarray  # κ of J_low (B-45)
    tau: np.ndarray  # (N, J) joint torques by inverse dynamics [N·m]
    zmp: np.ndarray  # (N, 2) the multibody ZMP [m]
    zmp_margin: np.ndarray  # its distance inside the real support polygon [m] (negative: outside)
    energy_two_steps_j: float  # (B-44) [J]
    foot_error_m: np.ndarray  # the worst sole's distance from its target [m]
    foot_error_rad: np.ndarray  # the worst sole's tilt or turn from flat, facing +x [rad]
    knee_margin_rad: np.ndarray  # the least knee angle beyond its straight-leg limit [rad]

    @property
    def least_zmp_margin_m(self) -> float | None:
        """The least ZMP margin of the judged rows [m] (None: too few rows)."""
        inner = self.zmp_margin[EDGE_ROWS:-EDGE_ROWS]
        return float(np.min(inner)) if len(inner) else None


def _yaw_column(T_sole: np.ndarray, axis_point: np.ndarray) -> np.ndarray:
    """The twist (linear, angular; world-aligned) of a sole turned about the vertical axis through ``axis_point``."""
    z = np.array([0.0, 0.0, 1.0])
    return np.concatenate([np.cross(z, T_sole[:3, 3] - axis_point), z])


def analyse(walk: Walk) -> WalkAnalysis:
    """κ, torques, the multibody ZMP, E_con and the tracking of a generated walk."""
    robot = walk.robot
    w = robot.wrapper()
    n, nj = walk.q.shape
    dt = float(walk.t[1] - walk.t[0]) if n > 1 else 1.0
    # generalised velocities at the rows (central differences of the periods' velocities) and accelerations
    v_period = walk.v  # velocity over the period ending at row i
    v = v_period.copy()
    v[:-1] = 0.5 * (v_period[:-1] + v_period[1:])
    a = np.gradient(v, dt, axis=0)
    waist = robot.walking.waist_yaw
    kappa, tau = np.zeros(n), np.zeros((n, nj))
    h = np.zeros((n, 6))
    mass = robot.mass_kg
    for i in range(n):
        T = walk.base[i]
        quat = quaternion_from_matrix(T[:3, :3])
        w.state.q[:3] = T[:3, 3]
        w.state.q[3:7] = quat
        w.state.q[7:] = walk.q[i]
        w.state.qd = v[i]
        w.state.qdd = a[i]
        w.update_kinematics()
        axis_point = (w.get_T_world_frame(waist)[:3, 3] if waist is not None else T[:3, 3])
        blocks = []
        for side in SIDES:
            leg = robot.legs[side]
            J = w.frame_jacobian(leg.sole, "local_world_aligned")
            T_sole = w.get_T_world_frame(leg.sole)
            blocks.append((J[:, 6 + np.asarray(leg.index)], _yaw_column(T_sole, axis_point)))
        J_low = np.zeros((12, 13))
        for k, (J_leg, col) in enumerate(blocks):
            J_low[6 * k:6 * k + 6, 0] = col
            J_low[6 * k:6 * k + 6, 1 + 6 * k:7 + 6 * k] = J_leg
        s = np.linalg.svd(J_low, compute_uv=False)
        kappa[i] = s[0] / s[-1] if s[-1] > 0 else np.inf
        full = w.mass_matrix() @ a[i] + w.non_linear_effects()
        supports = SIDES if walk.support[i] == "both" else (walk.support[i],)
        Jc = np.vstack([w.frame_jacobian(robot.legs[sd].sole, "local") for sd in supports])
        wrench, *_ = np.linalg.lstsq(Jc[:, :6].T, full[:6], rcond=None)
        tau[i] = full[6:] - Jc[:, 6:].T @ wrench
        h[i] = w.centroidal_map() @ v[i]
    zmp = zmp_from_momentum(walk.com, h, dt, mass)
    margin = np.zeros(n)
    polygons: dict[tuple, np.ndarray] = {}
    for i, key in enumerate(walk.timeline.support_keys(walk.t)):
        if key not in polygons:
            polygons[key] = polygon_of(key, robot.sole_length_m, robot.sole_width_m, 0.0)
        margin[i] = polygon_margin(zmp[i], polygons[key])
    err_m = np.max([np.linalg.norm(walk.feet[s][:, :3, 3] - walk.feet_target[s], axis=1) for s in SIDES], axis=0)
    err_rad = np.max([np.linalg.norm(walk.feet[s][:, :3, :3] - np.eye(3), axis=(1, 2)) / np.sqrt(2) for s in SIDES],
                     axis=0)
    knees = [robot.legs[s].index[3] for s in SIDES]
    knee_margin = np.min(walk.q[:, knees] - robot.lower_rad[knees], axis=1)
    return WalkAnalysis(kappa, tau, zmp, margin, energy_two_steps(walk, tau, v[:, 6:]), err_m, err_rad, knee_margin)


def zmp_from_momentum(com: np.ndarray, h: np.ndarray, dt: float, mass_kg: float) -> np.ndarray:
    """(N, 2) the ZMP on the ground [m] of a motion sampled every ``dt`` [s]: CoM ``com`` (N, 3) [m] and
    centroidal momentum ``h`` (N, 6) = (p [N·s], L [N·m·s]), its rate by central differences."""
    hdot = np.gradient(h, dt, axis=0)
    fz = hdot[:, 2] + mass_kg * GRAVITY
    return np.column_stack([com[:, 0] - (com[:, 2] * hdot[:, 0] + hdot[:, 4]) / fz,
                            com[:, 1] - (com[:, 2] * hdot[:, 1] - hdot[:, 3]) / fz])


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
    knee_margin_rad: float = 0.1  # no knee closer than this to straight (the leg's singularity) [rad]
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


def judge(walk: Walk, a: WalkAnalysis, criteria: SuccessCriteria = SuccessCriteria()) -> Verdict:
    """The first row that breaks one of ``criteria`` the planner's own model can judge (the twin's are
    the rehearsal's): a sole off its target, a knee within the margin of straight (near the
    singularity the IK loses the foot), a joint beyond its limits or a torque beyond its servo's, the
    multibody ZMP outside the support (the first and last ``EDGE_ROWS`` rows excepted)."""
    c = criteria
    robot = walk.robot
    checks = [
        (a.foot_error_m > c.foot_tolerance_m, lambda i: f"a sole {1000 * a.foot_error_m[i]:.2f} mm off its target"),
        (a.foot_error_rad > c.foot_tolerance_rad, lambda i: f"a sole {a.foot_error_rad[i]:.3f} rad off flat"),
        (a.knee_margin_rad < c.knee_margin_rad, lambda i: f"a knee {a.knee_margin_rad[i]:.3f} rad from straight "
                                                         f"(margin {c.knee_margin_rad:g} rad)"),
        (np.any((walk.q < robot.lower_rad - 1e-6) | (walk.q > robot.upper_rad + 1e-6), axis=1),
         lambda i: "a joint beyond its limits"),
        (np.any(np.abs(a.tau) > robot.servo_limit_nm, axis=1), lambda i: _over_torque(robot, a.tau[i])),
    ]
    zmp_bad = a.zmp_margin < c.zmp_margin_m
    zmp_bad[:EDGE_ROWS] = False
    zmp_bad[-EDGE_ROWS:] = False
    checks.append((zmp_bad, lambda i: f"the ZMP {1000 * -a.zmp_margin[i]:.1f} mm outside the support"))
    first, why = None, ""
    for bad, describe in checks:
        idx = np.flatnonzero(bad)
        if len(idx) and (first is None or idx[0] < first):
            first, why = int(idx[0]), describe(int(idx[0]))
    if first is None:
        return Verdict(True, "")
    return Verdict(False, why, float(walk.t[first]))
