"""The route's planning of one route after another (:func:`plan_route`): a route re-planned after a
refusal mostly shares its first steps with the one before, so

* the steps optimised so far are remembered (:attr:`RouteMemo.steps`, by :func:`~jethr1_plan.planning.plan.step_key`):
  each step has a solver of its own, so a remembered step is the one planning it again would compute,
  bit for bit;
* in one process, each step's rows are built as soon as it is optimised and the plan stops at the first
  refused row without optimising the steps after it (a refused step costs no more optimisation), and the
  rows built after each run of first steps are remembered (:attr:`RouteMemo.rows`: they depend on those
  steps alone);
* under the robust policy a swing row whose multibody ZMP stays nearer the sole's edge than
  ``balance.sole_margin_m`` even paced is refused (``strict_dynamics``), so that the search steps around it.

The plan is otherwise :func:`jethr1_plan.planning.plan.plan`'s: the same rows, the same first refused row.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from jethr1_plan.planning.phases import Sequence, build_sequence
from jethr1_plan.planning.plan import (
    Progress,
    finish_plan,
    one_blas_thread,
    optimise_step,
    parallel_steps,
    plan_parts,
    row_solver,
    step_jobs,
    step_key,
)
from jethr1_plan.planning.results import PlanResult, StepResult
from jethr1_plan.records.infeasible import Infeasible
from jethr1_plan.scenario import Scenario

__all__ = ["RouteMemo", "plan_route"]


@dataclass
class RouteMemo:
    """What one route's planning leaves for the next: the optimised steps (by step key) and the rows built
    after each run of first steps (by their keys)."""

    steps: dict = field(default_factory=dict)
    rows: dict = field(default_factory=dict)


def plan_route(scenario: Scenario, memo: RouteMemo, jobs: int = 1, progress: Progress | None = None) -> PlanResult:
    """Plan a route's scenario, re-using and filling ``memo``; ``jobs`` processes optimise the steps not
    remembered (the result does not depend on it).

    Raises:
        InfeasibleAt: at the first refused sample or row.
    """
    with one_blas_thread():
        t0 = time.perf_counter()
        cfg = scenario.optimiser
        todo, schedule = step_jobs(scenario, cfg, scenario.seed)
        keys = [step_key(job) for job in todo]
        total = sum(len(s.path_m) for s in scenario.steps)
        if jobs > 1 and len(todo) > 1:
            steps, first_bad = _optimise_parallel(todo, keys, memo, jobs, progress, total)
            early = None
        else:
            early = Sequence(scenario, scenario.robot, row_solver(scenario.robot), schedule, True, True)
            steps, first_bad, bad_row = _optimise_and_build(todo, keys, memo, early, progress, total)
        parts = plan_parts(scenario, cfg.method, scenario.seed, steps, first_bad, t0)
        if first_bad is not None:
            return finish_plan(parts, None, None)
        if early is None:
            rows, bad_row = build_sequence(scenario, scenario.robot, row_solver(scenario.robot), steps, schedule,
                                           stop_at_infeasible=True, strict_dynamics=True)
        elif bad_row is not None:
            rows = early.seq.rows
        else:
            rows, bad_row = early.finish()
        return finish_plan(parts, rows, bad_row)


def _optimise_parallel(todo, keys, memo: RouteMemo, jobs: int, progress: Progress | None, total: int
                       ) -> tuple[list[StepResult], Infeasible | None]:
    """Every step, the ones not remembered optimised in ``jobs`` processes; up to the first refused one."""
    fresh = parallel_steps([job for job, key in zip(todo, keys, strict=True) if key not in memo.steps], jobs)
    outcomes = []
    for k, key in enumerate(keys):
        if key not in memo.steps:
            memo.steps[key] = next(fresh)
        outcomes.append(memo.steps[key])
        if progress:
            progress(f"step {k}", sum(len(o[0].samples) for o in outcomes), total)
    return _up_to_refusal(outcomes)


def _optimise_and_build(todo, keys, memo: RouteMemo, early: Sequence, progress: Progress | None, total: int
                        ) -> tuple[list[StepResult], Infeasible | None, Infeasible | None]:
    """Step by step: optimise (unless remembered), then build its rows (unless remembered); stop at the first
    refused sample (second: it) or row (third: it)."""
    outcomes: list[tuple[StepResult, Infeasible | None]] = []
    done = 0
    for k, job in enumerate(todo):
        if keys[k] not in memo.steps:
            memo.steps[keys[k]] = optimise_step(job, None, progress, done, total)
        out = memo.steps[keys[k]]
        outcomes.append(out)
        done += len(out[0].samples)
        if out[1] is not None:
            break
        prefix = tuple(keys[:k + 1])
        if prefix in memo.rows:
            early.resume(memo.rows[prefix])
            continue
        bad_row = early.add(out[0])
        if bad_row is not None:
            return [o[0] for o in outcomes], None, bad_row
        memo.rows[prefix] = early.state()
    steps, first_bad = _up_to_refusal(outcomes)
    return steps, first_bad, None


def _up_to_refusal(outcomes: list[tuple[StepResult, Infeasible | None]]
                   ) -> tuple[list[StepResult], Infeasible | None]:
    steps: list[StepResult] = []
    for st, bad in outcomes:
        steps.append(st)
        if bad is not None:
            return steps, bad
    return steps, None
