"""SQP's share stage: the largest share of the tolerance a swing sample reaches, as a smooth program."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from jethr1_plan.optimisers.sqp_sample import AnalyticSample
from jethr1_plan.optimisers.sqp_share import max_share, scaled
from jethr1_plan.physics.share import largest_shares
from jethr1_plan.planning.plan import plan
from jethr1_plan.planning.problems import feet_before_each_step, path_problems
from jethr1_plan.scenario import load_scenario
from tests.conftest import ROOT


@pytest.fixture(scope="module")
def landing():
    """The 450 mm ditch's landing sample (59) and the posture Paper A's least-thrust plan puts there."""
    sc = load_scenario(ROOT / "configs" / "forward_ditch_450.yaml")
    minimal = plan(replace(sc, balance=replace(sc.balance, policy="minimal")), build_rows=False)
    problem = path_problems(sc, sc.robot, 0, feet_before_each_step(sc)[0])(59)
    return sc, problem, minimal.steps[0].samples[59].p_body


def test_the_stage_one_share_holds_and_no_nearby_posture_holds_more(landing):
    """Stage 1's posture balances at (s − 0.002) × the tolerance with every other constraint held;
    brute force over postures within 8 mm of it (2 mm grid, every P-only constraint held) finds none
    whose largest share (``physics.share``, the window's own bisection) exceeds s by 0.01."""
    sc, problem, p0 = landing
    full = AnalyticSample(sc.robot, problem, None)
    s, p = max_share(full, p0, 0.02)
    assert 0.3 < s < 0.8  # 0.518 measured; the whole tolerance does not fit within 23 N
    ok, thrust = AnalyticSample(sc.robot, scaled(problem, s - 0.002), None).feasible(p)
    assert ok and thrust <= 23.0
    assert not AnalyticSample(sc.robot, scaled(problem, min(1.0, s + 0.05)), None).feasible(p)[0]
    ax = np.arange(-0.008, 0.0081, 0.002)
    grid = p + np.stack(np.meshgrid(ax, ax, ax, indexing="ij"), axis=-1).reshape(-1, 3)
    com, cons, _ = full.posture_terms(grid)
    held = np.all(cons >= 0, axis=1)
    shares = largest_shares(com[held, :2], problem.fans_at(grid[held]), problem.support_polygon, problem.mass_kg,
                            problem.tolerance, np.array([23.0]))
    assert held.sum() >= 20 and shares.max() <= s + 0.01  # the swing leg near its stretch: few postures hold
    com_p = full.posture_terms(p[None])[0][:, :2]
    own = float(largest_shares(com_p, problem.fans_at(p[None]), problem.support_polygon, problem.mass_kg,
                               problem.tolerance, np.array([23.0]))[0])
    assert own == pytest.approx(s, abs=0.005)  # the smooth rows and the window agree (the rows keep 0.1 mm margin)


def test_a_sample_that_reaches_the_whole_tolerance_reports_share_one(landing):
    sc, _, _ = landing
    problem = path_problems(sc, sc.robot, 0, feet_before_each_step(sc)[0])(30)
    r = plan(sc, build_rows=False).steps[0]
    assert r.samples[30].share == 1.0 and r.samples[59].share < 0.6
    shares = r.shares
    assert np.all(np.diff(shares[50:]) <= 1e-9)  # falling towards the landing, where the window is narrowest
    full = AnalyticSample(sc.robot, problem, None)
    s, _ = max_share(full, r.samples[30].p_body, 0.02)
    assert s == 1.0
