"""A step of a plan executed step by step (:mod:`.stepwise`) whose re-anchorings the rows refuse, optimised again
from the plan's own samples instead of from scratch (*re-optimised*), and the test that spares building a
re-anchoring the rows would refuse at its ends.

Why: a plan's posture may sit on several limits at once (the trial's ditch landing: the swing leg at full stretch,
the support ankle at its limit, the fans at 23 N), so that no share of the swing sole's few millimetres of shift the
trunk follows keeps it within them, and the share of the tolerance the robot's longer step leaves is smaller than
the plan's. The planner's own sample program (:func:`~jethr1_plan.optimisers.sqp.resolve_path`) solved from the
plan's samples moves only the samples that need it, by millimetres, and gives up only the share the new ends cost;
every row is then built and checked under the scenario's own limits, as any plan's.
"""

from __future__ import annotations

import numpy as np

from jethr1_plan.planning.plan import Sequence, add_analysis, row_solver
from jethr1_plan.planning.results import PlanResult, StepResult
from jethr1_plan.records.plan_rows import RowField
from jethr1_plan.scenario import Scenario

__all__ = ["ends_reached", "reoptimised", "step_plan"]


def ends_reached(one: Scenario, path_m: np.ndarray, p_body_m: np.ndarray) -> bool:
    """Whether both legs reach, within their joint limits, the postures of the first and last samples of the one-step
    scenario ``one``'s swing ``path_m`` (N, 3) with P_body ``p_body_m`` (N, 3) [m]: the rows that stand exactly there
    (the swing's first row, and the first of the transfer after the landing) are feasible only where they do. Solved
    in closed form as the row builder solves them (the same postures to the bit; True, nothing checked, for a robot
    whose legs have no closed form)."""
    from jethr1_plan.kinematics.closed_form import ClosedFormPostureSolver, solve_postures
    from jethr1_plan.planning.problems import yaw_function
    from jethr1_plan.reasons import Reason

    robot, st = one.robot, one.steps[0]
    if not isinstance(row_solver(robot), ClosedFormPostureSolver):
        return True
    yaw_of_swing = yaw_function(one, robot, st.support, one.start[st.support])
    ends = path_m[[0, -1]]
    _, _, status = solve_postures(robot, p_body_m[[0, -1]], np.array([float(yaw_of_swing(p)) for p in ends]),
                                  {st.support: (one.start[st.support], 0.0), st.swing: (ends, 0.0)})
    return bool(np.all(status == Reason.OK))


def reoptimised(one: Scenario, nominal: StepResult, shift_m: np.ndarray) -> PlanResult | None:
    """The one-step scenario ``one`` optimised again from the plan's own samples ``nominal``, their trunk moved by
    ``shift_m`` (N, 3) [m] (:func:`~jethr1_plan.optimisers.sqp.resolve_path`: each posture kept where it holds the
    planner's sample program at its share of the tolerance, else solved from there): its rows built by the planner's
    row builder under the scenario's own limits (ρ too) and analysed; where a row between two samples is not
    feasible, the segments whose rows break a constraint solved again as the optimiser's last pass does
    (:func:`~jethr1_plan.optimisers.sqp.repair_path_between`) and the rows built again. None where a sample finds
    no posture or a row is still not feasible. Called within ``planning.plan.one_blas_thread`` (as
    :func:`~jethr1_plan.sim.stepwise.replan_step` calls it), its answer does not depend on the BLAS's threads."""
    from jethr1_plan.control.time_laws import swing_row_positions
    from jethr1_plan.optimisers.sqp import repair_path_between, resolve_path
    from jethr1_plan.planning.problems import path_problems

    robot, st, cfg = one.robot, one.steps[0], one.optimiser
    problem_at = path_problems(one, robot, 0, one.start)
    problems = [problem_at(i) for i in range(len(st.path_m))]
    got = resolve_path(robot, problems, nominal.p_body + shift_m, nominal.shares, cfg.sqp_smoothness_n_per_m2,
                       cfg.initial.half_range_m)
    if got is None:
        return None
    result = _planned(one, nominal, problems, *got)
    if result is None:  # a row between two samples: those segments solved again, as the optimiser's last pass does
        positions = swing_row_positions(len(problems), one.timing.swing_s, one.timing.rate_hz)
        result = _planned(one, nominal, problems, *repair_path_between(
            robot, problems, got[0], got[1], cfg.sqp_smoothness_n_per_m2, cfg.initial.half_range_m,
            lambda i, lam: problem_at(i + lam), positions))
    return result


def _planned(one: Scenario, nominal: StepResult, problems: list, p_body: np.ndarray, shares: np.ndarray,
             evals: np.ndarray) -> PlanResult | None:
    """The one-step plan of the postures ``p_body`` (N, 3) [m] holding ``shares`` (N,) of their ``problems``'
    tolerances: its rows built and analysed under ``one``'s own limits; None where a row is not feasible."""
    from jethr1_plan.optimisers import SampleResult
    from jethr1_plan.optimisers.problem import evaluate_candidates, fitness
    from jethr1_plan.optimisers.sqp_share import scaled

    st, cfg = one.steps[0], one.optimiser
    solver = row_solver(one.robot)
    samples = []
    for i, pr in enumerate(problems):
        cand = evaluate_candidates(solver, scaled(pr, float(shares[i])), p_body[i][None])
        samples.append(SampleResult(cand, float(fitness(cand, cfg.constants)[0]), int(evals[i]), "sqp",
                                    float(shares[i])))
    step = StepResult(0, st.swing, st.support, st.path_m, samples, nominal.fan_index)
    return step_plan(one, step, "re-optimised", int(evals.sum()))


def step_plan(one: Scenario, step: StepResult, method: str, evaluations: int = 0) -> PlanResult | None:
    """The one-step plan of ``step`` (its samples chosen) in the one-step scenario ``one``: its rows built by the
    planner's row builder and analysed under ``one``'s own limits; None where a row is not feasible."""
    robot = one.robot
    seq = Sequence(one, robot, row_solver(robot), None, stop_at_infeasible=True)
    bad = seq.add(step)
    rows, bad = (seq.seq.rows, bad) if bad is not None else seq.finish()
    if bad is None:
        bad = add_analysis(rows, robot, 1.0 / one.timing.rate_hz, False)
    if bad is not None or not all(rows.columns[RowField.FEASIBLE]):
        return None
    return PlanResult(one, robot, method, one.seed, [step], rows, None, evaluations, 0.0)
