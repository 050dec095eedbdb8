"""The SLSQP path optimiser (``--optimiser sqp``): its smooth balance model, and what it must beat."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
import yaml

from jethr1_plan.cli import run
from jethr1_plan.geometry import GRAVITY
from jethr1_plan.optimisers import sqp, sqp_sample
from jethr1_plan.optimisers.exhaustive import exhaustive_cell
from jethr1_plan.planning.plan import plan
from jethr1_plan.planning.problems import feet_before_each_step, path_problems
from jethr1_plan.scenario import load_scenario
from jethr1_plan.studies.compare import step_evaluator
from tests.conftest import ROOT

DITCH = ROOT / "configs" / "forward_ditch_450.yaml"


def _paper_a():
    """The 450 mm ditch as Paper A planned it (the minimal policy: the least thrust)."""
    sc = load_scenario(DITCH)
    return replace(sc, balance=replace(sc.balance, policy="minimal"))


@pytest.fixture(scope="module")
def ditch_plans():
    """GAS, sqp with smoothness a tie-break (ε = 10 N/m²: the least thrust's path) and sqp at its default ε."""
    sc = _paper_a()
    tie = replace(sc, optimiser=replace(sc.optimiser, sqp_smoothness_n_per_m2=10.0))
    return sc, {"gas": plan(sc, method="gas", build_rows=False), "sqp": plan(tie, method="sqp", build_rows=False),
                "default": plan(sc, build_rows=False)}


def _problem(sc, robot, i):
    return path_problems(sc, robot, 0, feet_before_each_step(sc)[0])(i)


def test_smooth_balance_rows_reproduce_the_exact_minimal_thrust(robot, monkeypatch):
    """With the thrust as a variable, the polygon rows b(1−u) − n·(CoM − u·P_T) ≥ 0 hold from
    u = F*/(M·g) on, F* being the exact ray-clipping thrust (A-5), and fail just below it."""
    monkeypatch.setattr(sqp_sample, "ZMP_MARGIN_M", 0.0)
    sc = _paper_a()
    prob = _problem(sc, robot, 55)
    sample = sqp_sample.AnalyticSample(robot, prob, None)
    rng = np.random.default_rng(3)
    P = np.array([0.11, -0.12, 0.21]) + rng.uniform(-0.01, 0.01, (40, 3))
    com, _, thrust = sample.posture_terms(P)
    k = len(sample.offsets)
    checked = 0
    for p, c, t in zip(P, com, thrust, strict=True):
        if not (0 < t < prob.thrust_max_n):
            continue
        u = t / (robot.mass_kg * GRAVITY)
        rows = sample._constraints(np.append(p, u), c[:2], np.zeros(0))[:k]
        below = sample._constraints(np.append(p, u - 1e-6), c[:2], np.zeros(0))[:k]
        assert rows.min() > -1e-9
        assert below.min() < 0
        checked += 1
    assert checked >= 10


def test_restore_brings_a_slightly_infeasible_posture_back(robot):
    sc = _paper_a()
    sample = sqp_sample.AnalyticSample(robot, _problem(sc, robot, 59), None)
    found = plan(sc, method="sqp", build_rows=False).steps[0].samples[59].p_body
    # push the pelvis 0.5 mm away from the swing ankle: the swing (left) leg overstretches
    away = found - (sample.feet["left"][0] + sample.up)
    pushed = found + 0.0005 * away / np.linalg.norm(away)
    _, cons, _ = sample.posture_terms(pushed[None])
    assert cons.min() < -sqp_sample.MARGIN
    ok, _ = sample.feasible(sample.restore(pushed))
    assert ok


def test_sqp_beats_gas_on_thrust_with_ten_times_fewer_evaluations(ditch_plans):
    _, plans = ditch_plans
    gas, opt = plans["gas"], plans["sqp"]
    assert opt.feasible and all(s.feasible for st in opt.steps for s in st.samples)
    tg, to = gas.steps[0].thrust_n, opt.steps[0].thrust_n
    assert to.max() <= tg.max() + 0.05
    assert to.mean() <= tg.mean() + 0.05
    assert 10 * opt.evaluations <= gas.evaluations


def test_the_default_optimiser_dominates_gas(ditch_plans):
    """The default (sqp at ε = 7·10⁴ N/m²) is at least as smooth as GAS at no more max and mean thrust,
    with at least 10x fewer evaluations (the Pareto verdict); smoother than the least thrust's path, and
    its price never raises the path's maximum above that path's."""
    _, plans = ditch_plans
    default, gas, least = plans["default"], plans["gas"], plans["sqp"]
    assert default.method == "sqp" and default.feasible

    def sm(r):
        return float(np.sum(np.diff(r.steps[0].p_body, axis=0) ** 2))

    assert sm(default) <= sm(gas) and sm(default) < sm(least)
    assert default.steps[0].thrust_n.max() <= gas.steps[0].thrust_n.max()
    assert default.steps[0].thrust_n.mean() <= gas.steps[0].thrust_n.mean()
    assert 10 * default.evaluations <= gas.evaluations
    assert default.steps[0].thrust_n.max() <= least.steps[0].thrust_n.max() + 1e-3


def test_sqp_is_within_half_a_percent_of_the_exhaustive_minimum(ditch_plans, robot):
    """An independent dense search (every reachable pelvis on a 1 cm grid, refined on 1 mm) finds
    no posture that needs 0.5 % of the thrust limit less than the optimiser's, on samples along
    the part of the swing that needs thrust."""
    sc, plans = ditch_plans
    ev, cells = step_evaluator(sc, 0)
    thrust = plans["sqp"].steps[0].thrust_n
    for i in (41, 47, 53, 59):
        _, ref, reason = exhaustive_cell(ev, cells, i, 0.01)
        assert reason == 0
        assert thrust[i] <= ref + 0.005 * sc.balance.thrust_max_n, (i, thrust[i], ref)


def test_sqp_crosses_the_ditch_with_a_20_5_n_fan_and_verify_agrees(tmp_path, capsys):
    """GAS needs 20.8 N at the landing sample; the exact optimum is below 20.5 N. With a 20.5 N fan
    sqp plans the whole trajectory and the independent re-check accepts every row."""
    doc = yaml.safe_load(DITCH.read_text())
    doc["balance"] = {"thrust_max_n": 20.5, "policy": "minimal"}
    path = tmp_path / "ditch_20_5.yaml"
    path.write_text(yaml.safe_dump(doc))
    out = tmp_path / "p"
    assert run(["plan", str(path), "--optimiser", "sqp", "-o", str(out), "--json", "--no-progress"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["optimiser"] == "sqp"
    assert summary["peak_thrust_n"] <= 20.5
    assert run(["verify", str(out / path.stem)]) == 0


@pytest.mark.parametrize("name", ["side_step", "jet_hr1_trial", "jet_hr1_trial_robust"])
def test_sqp_plans_every_config_and_its_rows_between_samples_hold(tmp_path, name):
    """The 50 Hz rows interpolate P_body between samples; sqp's postures sit on constraint
    boundaries, so the segments between them are checked (and margins widened where needed): the
    whole trajectory must pass the planner's own check and the independent one."""
    out = tmp_path / "p"
    assert run(["plan", str(ROOT / "configs" / f"{name}.yaml"), "--optimiser", "sqp", "-o", str(out),
                "--no-progress"]) == 0
    assert run(["verify", str(out / name)]) == 0


def test_the_between_check_finds_a_segment_that_cuts_the_edge_cone(robot):
    """Two feasible postures whose straight-line interpolation leaves the (A-10) cone are flagged."""
    sc = _paper_a()
    problem_at = path_problems(sc, robot, 0, feet_before_each_step(sc)[0])

    def between(i, lam):
        return problem_at(i + lam)

    found = [sqp_sample.Found(p, 0.0, True) for p in plan(sc, method="sqp", build_rows=False).steps[0].p_body]
    evals = np.zeros(len(found), dtype=np.int64)
    assert sqp.infeasible_between(robot, found, between, evals) == []
    assert evals.sum() > 0
    # a detour at one sample: its own posture moved to where it still holds, far from both neighbours
    i = 30
    sample = sqp_sample.AnalyticSample(robot, _problem(sc, robot, i), None, margin_scale=0.0)
    rng = np.random.default_rng(0)
    for _ in range(2000):
        p = found[i].p + rng.uniform(-0.06, 0.06, 3)
        if sample.feasible(p)[0]:
            bent = list(found)
            bent[i] = sqp_sample.Found(p, 0.0, True)
            if sqp.infeasible_between(robot, bent, between, evals):
                break
    else:
        pytest.fail("no detour found")
    assert set(sqp.infeasible_between(robot, bent, between, evals)) <= {i - 1, i}
