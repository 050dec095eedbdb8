"""From a scenario to the optimisers' problems: per step the swing samples, their stances and balance settings."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from jethr1_plan.geometry import other_side, sole_polygon
from jethr1_plan.kinematics import Stance
from jethr1_plan.optimisers.problem import SampleProblem
from jethr1_plan.physics.balance import body_yaw_eq4, body_yaw_forward_axis
from jethr1_plan.robot.model import RobotModel, fan_ground_xy
from jethr1_plan.scenario import Scenario

__all__ = [
    "NOMINAL_HEIGHT_FRACTION",
    "feet_before_each_step",
    "nominal_p_body",
    "path_problems",
    "sample_problem",
    "yaw_function",
]

NOMINAL_HEIGHT_FRACTION = 0.8  # centre of the initial phase's box: pelvis height over the support sole, in leg lengths


def yaw_function(scenario: Scenario, robot: RobotModel, support: str, support_xyz: np.ndarray):
    """Body yaw [rad] as a function of the swing sole position, per the scenario's mode."""
    swing = other_side(support)
    fan = robot.fan_for(swing)  # turns the trunk towards the swing foot's fan (its sole without one)
    off = np.asarray(fan.offset_m[:2]) if fan is not None else np.zeros(2)
    if scenario.yaw_mode in ("eq4", "mpc"):  # mpc smooths this reference (yaw_mpc.build_schedule)
        return lambda sw: float(body_yaw_eq4(support_xyz[:2], sw[:2] + off, support))
    if scenario.yaw_mode == "forward_axis":
        return lambda sw: float(body_yaw_forward_axis(support_xyz[:2], sw[:2] + off))
    return lambda sw: scenario.body_yaw.fixed_rad


def sample_problem(scenario: Scenario, robot: RobotModel, support: str, support_xyz: np.ndarray,
                   swing_xyz: np.ndarray, yaw: float) -> SampleProblem:
    """The optimisation problem at one swing sample: the fans that may thrust are the swing sole's
    and the trunk's (a trunk fan's row of ``fan_xy`` is its offset from P_body, turned by ``yaw``)."""
    swing = other_side(support)
    index = robot.swing_fans(swing)
    fans = [robot.fans[i] for i in index]
    soles = {support: support_xyz, swing: swing_xyz}
    fan_xy = np.array([fan_ground_xy(f, soles, np.zeros(3), yaw) for f in fans]).reshape(len(fans), 2)
    stance = Stance(support, support_xyz, 0.0, swing_xyz, 0.0, yaw)
    poly = sole_polygon(support_xyz[:2], 0.0, robot.sole_length_m, robot.sole_width_m, scenario.balance.sole_margin_m)
    return SampleProblem(stance=stance, fan_xy=fan_xy, ankle_xy=swing_xyz[:2].copy(), edge_origin_xy=support_xyz[:2],
                         support_polygon=poly, mass_kg=robot.mass_kg, thrust_max_n=scenario.balance.thrust_max_n,
                         rho_rad=scenario.balance.rho_rad, tolerance=scenario.balance.tolerance,
                         fan_on_trunk=np.array([f.on_trunk for f in fans], dtype=bool),
                         fan_max_n=np.array([f.thrust_max_n for f in fans], dtype=float),
                         fan_index=np.array(index, dtype=np.int64))


def path_problems(scenario: Scenario, robot: RobotModel, si: int, feet: dict[str, np.ndarray],
                  sample_yaw: np.ndarray | None = None) -> Callable[[float], SampleProblem]:
    """``problem_at(u)``: the problem with the swing sole at path parameter ``u`` of step ``si``
    (sample index, fractional between samples, interpolated as the sequence's rows are); the body
    yaw from the scenario's mode, or interpolated in ``sample_yaw`` (the MPC schedule's samples)."""
    step = scenario.steps[si]
    support = step.support
    yaw_of = yaw_function(scenario, robot, support, feet[support])
    idx = np.arange(len(step.path_m))

    def problem_at(u: float) -> SampleProblem:
        swing = np.array([np.interp(u, idx, step.path_m[:, j]) for j in range(3)])
        yaw = yaw_of(swing) if sample_yaw is None else float(np.interp(u, idx, sample_yaw))
        return sample_problem(scenario, robot, support, feet[support], swing, yaw)

    return problem_at


def feet_before_each_step(scenario: Scenario) -> list[dict[str, np.ndarray]]:
    """Both sole positions [m] at the start of every step."""
    feet = {k: v.copy() for k, v in scenario.start.items()}
    out = []
    for step in scenario.steps:
        out.append({k: v.copy() for k, v in feet.items()})
        feet[step.swing] = step.landing_m.copy()
    return out


def nominal_p_body(scenario: Scenario, robot: RobotModel, support_xyz: np.ndarray, path_m: np.ndarray) -> np.ndarray:
    """(N, 3) per swing sample the centre of the initial search box [m]: halfway between the soles,
    ``nominal_height_m`` (or 0.8 leg lengths) over the support sole."""
    z_nom = scenario.nominal_height_m or NOMINAL_HEIGHT_FRACTION * robot.leg_length_m
    mid = 0.5 * (support_xyz[:2] + path_m[:, :2])
    return np.column_stack([mid, np.full(len(path_m), support_xyz[2] + z_nom)])
