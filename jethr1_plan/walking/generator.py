"""Paper B's walking pattern generator (Fig. 3): footsteps → CoM by MPC (B-18) → look-ahead pelvic
rotation (B-27..B-33) → yaw MPC (B-34..B-38) → QP IK of the lower body (B-39, B-40) → arm swing that
cancels the lower body's yaw momentum of the same period (B-41..B-43), one control period after the
other, every joint within its rate and acceleration limits (no impulse by construction).

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
from jethr1_plan.walking.ik import COM_WEIGHT, IKSettings, WalkIK
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
    pelvis_rotation: bool = True  # the walk turns the pelvis (Paper B's mode), or keeps it facing the walk
    ik: IKSettings = field(default_factory=IKSettings)
    window_bound: np.ndarray | None = None  # (N, J) the joints whose rate sat on an edge of their window
    infeasible: tuple[int, str] | None = None  # the first row no posture within the limits could follow, and why
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


def _describe_window(name: str, q: float, rate: float, lo: float, hi: float, lower: float, upper: float) -> str:
    """Why a joint's window of rates is empty: it moves towards a limit too fast to stop."""
    towards = upper if rate > 0 else lower
    return (f"{name} at {q:.3f} rad moving {rate:+.2f} rad/s cannot stop before {towards:.3f} rad within its "
            f"acceleration limit (rates {lo:+.2f} > {hi:+.2f} rad/s)")


