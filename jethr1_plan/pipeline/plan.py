"""A scenario planned and written: the plan (:func:`jethr1_plan.planning.plan.plan`), its
``summary.json``, its optimised steps (``optimised_steps.json``, :mod:`jethr1_plan.files.plan_steps`), and
the trajectory files, which are re-checked by the independent verifier
(:func:`jethr1_plan.verify.plan.verify_rows`) before anything is written: a plan that fails its own
re-check is a bug and leaves no file behind."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from jethr1_plan.errors import InfeasiblePlan, SelfCheckFailed
from jethr1_plan.files.plan_csv import read_trajectory_csv
from jethr1_plan.files.plan_folder import write_plan, write_summary_only
from jethr1_plan.files.plan_steps import scenario_steps_key
from jethr1_plan.planning.plan import plan
from jethr1_plan.planning.report import plan_summary
from jethr1_plan.planning.results import PlanResult
from jethr1_plan.scenario import Scenario
from jethr1_plan.verify.plan import verify_rows

__all__ = ["plan_to_folder", "self_check"]


def self_check(csv_text: str, result: PlanResult, summary: dict, strict_torque: bool) -> None:
    """Run ``verify`` on the trajectory's CSV text before anything is written.

    Raises:
        SelfCheckFailed: the plan fails its own re-check (a bug).
    """
    _, failures = verify_rows(read_trajectory_csv(csv_text, robot=result.robot), result.robot, summary=summary,
                              scenario=result.scenario, torque_limits=strict_torque, max_failures=5)
    if failures:
        raise SelfCheckFailed("the planned trajectory fails its own re-check: " + "; ".join(map(str, failures)))


def plan_to_folder(scenario: Scenario, outdir: Path, *, strict_torque: bool = False, write_infeasible: bool = False,
                   **plan_options: Any) -> tuple[PlanResult, dict, Path, list[str]]:
    """Plan ``scenario`` and write OUTDIR/<stem>/; (result, summary, folder, the user's files kept there).

    ``plan_options`` go to :func:`~jethr1_plan.planning.plan.plan` (method, seed, progress, jobs,
    kinematics). With ``write_infeasible`` an infeasible plan is written with its rows marked.

    Raises:
        InfeasiblePlan: no feasible plan (summary.json alone written, unless ``write_infeasible``).
    """
    try:
        result = plan(scenario, keep_going=write_infeasible, strict_torque=strict_torque, **plan_options)
    except InfeasiblePlan as exc:
        exc.written = write_summary_only(scenario, outdir, exc.summary)
        raise
    summary = plan_summary(result)
    key = scenario_steps_key(result.scenario, result.method, result.seed)
    folder, kept = write_plan(result, outdir, summary, trajectory=True,
                              check=lambda text: self_check(text, result, summary, strict_torque), steps_key=key)
    return result, summary, folder, kept
