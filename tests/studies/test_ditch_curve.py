"""`jethr1 ditch-curve`: the most robust crossing of each ditch and the widest ditch per tolerance, from plans the
planner itself makes."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from jethr1_plan.cli import run
from jethr1_plan.errors import InfeasiblePlan
from jethr1_plan.planning.plan import plan
from jethr1_plan.planning.report import share_summary
from jethr1_plan.scenario import ROBUST_DEFAULT
from jethr1_plan.studies.ditch_curve import default_base, ditch_scenario, landing_x
from jethr1_plan.swing_path import sole_on_carton


def test_the_geometry_is_paper_as():
    sc = ditch_scenario(default_base(), 0.45, ROBUST_DEFAULT, 0.16)
    landing = sc.steps[0].landing_m
    np.testing.assert_allclose(landing, [0.615, -0.1125, 0.0])  # configs/forward_ditch_450.yaml
    b = sc.cartons[2]
    assert abs(b.top_rectangle()[0] - 0.080 - 0.45) < 1e-12  # carton B's rear edge, 0.45 m past A's front
    assert sole_on_carton(landing, 0.0, 0.16, 0.09, b) and landing_x(0.30, 0.16) == 0.465


def test_wider_ditches_need_more_thrust_and_tolerance_narrows_them(tmp_path, capsys):
    out = tmp_path / "dc"
    assert run(["ditch-curve", "--gaps", "0.30:0.44:0.07", "--scales", "0,1", "--optimiser", "sqp", "-j", "2",
                "-o", str(out), "--json", "--no-progress"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["gaps_m"] == [0.30, 0.37, 0.44]
    minimal, robust = doc["tolerances"]
    assert minimal["thrust_error"] == 0 and robust["thrust_error"] == 0.1 and robust["com_error_m"] == 0.01
    # Paper A's policy crosses all three; thrust grows with the gap
    f = minimal["peak_thrust_n"]
    assert all(v is not None for v in f) and f[0] < f[1] < f[2] <= 23.0
    assert minimal["widest_gap_m"] == 0.44 and minimal["thrust_at_widest_n"] == f[2]
    # the robust policy needs more thrust for the same gap and cannot cross 0.44 m
    assert robust["peak_thrust_n"][0] > f[0] and robust["peak_thrust_n"][2] is None
    assert robust["widest_gap_m"] in (0.30, 0.37) and "infeasible" in robust["reason"][2]
    assert (out / "ditch_curve.png").read_bytes()[:4] == b"\x89PNG"
    assert json.loads((out / "ditch_curve.json").read_text()) == doc


def test_bad_gaps_are_exit_2(tmp_path):
    for gaps in ("0.3:0.2:0.01", "a:b:c", "0.3:0.5:0", "0.3:nan:0.01", "0.001:100:0.0001"):
        assert run(["ditch-curve", "--gaps", gaps, "-o", str(tmp_path / "x"), "--no-progress"]) == 2
    assert not (tmp_path / "x").exists()


def test_the_share_reported_for_a_gap_is_one_a_plan_holds_and_wider_gaps_hold_less(tmp_path, capsys):
    """The default optimiser (sqp) on 0.40, 0.43, 0.46 m: the share falls (or stays) as the gap widens and
    stays in (0, 1); at the widest gap, the whole of share × T planned as a fixed tolerance is feasible with
    every row holding all of it, and asking the objective plan for 0.02 more share than reported is exit 3."""
    out = tmp_path / "dc"
    assert run(["ditch-curve", "--gaps", "0.40:0.46:0.03", "--scales", "", "-j", "2", "-o", str(out), "--json",
                "--no-progress"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["optimiser"] == "sqp" and doc["tolerances"] == []
    rob = doc["robustness"]
    assert [r["gap_m"] for r in rob] == [0.40, 0.43, 0.46]
    shares = [r["share"] for r in rob]
    assert all(s is not None and 0.0 < s < 1.0 for s in shares), shares
    assert shares[0] >= shares[1] >= shares[2], shares
    assert all(r["peak_thrust_n"] <= 23.0 + 1e-9 and r["mean_thrust_n"] < r["peak_thrust_n"] for r in rob)
    held = rob[2]["tolerance"]
    assert held["thrust_error"] == pytest.approx(0.1 * shares[2])
    assert held["com_error_m"] == pytest.approx(0.01 * shares[2])

    base = default_base()
    fixed = ditch_scenario(base, 0.46, base.balance.robust.scaled(shares[2] - 1e-3), 0.16)
    result = plan(replace(fixed, balance=replace(fixed.balance, min_share=1.0)))
    assert result.feasible
    assert share_summary(result.rows, fixed.balance.tolerance)["least"] > 1.0 - 1e-3
    greedy = ditch_scenario(base, 0.46, base.balance.robust, 0.16)
    with pytest.raises(InfeasiblePlan, match="min_share"):
        plan(replace(greedy, balance=replace(greedy.balance, min_share=shares[2] + 0.02)))
