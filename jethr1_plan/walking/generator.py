"""Paper B's walking pattern generator (Fig. 3): footsteps → CoM by MPC (B-18) → look-ahead pelvic
rotation (B-27..B-33) → yaw MPC (B-34..B-38) → QP IK of the lower body (B-39, B-40) → arm swing that
cancels the lower body's yaw momentum (B-41..B-43), one control period after the other.

The MPCs are updated every ``CoMSettings.dt_s`` (their step; the pelvis's yaw follows the yaw MPC's
constant acceleration in between); the IK and the arm QP run every control period.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np

from jethr1_plan.control.yaw_mpc import yaw_mpc_step, yaw_step_state
from jethr1_plan.geometry import SIDES
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.walking.arm_swing import arm_rates
from jethr1_plan.walking.com_mpc import CoMPlan, CoMSettings, plan_com
from jethr1_plan.walking.ik import WalkIK
from jethr1_plan.walking.pelvis_yaw import reference_yaw
from jethr1_plan.walking.timeline import Timeline

__all__ = ["ArmSwing", "PelvisRotation", "Walk", "generalized_velocity", "generate", "yaw_bounds"]


@dataclass(frozen=True)
class PelvisRotation:
    """The pelvic rotation (B-27..B-38); ``mode`` none keeps the pelvis facing the walk."""

    mode: str = "paper_b"  # paper_b | none
    k_pel: float = 0.4  # (B-31, B-32); Paper B does not state it: chosen by walk-sweep, see the README
    horizon_s: float = 1.6  # the yaw MPC's horizon (Paper B: 1.6 s)
    alpha: float = 1.0  # α_pel
    beta: float = 1e-10  # β_pel


@dataclass(frozen=True)
class ArmSwing:
    """(B-43)'s weights; ``enabled`` false holds the arms at home."""

    enabled: bool = True
    w1: float = 1.0
    w2: float = 1e-2
    w3: float = 1e-4


@dataclass
class Walk:
    """A generated walk: one row per control period (SI units)."""

    robot: RobotModel
    timeline: Timeline
    com_plan: CoMPlan
    t: np.ndarray  # (N,) [s]
    support: np.ndarray  # (N,) 'left' | 'right' | 'both'
    step: np.ndarray  # (N,) the step under way
    q: np.ndarray  # (N, J) [rad]
    base: np.ndarray  # (N, 4, 4) the trunk's pose
    com_ref: np.ndarray  # (N, 3) the LIPM's CoM at its height [m]
    com: np.ndarray  # (N, 3) the posture's CoM [m]
    zmp_ref: np.ndarray  # (N, 2) (B-18)'s reference [m]
    zmp_lipm: np.ndarray  # (N, 2) the LIPM's ZMP [m]
    yaw_ref: np.ndarray  # (N,) the look-ahead reference's first value (B-30) [rad]
    yaw: np.ndarray  # (N,) the pelvic rotation the yaw MPC gives [rad]
    yaw_rate: np.ndarray  # (N,) [rad/s]
    feet_target: dict[str, np.ndarray]  # side -> (N, 3) [m]
    feet: dict[str, np.ndarray]  # side -> (N, 4, 4) the soles the posture reaches
    h_low: np.ndarray  # (N,) the lower body's yaw momentum (B-41) [N·m·s]
    h_up: np.ndarray  # (N,) the arms' (B-42) [N·m·s]
    v: np.ndarray  # (N, 6 + J) the generalised velocity of each period (base in its own frame)
    yaw_horizon: list[np.ndarray] = field(default_factory=list)  # per MPC update, the reference over its horizon
    wall_s: float = 0.0


def yaw_bounds(robot: RobotModel) -> tuple[float, float]:
    """The pelvic rotations [rad] the joints allow with the feet facing +x: the hip yaws turn by −θ,
    the waist yaw (if any) by −θ too."""
    lo, hi = -math.inf, math.inf
    joints = [leg.index[0] for leg in robot.legs.values()]
    if robot.walking.waist_yaw is not None:
        joints.append(robot.joint_names.index(robot.walking.waist_yaw))
    for j in joints:
        lo, hi = max(lo, -robot.upper_rad[j]), min(hi, -robot.lower_rad[j])
    return lo, hi


@numba.njit(cache=True)
def generalized_velocity(T0: np.ndarray, T1: np.ndarray, q0: np.ndarray, q1: np.ndarray, dt: float) -> np.ndarray:
    """(6 + J,): the base's linear and angular velocity in its own frame, then the joint rates, of
    the motion from (T0, q0) to (T1, q1) over ``dt`` [s] (pinocchio's free-flyer convention; the
    angular velocity from the rotation vector of R0ᵀR1)."""
    R0, R1 = np.ascontiguousarray(T0[:3, :3]), np.ascontiguousarray(T1[:3, :3])
    out = np.empty(6 + len(q0))
    out[:3] = np.ascontiguousarray(R1.T) @ (T1[:3, 3] - T0[:3, 3]) / dt
    R = np.ascontiguousarray(R0.T) @ R1
    c = min(1.0, max(-1.0, (R[0, 0] + R[1, 1] + R[2, 2] - 1.0) / 2.0))
    angle = math.acos(c)
    k = 0.5 if angle < 1e-9 else angle / (2.0 * math.sin(angle))
    out[3] = k * (R[2, 1] - R[1, 2]) / dt
    out[4] = k * (R[0, 2] - R[2, 0]) / dt
    out[5] = k * (R[1, 0] - R[0, 1]) / dt
    out[6:] = (q1 - q0) / dt
    return out