def generate(robot: RobotModel, timeline: Timeline, com: CoMSettings, rotation: PelvisRotation, arms: ArmSwing,
             control_hz: float, ik_settings: IKSettings | None = None, knee_bend_rad: float = 0.0) -> Walk:
    """Generate the walk of ``timeline`` on ``robot``, each knee kept ``knee_bend_rad`` [rad] from straight.

    Each period: the lower body's QP IK within the joints' windows of rates (``joint_window``); with
    arms, their (B-43) rates for the lower body's momentum of this period, then one more IK step of
    the lower body with the arms where they now are. Where a window is empty or the QP has no
    solution the walk is infeasible from that row on (``Walk.infeasible``; the period is still
    taken, the window widened or the CoM released, so that the rows go on)."""
    import time

    t_wall = time.perf_counter()
    ik_settings = ik_settings or IKSettings()
    dt = 1.0 / control_hz
    plan = plan_com(timeline, com, dt)
    n = len(plan.t)
    ik = WalkIK(robot, dt, knee_bend_rad)
    feet0, _ = timeline.feet(plan.t[:1])
    ik.stand({s: feet0[s][0] for s in SIDES}, np.array([*plan.pos[0], com.height_m]), 0.0)
    ik.walk(ik_settings)
    nj = len(robot.joint_names)
    out_q, out_base = np.zeros((n, nj)), np.zeros((n, 4, 4))
    out_com = np.zeros((n, 3))
    feet_pos, _ = timeline.feet(plan.t)
    feet_reached = {s: np.zeros((n, 4, 4)) for s in SIDES}
    yaw, yaw_rate, yaw_ref = np.zeros(n), np.zeros(n), np.zeros(n)
    h_low, h_up = np.zeros(n), np.zeros(n)
    velocity = np.zeros((n, 6 + nj))
    bound = np.zeros((n, nj), dtype=bool)
    lo, hi = yaw_bounds(robot)
    period = _Period(ik, robot.joint_names, dt, arms, _Failures())
    yaw_state = np.zeros(2)
    per_update = round(com.dt_s / dt)
    horizons = []
    T_prev, q_prev = ik.base, ik.q
    rate_prev = np.zeros(nj)  # the joints' rates over the last period [rad/s]
    for i in range(n):
        t = plan.t[i]
        if i % per_update == 0:
            acc, ref = _yaw_update(plan, timeline, com, rotation, yaw_state, i // per_update, t, lo, hi)
            if rotation.mode == "paper_b":
                horizons.append(ref)
            yaw_acc, yaw_start, u_start = acc, yaw_state.copy(), t
            yaw_ref_now = float(ref[0])
            yaw_state = yaw_step_state(yaw_state, acc, com.dt_s)
        state = yaw_step_state(yaw_start, yaw_acc, t - u_start)
        yaw[i], yaw_rate[i], yaw_ref[i] = state[0], state[1], yaw_ref_now
        target = np.array([*plan.pos[i], com.height_m])
        targets = {s: feet_pos[s][i] for s in SIDES}
        if i == 0:  # the standing posture itself
            T, q, v = T_prev, q_prev, np.zeros(6 + nj)
        else:
            T, q, v, rate_prev = period.step(i, T_prev, q_prev, rate_prev, targets, target, float(yaw[i]), bound[i])
        A_yaw = ik.wrapper.centroidal_map()[5]
        lower_cols = period.lower_cols
        h_low[i] = float(A_yaw[lower_cols] @ v[lower_cols])
        h_up[i] = float(A_yaw[~lower_cols] @ v[~lower_cols])
        out_q[i], out_base[i], velocity[i] = q, T, v
        out_com[i] = ik.wrapper.com_world()
        for s in SIDES:
            feet_reached[s][i] = ik.wrapper.get_T_world_frame(robot.legs[s].sole)
        T_prev, q_prev = T, q
    support, step = timeline.phase(plan.t)
    return Walk(robot, timeline, plan, plan.t, support, step, out_q, out_base,
                np.column_stack([plan.pos, np.full(n, com.height_m)]), out_com, plan.zmp_ref, plan.zmp,
                yaw_ref, yaw, yaw_rate, feet_pos, feet_reached, h_low, h_up, velocity, horizons,
                rotation.mode == "paper_b", ik_settings, bound, period.failures.first, time.perf_counter() - t_wall)


def _yaw_update(plan, timeline: Timeline, com: CoMSettings, rotation: PelvisRotation, yaw_state: np.ndarray, u: int,
                t: float, lo: float, hi: float) -> tuple[float, np.ndarray]:
    """At the CoM plan's update ``u`` (time ``t`` [s]): the pelvis yaw's acceleration [rad/s²] and its reference over
    the MPC's horizon [rad] (Paper B's pelvic rotation, (B-6)..(B-8)); none without it."""
    if rotation.mode != "paper_b":
        return 0.0, np.zeros(1)
    steps = plan.predicted.shape[1]
    future = np.minimum(t + com.dt_s * np.arange(1, steps + 1), timeline.duration_s)
    f, _ = timeline.feet(future)
    ref = reference_yaw(plan.predicted[u], f["left"][:, :2], f["right"][:, :2], rotation.k_pel)
    keep = max(2, round(rotation.horizon_s / com.dt_s))
    ref = ref[:keep] if len(ref) >= keep else np.concatenate([ref, np.full(keep - len(ref), ref[-1])])
    acc, _, _ = yaw_mpc_step(yaw_state, ref, com.dt_s, rotation.alpha, rotation.beta, lo, hi)
    return acc, ref


class _Failures:
    """The first row at which the walk became infeasible, and why."""

    def __init__(self) -> None:
        self.first: tuple[int, str] | None = None

    def fail(self, row: int, reason: str) -> None:
        if self.first is None:
            self.first = (row, reason)


class _Period:
    """One control period of the walk after the first row: the lower body's QP IK within the joints' windows of
    rates, then, with arms, their (B-43) rates and the IK again with the arms there."""

    def __init__(self, ik: WalkIK, names: tuple[str, ...], dt: float, arms: ArmSwing, failures: _Failures) -> None:
        self.ik, self.names, self.dt, self.arms, self.failures = ik, names, dt, arms, failures
        self.arm_idx = ik.arm_index
        self.solved = ik.solved_index
        self.swing_arms = arms.enabled and len(self.arm_idx) > 0
        self.lower_cols = np.ones(6 + len(names), dtype=bool)
        self.lower_cols[6 + self.arm_idx] = False
        self.arm_home = ik.home[self.arm_idx].astype(float)

    def _solve(self, row: int, targets: dict, target_com: np.ndarray, yaw_now: float, arm_q: np.ndarray | None
               ) -> None:
        ik = self.ik
        try:
            ik.step(targets, target_com, yaw_now, arm_q)
        except RuntimeError:  # PlaCo's "QPError: Infeasible QP": no posture keeps the CoM within the windows
            self.failures.fail(row, "no posture within the joints' rate windows keeps the CoM on the LIPM's")
            ik.com.configure("com", "soft", COM_WEIGHT)
            ik.step(targets, target_com, yaw_now, arm_q)
            ik.com.configure("com", "hard", 1.0)

    def _window(self, i: int, q_prev: np.ndarray, rate_prev: np.ndarray, joints: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The window of rates of ``joints`` [rad/s] (lower, upper bounds) and where it is empty; the first empty
        one is a failure of row ``i``."""
        ik = self.ik
        w_lo, w_hi = ik.window(q_prev, rate_prev, joints)
        empty = np.flatnonzero(w_lo > w_hi)
        for k in empty[:1]:
            j = int(joints[k])
            self.failures.fail(i, _describe_window(self.names[j], q_prev[j], rate_prev[j], w_lo[k], w_hi[k],
                                                   ik.lower[j], ik.upper[j]))
        return w_lo, w_hi, empty

    def step(self, i: int, T_prev: np.ndarray, q_prev: np.ndarray, rate_prev: np.ndarray, targets: dict,
             target: np.ndarray, yaw_now: float, bound_row: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Row ``i``: (the base's pose, the joints [rad], the generalised velocity, the joints' rates [rad/s]);
        ``bound_row`` marks the joints whose rate lies on its window's bound."""
        ik, dt, solved, arm_idx = self.ik, self.dt, self.solved, self.arm_idx
        w_lo, w_hi, empty = self._window(i, q_prev, rate_prev, solved)
        if len(empty):
            w_lo[empty] = w_hi[empty] = 0.5 * (w_lo[empty] + w_hi[empty])
        ik.set_window(q_prev, w_lo, w_hi)
        self._solve(i, targets, target, yaw_now, None)
        if self.swing_arms:  # the arms cancel the lower body's yaw momentum of this very period
            v = generalized_velocity(T_prev, ik.base, q_prev, ik.q, dt)
            A_yaw = ik.wrapper.centroidal_map()[5]
            a_lo, a_hi, _ = self._window(i, q_prev, rate_prev, arm_idx)
            lower_cols, arms = self.lower_cols, self.arms
            rates = arm_rates(float(A_yaw[lower_cols] @ v[lower_cols]), np.ascontiguousarray(A_yaw[6 + arm_idx]),
                              q_prev[arm_idx], self.arm_home, a_lo, a_hi, dt, arms.w1, arms.w2, arms.w3)
            self._solve(i, targets, target, yaw_now, q_prev[arm_idx] + dt * rates)
        T, q = ik.base, ik.q
        v = generalized_velocity(T_prev, T, q_prev, q, dt)
        rate = (q - q_prev) / dt
        bound_row[solved] = (np.abs(rate[solved] - w_lo) < 1e-6) | (np.abs(rate[solved] - w_hi) < 1e-6)
        if self.swing_arms:
            bound_row[arm_idx] = (np.abs(rate[arm_idx] - a_lo) < 1e-6) | (np.abs(rate[arm_idx] - a_hi) < 1e-6)
        return T, q, v, rate
