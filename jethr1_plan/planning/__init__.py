"""Planning: a scenario's problems (:mod:`.problems`), their optimisation and the output-rate sequence
(:mod:`.plan`, :mod:`.sequence`), the commands sent to the robot (:mod:`.commands`), the yaw MPC
(:mod:`.yaw_mpc`) and what a plan reports (:mod:`.report`)."""

from __future__ import annotations

from jethr1_plan.planning.plan import StepJob, build_sequence, optimise_step, plan
from jethr1_plan.planning.problems import feet_before_each_step, path_problems, sample_problem, yaw_function
from jethr1_plan.planning.report import describe_infeasible, plan_summary, robustness_summary, smoothness
from jethr1_plan.planning.results import PlanResult, StepResult

__all__ = ["PlanResult", "StepJob", "StepResult", "build_sequence", "describe_infeasible", "feet_before_each_step",
           "optimise_step", "path_problems", "plan", "plan_summary", "robustness_summary", "sample_problem",
           "smoothness", "yaw_function"]
