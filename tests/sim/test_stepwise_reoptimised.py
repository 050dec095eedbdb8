"""A step whose re-anchorings are refused, optimised again from the plan's own samples (``stepwise.reoptimised``,
``optimisers.sqp.resolve_path``) instead of from scratch: the trial's ditch step at nominal, whose landing posture
sits on the swing leg's full stretch, the support knee's limit and the thrust limit at once, so that no share of the
sole's few millimetres of shift the trunk follows keeps it within the legs' reach; and trial 44's step of the route of
terrain seed 2 (``test_stepwise_fallback``), which took the fall-back over a finer path. Every row held to the
scenario's own ρ and μ / 2, restated from the rows (the URDF's own forward kinematics, verify's dynamics), and to the
independent verify."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from jethr1_plan.files.plan_table import plan_table
from jethr1_plan.planning.plan import Sequence, plan, row_solver
from jethr1_plan.planning.report import plan_summary
from jethr1_plan.planning.results import StepResult
from jethr1_plan.records.plan_rows import RowField
from jethr1_plan.scenario import load_scenario
from jethr1_plan.sim import stepwise
from jethr1_plan.sim.reoptimise import ends_reached
from jethr1_plan.sim.stepwise import TRUNK_SHARES, execute, plan_anew, replan_step
from jethr1_plan.verify.plan import verify_rows
from tests.conftest import ROOT
from tests.sim.test_stepwise_fallback import _case, _edge_angles_deg, _friction_ratios


@pytest.fixture(scope="module")
def trial():
    sc = load_scenario(ROOT / "configs" / "jet_hr1_trial.yaml")
    return sc, plan(sc)


def _within_every_limit(sc, result, support_xy: np.ndarray) -> None:
    """Every row of a one-step plan feasible under ``sc``'s own limits: the rows' marks, (A-10)'s edge angle within
    ``sc``'s ρ and the friction the rows' motion needs within μ / 2 (both restated from the rows), and verify's
    checks of the rows (the CoM, ZMP, thrust window, tolerance share, joint limits, from PlaCo's forward kinematics)."""
    rows = result.rows
    assert result.scenario.balance.rho_rad == sc.balance.rho_rad  # the scenario's own ρ, not widened
    assert all(rows.columns[RowField.FEASIBLE])
    assert _edge_angles_deg(sc.robot, rows, support_xy).max() <= math.degrees(sc.balance.rho_rad) + 1e-3
    assert _friction_ratios(sc.robot, rows, 1.0 / sc.timing.rate_hz).max() <= sc.robot.sole_friction / 2.0 + 1e-3
    _, failures = verify_rows(plan_table(sc.robot, rows), sc.robot, summary=plan_summary(result),
                              scenario=result.scenario)
    assert failures == []


def test_the_trial_at_nominal_is_executed_without_a_step_optimised_from_scratch(trial, monkeypatch):
    """``jethr1 simulate`` of the trial (feed-forward, no perturbation): the robot estimates its swing sole 2.7 mm
    behind where step 1 starts and perceives its foothold 3.4 mm off the plan's, 2.7 mm further. Step 0 is
    re-anchored. Step 1's landing posture has the swing leg within 0.2 mm of full stretch and the support ankle's
    pitch within 0.2° of its limit: with the trunk following none or half of the sole's shift the swing leg cannot
    reach the landing, following all of it the support ankle passes its limit, so every re-anchoring is refused at
    the landing itself (``ends_reached``, the rows agree). Optimised again from the plan's samples, the samples near
    the landing move by millimetres and give up the share of the tolerance the longer step costs, no more than an
    optimisation from scratch gives up (0.516 → 0.476 at the landing); no step is optimised from scratch, both land
    within 6 mm of their footholds, every row within the scenario's own limits."""
    sc, nominal = trial

    def from_scratch(*_a, **_k):
        raise AssertionError("a step optimised from scratch")

    monkeypatch.setattr(stepwise, "plan", from_scratch)
    ex = execute(sc, nominal.steps, "feedforward")
    assert ex.run.survived and ex.refused is None
    assert [s["mode"] for s in ex.steps] == ["re-anchored", "re-optimised"]
    assert all(s["landing_error_m"] < 0.006 for s in ex.steps)
    monkeypatch.undo()
    step = ex.plans[1]
    st0 = sc.steps[1]
    # why: the estimated start and the perceived foothold, and the trunk's shares refused at the landing
    assert 0.002 < np.linalg.norm(step.start_m["left"] - sc.steps[0].landing_m) < 0.004
    assert 0.003 < np.linalg.norm(step.target_m - st0.landing_m) < 0.004
    one = step.result.scenario
    path = one.steps[0].path_m
    for share in TRUNK_SHARES:
        shift = share * (path - st0.path_m)
        assert not ends_reached(one, path, nominal.steps[1].p_body + shift)
        moved = StepResult(0, st0.swing, st0.support, path, [replace(x, best=replace(x.best, p_body=x.best.p_body
                                                                                     + shift[i]))
                                                             for i, x in enumerate(nominal.steps[1].samples)],
                           nominal.steps[1].fan_index)
        seq = Sequence(one, sc.robot, row_solver(sc.robot), None, stop_at_infeasible=True)  # as re-anchoring
        bad = seq.add(moved)
        assert (bad or seq.finish()[1]) is not None  # the rows refuse it too
    _within_every_limit(sc, step.result, step.start_m["right"][:2])
    # as robust as the step optimised from scratch from the same stance, sample by sample
    anew, mode = plan_anew(one)
    assert mode == "optimised"
    again = step.result.steps[0]
    assert np.all(again.shares >= anew.steps[0].shares - 0.005)
    assert again.shares[-1] == pytest.approx(0.476, abs=0.005) and nominal.steps[1].shares[-1] > 0.51
    assert np.max(np.linalg.norm(again.p_body - nominal.steps[1].p_body, axis=1)) < 0.006


def test_a_step_of_the_route_that_took_the_fall_back_is_optimised_again_from_its_samples():
    """Trial 44's step 2 of the route of terrain seed 2: its re-anchorings are refused (the (A-10) cone) and, before,
    the plain optimisation too, so the robot planned it over a path with twice the samples (2.5–8 s of a core).
    Optimised again from the plan's own samples it plans in a fraction of that, every row within ρ = 5° and μ / 2."""
    sc, start, target, cartons, _ = _case("trial 44, step 2")
    nominal = plan(sc).steps[0]
    result, mode = replan_step(sc, 0, nominal, start, target, cartons)
    assert mode == "re-optimised" and len(result.steps[0].path_m) == len(sc.steps[0].path_m)
    _within_every_limit(sc, result, start["right"][:2])


def test_the_plans_own_samples_on_their_own_path_are_kept(trial):
    """``resolve_path`` from the plan's own samples on the plan's own path: every sample is kept to the bit, at its
    own share of the tolerance (it holds the sample program already there)."""
    from jethr1_plan.optimisers.sqp import resolve_path
    from jethr1_plan.planning.problems import feet_before_each_step, path_problems

    sc, nominal = trial
    cfg = sc.optimiser
    for k, st in enumerate(nominal.steps):
        problem_at = path_problems(sc, sc.robot, k, feet_before_each_step(sc)[k])
        got = resolve_path(sc.robot, [problem_at(i) for i in range(len(st.path_m))], st.p_body, st.shares,
                           cfg.sqp_smoothness_n_per_m2, cfg.initial.half_range_m)
        assert got is not None
        p_body, shares, _ = got
        np.testing.assert_array_equal(p_body, st.p_body)
        np.testing.assert_array_equal(shares, st.shares)
    assert (nominal.steps[1].shares < 1.0).sum() >= 5  # the ditch's last samples hold a share of the tolerance


def test_a_row_between_two_re_optimised_samples_refused_has_its_segments_solved_again(trial, monkeypatch):
    """``simulate --trials``' first draw of the trial (its IMU law, thrust ×0.80, servos ×1.20, its sensors' errors):
    re-optimised from the plan's samples, step 1 holds every sample, but a swing row between two of them (at the
    share interpolated between theirs) finds no thrust that balances; with those segments solved again as the
    optimiser's last pass does (``sqp.repair_path_between``) the step is re-optimised, every row within the
    scenario's own limits, instead of optimised from scratch."""
    import jethr1_plan.optimisers.sqp as sqp
    from jethr1_plan.sim.certificate import draws
    from jethr1_plan.sim.reoptimise import reoptimised

    sc, nominal = trial
    p = draws(0, 1, "default", None, sc.robot)[0]
    ex = execute(sc, nominal.steps, "feedback", p)
    assert ex.run.survived and [s["mode"] for s in ex.steps] == ["re-anchored", "re-optimised"]
    step = ex.plans[1]
    _within_every_limit(sc, step.result, step.start_m["right"][:2])
    one = step.result.scenario
    half = TRUNK_SHARES[0] * (one.steps[0].path_m - sc.steps[1].path_m)
    monkeypatch.setattr(sqp, "repair_path_between", lambda *a: (_ for _ in ()).throw(AssertionError("repaired")))
    with pytest.raises(AssertionError, match="repaired"):  # the rows of the samples as re-solved are refused
        reoptimised(one, nominal.steps[1], half)
