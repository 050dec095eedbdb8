"""A written multi-step plan (a scenario's or a route's) executed step by step in the twin, as the robot
would (``jethr1 simulate`` of a plan of several steps; ``jethr1 replan-steps``, its alias, plans a
scenario first): each step planned again from where the robot estimates its soles stand
(:mod:`jethr1_plan.sim.stepwise`), in one continuous twin run; randomised trials of it; and the steps
executed, written as a plan folder of their own (``PLAN_DIR/executed/``).

The steps' own optimised postures are the plan's: those ``jethr1 plan`` kept in the folder
(``optimised_steps.json``, :mod:`jethr1_plan.files.plan_steps`) where they are the folder's plan's;
else (a folder of an earlier jethr1, a route's, a file that is stale or does not read) the plan folder's
scenario is planned again here (``planning.plan``, its optimiser and seed from ``summary.json``), and its
rows must be the folder's, or the folder is not the plan its scenario makes now (another version, other
options): bad input.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.files.plan_folder import PLAN_FILES, write_plan
from jethr1_plan.files.plan_steps import scenario_steps_key, stored_steps
from jethr1_plan.files.plan_table import joint_matrix, plan_table
from jethr1_plan.folders.plan import plan_scenario
from jethr1_plan.planning.plan import plan
from jethr1_plan.planning.report import plan_summary
from jethr1_plan.planning.results import StepResult
from jethr1_plan.scenario import Scenario
from jethr1_plan.sim.stepwise import MODES, Execution, execute, executed_plan
from jethr1_plan.sim.track import Perturbation, PlanTrack

__all__ = ["EXECUTED", "EXECUTED_FILES", "execution_record", "nominal_plan", "run_steps", "write_executed"]

EXECUTED = "executed"  # the executed steps' plan folder, inside the plan folder
EXECUTED_FILES = PLAN_FILES | {"executed.yaml"}


def nominal_plan(folder: Path, summary: dict, track: PlanTrack, note: Callable[[str], None] | None = None
                 ) -> tuple[Scenario, list[StepResult]]:
    """The plan folder's scenario (its policy as ``summary.json`` states it) and its steps as the planner
    optimised them: those the folder keeps where they are its plan's, else optimised again now (``note`` is
    told why, in one line).

    Raises:
        InputError: no scenario to plan from, or its plan is not the folder's.
    """
    scenario = plan_scenario(folder, summary)
    if scenario is None:
        raise InputError(str(folder / "summary.json"), "scenario_yaml", "no scenario to plan each step from")
    policy = (summary.get("balance") or {}).get("policy")
    if policy in ("robust", "minimal") and policy != scenario.balance.policy:
        scenario = replace(scenario, balance=replace(scenario.balance, policy=policy))
    method, seed = summary.get("optimiser"), summary.get("seed")
    if isinstance(method, str) and type(seed) is int:
        key = scenario_steps_key(scenario, method, seed)
        steps, why = stored_steps(folder, summary, key, len(scenario.robot.joint_names))
        if steps is not None:
            return scenario, [StepResult(st.index, st.swing, st.support, st.path_m, st.samples, st.fan_index)
                              for st in steps]
        if note is not None:
            note(f"{why}; optimising the plan's steps again")
    result = plan(scenario, method=method, seed=seed)
    assert result.rows is not None
    again = joint_matrix(plan_table(result.robot, result.rows), result.robot)
    if again.shape != track.q.shape or float(np.max(np.abs(again - track.q))) > 1e-9:
        raise InputError(str(folder / "trajectory.csv"), "", "not the plan its scenario makes now (planned by another "
                         "version or with other options): plan it again before simulating it step by step")
    return scenario, result.steps


def _trial(folder: str, summary: dict, steps: list[StepResult], controller: str, p: Perturbation, seed: int,
           record: bool) -> Execution:
    scenario = plan_scenario(Path(folder), summary)
    assert scenario is not None
    policy = (summary.get("balance") or {}).get("policy")
    if policy in ("robust", "minimal") and policy != scenario.balance.policy:
        scenario = replace(scenario, balance=replace(scenario.balance, policy=policy))
    return execute(scenario, steps, controller, p, seed, record, float(summary["thrust_max_n"]))


def run_steps(folder: Path, summary: dict, scenario: Scenario, steps: list[StepResult], controller: str,
              perturbations: list[Perturbation], jobs: int = 1, progress=None, seed: int = 0) -> list[Execution]:
    """Every perturbation's step-by-step run (the first recorded), in order; the results do not depend on
    ``jobs``."""
    thrust_max = float(summary["thrust_max_n"])
    if jobs <= 1 or len(perturbations) == 1:
        out = []
        for k, p in enumerate(perturbations):
            out.append(execute(scenario, steps, controller, p, seed, k == 0, thrust_max))
            if progress:
                progress(f"run {k + 1}", k + 1, len(perturbations))
        return out
    from joblib import delayed

    from jethr1_plan.io.pool import parallel

    out = []
    tasks = [delayed(_trial)(str(folder), summary, steps, controller, p, seed, k == 0)
             for k, p in enumerate(perturbations)]
    for k, r in enumerate(parallel(jobs, return_as="generator")(tasks)):
        out.append(r)
        if progress:
            progress(f"run {k + 1}", k + 1, len(perturbations))
    return out


def execution_record(ex: Execution) -> dict[str, Any]:
    """A step-by-step run's own record for ``simulation.json``: per step how it was planned, the foothold,
    the perceived one, where the sole landed and its error against the foothold, the judge's parts; the
    step the robot could not plan."""
    errors = [s["landing_error_m"] for s in ex.steps if "landing_error_m" in s]
    return {"steps": ex.steps, "refused": ex.refused,
            "max_landing_error_m": max(errors) if errors else None,
            "re_anchored": sum(s["mode"] == "re-anchored" for s in ex.steps),
            "optimised": sum(s["mode"] == "optimised" for s in ex.steps),
            "modes": {m: sum(s["mode"] == m for s in ex.steps) for m in MODES}}


def write_executed(folder: Path, scenario: Scenario, ex: Execution) -> tuple[Path, bool]:
    """``folder/executed/``: the executed steps as a plan folder (:func:`~jethr1_plan.sim.stepwise.executed_plan`),
    with its scenario ``executed.yaml`` where it is one; (the folder, whether its rows are all feasible)."""
    target = Path(folder) / EXECUTED
    result, text = executed_plan(scenario, ex, target)
    summary = plan_summary(result)
    summary["executed"] = {"from": str(Path(folder).resolve()), "steps": len(result.steps),
                           "note": "the steps as executed step by step in the twin (docs/rehearsal.md)"}
    write_plan(result, target, summary, folder=target, extra={"executed.yaml": text.encode()} if text else {},
               own=EXECUTED_FILES)
    return target, result.feasible
