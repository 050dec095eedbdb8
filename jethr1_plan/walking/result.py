"""One walk from its file to its verdict: generate it (Paper B's pipeline), analyse it (κ, torques,
the multibody ZMP, friction, E_con), judge it against the walk's success criteria and rehearse it in the
MuJoCo twin; and its ``summary.json`` document."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from jethr1_plan.arithmetic import signature

import numpy as np

from jethr1_plan.geometry import SIDES
from jethr1_plan.walking.analysis import Verdict, WalkAnalysis
from jethr1_plan.walking.generator import Walk, generate
from jethr1_plan.walking.spec import WalkSpec

__all__ = ["WALK_SAG_FILTER_S", "WalkResult", "WalkRun", "generate_walk", "walk_summary"]

# The walk's torques are dynamic and continuous (inverse dynamics of smooth rows), so its servo
# commands add the sag unfiltered (a plan's static torques jump at hand-overs and are low-passed).
# Measured in the Jet-HR1 twin at 0.12 m steps: the soles end 47 mm short of their footholds without
# the compensation, 6 mm with it, 7 mm with a 20 ms filter, 11 mm with 50 ms.
WALK_SAG_FILTER_S = 0.0


@dataclass(frozen=True)
class WalkRun:
    """The rehearsal's verdict and measurements (SI units; angles in degrees where named so)."""

    survived: bool
    fell_at_s: float | None  # the walk's time of the fall [s]
    reason: str
    max_tilt_deg: float
    landing_error_m: float  # the soles' largest distance from their last footholds at the end [m]
    simulated_s: float



@dataclass
class WalkResult:
    """A generated walk and how it fared (SI units)."""

    spec: WalkSpec
    walk: Walk
    analysis: WalkAnalysis
    verdict: Verdict  # against the success criteria, from the planner's own model
    rehearsal: WalkRun | None  # in the MuJoCo twin (None: not asked for)
    armless_peak_momentum_nms: float | None  # peak |yaw momentum| of the same walk with the arms held
    commands_rad: np.ndarray  # (N, J) servo commands: the rows plus the sag under their torques (commands.py)

    @property
    def ok(self) -> bool:
        """The criteria hold and the twin did not fall and ended on its footholds."""
        return self.failure is None

    @property
    def failure(self) -> tuple[float | None, str] | None:
        """(time [s], reason) of the first failure, or None."""
        if not self.verdict.ok:
            return self.verdict.time_s, self.verdict.reason
        r = self.rehearsal
        if r is not None and not r.survived:
            return r.fell_at_s, f"the MuJoCo twin fell: {r.reason}"
        tol = self.spec.success.landing_tolerance_m
        if r is not None and r.landing_error_m > tol:
            return None, (f"in the MuJoCo twin the soles ended {1000 * r.landing_error_m:.1f} mm from their last "
                          f"footholds (tolerance {1000 * tol:g} mm)")
        return None


def generate_walk(spec: WalkSpec) -> Walk:
    """Paper B's pipeline on ``spec`` (no analysis)."""
    return generate(spec.robot, spec.timeline(), spec.com, spec.rotation, spec.arms, spec.timing.control_hz, spec.ik,
                    spec.success.knee_margin_rad)


def _peak(x: np.ndarray) -> float:
    return float(np.max(np.abs(x))) if len(x) else 0.0


def walk_summary(result: WalkResult) -> dict:
    """``summary.json`` of a walk (SI units; names carry them)."""
    from jethr1_plan import __version__

    spec, walk, a = result.spec, result.walk, result.analysis
    total = walk.h_low + walk.h_up
    duration = float(walk.timeline.duration_s)
    failure = result.failure
    rehearsal = None if result.rehearsal is None else {
        "survived": result.rehearsal.survived, "fell_at_s": result.rehearsal.fell_at_s,
        "reason": result.rehearsal.reason or None, "max_trunk_tilt_deg": result.rehearsal.max_tilt_deg,
        "landing_error_m": None if not result.rehearsal.survived else result.rehearsal.landing_error_m}
    judged = a.tau[a.judged]
    tau_peak = np.max(np.abs(judged), axis=0) if len(judged) else np.zeros(len(spec.robot.joint_names))
    return {
        "kind": "walk",
        "version": __version__,
        "arithmetic": signature(),  # the kernels that computed it: the bytes are the same wherever this is
        "name": spec.name,
        "walk_file": spec.source,
        "robot": spec.robot.name,
        "robot_yaml": str(spec.robot.yaml_path),
        "ok": result.ok,
        "failure": None if failure is None else {"time_s": failure[0], "reason": failure[1]},
        "spec": {"footsteps": {k: v for k, v in asdict(spec.footsteps).items() if k != "landings"} | {
                     "landings": [{"side": s, "position_m": list(p)} for s, p in spec.footsteps.landings]},
                 "timing": asdict(spec.timing), "com": asdict(spec.com), "pelvis_rotation": asdict(spec.rotation),
                 "arm_swing": asdict(spec.arms), "ik": asdict(spec.ik), "success": asdict(spec.success)},
        "start_m": {side: [float(v) for v in p] for side, p in walk.timeline.start.items()},
        "steps": [{"side": st.side, "position_m": [float(v) for v in st.position_m], "lift_s": st.t_lift,
                   "land_s": st.t_land} for st in walk.timeline.steps],
        "rows": len(walk.t),
        "duration_s": duration,
        "wall_s": walk.wall_s,
        "realtime_factor": duration / walk.wall_s if walk.wall_s > 0 else None,
        "peak_yaw_rad": _peak(walk.yaw),
        "peak_yaw_rate_rad_s": _peak(walk.yaw_rate),
        "peak_kappa": float(np.max(a.kappa)),
        "mean_kappa": float(np.mean(a.kappa)),
        "peak_kappa_leg": {side: float(np.max(a.kappa_leg[:, k])) for k, side in enumerate(SIDES)},
        "yaw_momentum": {"peak_lower_nms": _peak(walk.h_low), "peak_upper_nms": _peak(walk.h_up),
                         "peak_total_nms": _peak(total),
                         "peak_with_arms_held_nms": result.armless_peak_momentum_nms,
                         "reduction": (None if not result.armless_peak_momentum_nms else
                                       1.0 - _peak(total) / result.armless_peak_momentum_nms)},
        "energy_two_steps_j": a.energy_two_steps_j,
        "least_knee_bend_rad": float(np.min(a.knee_bend_rad)),
        "least_reach_left_m": float(np.min(a.reach_left_m)),
        "least_zmp_margin_m": a.least_zmp_margin_m,
        "peak_friction_ratio": a.peak_friction_ratio,
        "sole_friction": spec.robot.sole_friction,
        "peak_joint_acceleration_rad_s2": a.peak_joint_acceleration_rad_s2,
        "max_foot_error_m": float(np.max(a.foot_error_m)),
        "max_com_error_m": float(np.max(a.com_error_m)),
        "peak_torque_nm": {j: float(v) for j, v in zip(spec.robot.joint_names, tau_peak, strict=True)},
        "peak_torque_ratio": float(np.max(tau_peak / spec.robot.servo_limit_nm)) if len(tau_peak) else 0.0,
        "rehearsal": rehearsal,
    }