def generate(robot: RobotModel, timeline: Timeline, com: CoMSettings, rotation: PelvisRotation, arms: ArmSwing,
             control_hz: float) -> Walk:
    """Generate the walk of ``timeline`` on ``robot``."""
    import time

    t_wall = time.perf_counter()
    dt = 1.0 / control_hz
    plan = plan_com(timeline, com, dt)
    n = len(plan.t)
    ik = WalkIK(robot, dt)
    feet0, _ = timeline.feet(plan.t[:1])
    ik.stand({s: feet0[s][0] for s in SIDES}, np.array([*plan.pos[0], com.height_m]), 0.0)
    nj = len(robot.joint_names)
    out_q, out_base = np.zeros((n, nj)), np.zeros((n, 4, 4))
    out_com = np.zeros((n, 3))
    feet_pos, _ = timeline.feet(plan.t)
    feet_reached = {s: np.zeros((n, 4, 4)) for s in SIDES}
    yaw, yaw_rate, yaw_ref = np.zeros(n), np.zeros(n), np.zeros(n)
    h_low, h_up = np.zeros(n), np.zeros(n)
    velocity = np.zeros((n, 6 + nj))
    lo, hi = yaw_bounds(robot)
    arm_idx = ik.arm_index
    swing_arms = arms.enabled and len(arm_idx) > 0
    arm_q = ik.home[arm_idx].copy()
    lower_cols = np.ones(6 + nj, dtype=bool)
    lower_cols[6 + arm_idx] = False
    arm_lo, arm_hi = robot.lower_rad[arm_idx].astype(float), robot.upper_rad[arm_idx].astype(float)
    arm_home = ik.home[arm_idx].astype(float)
    arm_rate = np.array([ik.wrapper.model.velocityLimit[6 + i] for i in arm_idx], dtype=float)
    yaw_state = np.zeros(2)
    per_update = round(com.dt_s / dt)
    horizons = []
    T_prev, q_prev = ik.base, ik.q
    for i in range(n):
        t = plan.t[i]
        if i % per_update == 0:
            u = i // per_update
            if rotation.mode == "paper_b":
                steps = plan.predicted.shape[1]
                future = np.minimum(t + com.dt_s * np.arange(1, steps + 1), timeline.duration_s)
                f, _ = timeline.feet(future)
                ref = reference_yaw(plan.predicted[u], f["left"][:, :2], f["right"][:, :2], rotation.k_pel)
                keep = max(2, round(rotation.horizon_s / com.dt_s))
                ref = ref[:keep] if len(ref) >= keep else np.concatenate([ref, np.full(keep - len(ref), ref[-1])])
                acc, _, _ = yaw_mpc_step(yaw_state, ref, com.dt_s, rotation.alpha, rotation.beta, lo, hi)
                horizons.append(ref)
            else:
                acc, ref = 0.0, np.zeros(1)
            yaw_acc, yaw_start, u_start = acc, yaw_state.copy(), t
            yaw_ref_now = float(ref[0])
            yaw_state = yaw_step_state(yaw_state, acc, com.dt_s)
        state = yaw_step_state(yaw_start, yaw_acc, t - u_start)
        yaw[i], yaw_rate[i], yaw_ref[i] = state[0], state[1], yaw_ref_now
        target = np.array([*plan.pos[i], com.height_m])
        ik.step({s: feet_pos[s][i] for s in SIDES}, target, float(yaw[i]), arm_q if swing_arms else None)
        T, q = ik.base, ik.q
        v = generalized_velocity(T_prev, T, q_prev, q, dt) if i else np.zeros(6 + nj)
        A_yaw = ik.wrapper.centroidal_map()[5]
        h_low[i] = float(A_yaw[lower_cols] @ v[lower_cols])
        h_up[i] = float(A_yaw[~lower_cols] @ v[~lower_cols])
        if swing_arms and i:
            rates = arm_rates(h_low[i], np.ascontiguousarray(A_yaw[6 + arm_idx]), arm_q, arm_home, arm_lo, arm_hi,
                              arm_rate, dt, arms.w1, arms.w2, arms.w3)
            arm_q = arm_q + dt * rates
        out_q[i], out_base[i], velocity[i] = q, T, v
        out_com[i] = ik.wrapper.com_world()
        for s in SIDES:
            feet_reached[s][i] = ik.wrapper.get_T_world_frame(robot.legs[s].sole)
        T_prev, q_prev = T, q
    support, step = timeline.phase(plan.t)
    return Walk(robot, timeline, plan, plan.t, support, step, out_q, out_base,
                np.column_stack([plan.pos, np.full(n, com.height_m)]), out_com, plan.zmp_ref, plan.zmp,
                yaw_ref, yaw, yaw_rate, feet_pos, feet_reached, h_low, h_up, velocity, horizons,
                time.perf_counter() - t_wall)
