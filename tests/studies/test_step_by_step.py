"""`jethr1 replan-steps`: each step planned from the measured soles to the scenario's landing."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from jethr1_plan.cli import run
from jethr1_plan.errors import InputError
from jethr1_plan.scenario import load_scenario, load_scenario_text
from jethr1_plan.studies.step_by_step import measured_soles, reanchor, step_scenario
from jethr1_plan.swing_path import arc_path
from tests.conftest import ROOT

CONFIG = ROOT / "configs" / "scattered_steps.yaml"


def test_a_reanchored_path_starts_at_the_measured_sole_and_lands_where_it_did():
    path = arc_path(np.array([0.0, 0.1125, 0.0]), np.array([0.27, 0.13, 0.0]), 0.05, 40)
    start = path[0] + np.array([-0.006, 0.004, 0.0])
    moved = reanchor(path, start)
    assert np.array_equal(moved[0], start) and np.array_equal(moved[-1], path[-1])
    shift = np.linalg.norm(moved - path, axis=1)
    assert np.all(np.diff(shift) <= 1e-12) and shift[0] == pytest.approx(np.hypot(0.006, 0.004))
    assert np.array_equal(moved[:, 2], path[:, 2])  # a level offset leaves the heights alone


def test_a_step_from_measured_soles_is_a_valid_one_step_scenario_to_the_same_landing():
    sc = load_scenario(CONFIG)
    feet = {"left": np.array([0.265, 0.128, 0.0]), "right": np.array([0.304, -0.099, 0.0])}
    one = step_scenario(sc, 2, feet)
    assert one.name == "scattered_steps_step2" and len(one.steps) == 1
    assert np.array_equal(one.start["left"], feet["left"]) and np.array_equal(one.start["right"], feet["right"])
    st = one.steps[0]
    assert st.swing == "left" and np.array_equal(st.path_m[0], feet["left"])
    np.testing.assert_array_equal(st.landing_m, sc.steps[2].landing_m)  # a world target, not a displacement
    assert one.cartons == sc.cartons and one.balance == sc.balance
    # a path of points keeps its shape, re-anchored
    doc = yaml.safe_load(sc.text)
    doc["steps"][2]["path"] = {"kind": "points", "points_m": sc.steps[2].path_m.tolist()}
    pts = load_scenario_text(yaml.safe_dump(doc), "points.yaml")
    again = step_scenario(pts, 2, feet)
    np.testing.assert_allclose(again.steps[0].path_m, reanchor(sc.steps[2].path_m, feet["left"]), atol=1e-12)
    # soles measured off their cartons are the scenario's bad input, named
    with pytest.raises(InputError, match=r"start\.left"):
        step_scenario(sc, 2, {**feet, "left": np.array([0.2, 0.4, 0.0])})


def test_the_twin_measures_the_planned_soles_on_the_plans_first_row(tmp_path):
    from jethr1_plan.sim.rehearsal import load_plan

    assert run(["plan", str(ROOT / "configs" / "side_step.yaml"), "-o", str(tmp_path), "--no-progress"]) == 0
    track = load_plan(tmp_path / "side_step")
    soles = measured_soles(track, np.concatenate([track.pelvis[0], track.q[0]]))
    sc = load_scenario(ROOT / "configs" / "side_step.yaml")
    for side in ("left", "right"):
        np.testing.assert_allclose(soles[side][0], sc.start[side], atol=1e-6)
        assert abs(soles[side][1]) < 1e-6


def test_a_bad_scenario_is_exit_2_with_nothing_written(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nsteps: 3\n")
    for path in (tmp_path / "missing.yaml", bad):
        assert run(["replan-steps", str(path), "-o", str(tmp_path / "out"), "--no-progress"]) == 2
    assert not (tmp_path / "out").exists()


def test_replan_steps_plans_rehearses_and_measures_a_step_in_the_twin(tmp_path, capsys):
    """side_step end to end: the step's plan folder verifies, the rehearsal survives, and the landing measured
    in the twin lies within 10 mm of the scenario's landing (its error the measured sole's, not the plan's)."""
    import json

    out = tmp_path / "rs"
    assert run(["replan-steps", str(ROOT / "configs" / "side_step.yaml"), "-o", str(out), "--json",
                "--no-progress"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert json.loads((out / "side_step" / "replan_steps.json").read_text()) == doc
    (step,) = doc["steps"]
    assert doc["all_survived"] and step["survived"] and step["feasible"]
    landed, target = np.array(step["landed_m"]), np.array(step["landing_target_m"])
    assert step["landing_error_m"] == pytest.approx(np.hypot(*(landed - target)[:2]))
    assert 0.0 < step["landing_error_m"] < 0.010 and abs(landed[2] - target[2]) < 0.002
    assert run(["verify", str(out / "side_step" / step["folder"])]) == 0
