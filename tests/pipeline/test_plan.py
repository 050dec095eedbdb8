"""pipeline.plan: a scenario planned, re-checked by the independent verifier before anything is written, and
written; a plan that fails its own re-check leaves no file, an infeasible one only its summary.json."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from jethr1_plan.errors import InfeasiblePlan, SelfCheckFailed
from jethr1_plan.files.plan_csv import read_trajectory_csv
from jethr1_plan.pipeline import plan as pipeline
from jethr1_plan.scenario import load_scenario_text
from tests.conftest import ROOT

SIDE_STEP = (ROOT / "configs" / "side_step.yaml").read_text()


def _side_step(samples: int = 60, **balance: float):
    """The side step, its swing path of ``samples`` samples (an infeasible plan is found as soon with 6: with
    ``thrust_max_n`` 0.5, 0.8 s of CPU against 13.5 s with 60), its ``balance`` values in place of 23.0."""
    text = SIDE_STEP.replace("samples: 60", f"samples: {samples}")
    for key, value in balance.items():
        text = text.replace(f"  {key}: 23.0", f"  {key}: {value}")
    return load_scenario_text(text, "side_step.yaml")


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    out = tmp_path_factory.mktemp("pipeline")
    result, summary, folder, kept = pipeline.plan_to_folder(_side_step(), out)
    return result, summary, folder, kept


def test_the_folder_holds_what_was_planned_and_checked(planned) -> None:
    result, summary, folder, kept = planned
    assert folder.name == "side_step" and kept == []
    assert json.loads((folder / "summary.json").read_text()) == json.loads(json.dumps(summary))
    c = read_trajectory_csv((folder / "trajectory.csv").read_text(), robot=result.robot)
    assert len(c["time_s"]) == summary["row_count"] == len(result.rows)
    # the written thrust never exceeds the scenario's limit (23 N) on any fan
    thrust = np.column_stack([c[f"thrust_{f.name}_n"] for f in result.robot.fans])
    assert float(thrust.max()) <= 23.0 + 1e-9
    pipeline.self_check((folder / "trajectory.csv").read_text(), result, summary, strict_torque=False)


def test_a_row_the_verifier_refuses_is_a_self_check_failure(planned) -> None:
    result, summary, folder, _ = planned
    text = (folder / "trajectory.csv").read_text()
    header, *rows = text.splitlines()
    k = header.split(",").index("com_z_m")
    cells = rows[10].split(",")
    cells[k] = f"{float(cells[k]) + 0.01:.6f}"  # the CoM column 1 cm off what the joints give
    rows[10] = ",".join(cells)
    with pytest.raises(SelfCheckFailed, match="CoM column wrong"):
        pipeline.self_check("\n".join([header, *rows]) + "\n", result, summary, strict_torque=False)


def test_a_plan_that_fails_its_own_re_check_writes_nothing(tmp_path: Path, monkeypatch) -> None:
    def refuse(*args, **kwargs):
        raise SelfCheckFailed("planted")

    monkeypatch.setattr(pipeline, "self_check", refuse)
    with pytest.raises(SelfCheckFailed, match="planted"):
        pipeline.plan_to_folder(_side_step(), tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_an_infeasible_plan_writes_its_summary_alone(tmp_path: Path) -> None:
    with pytest.raises(InfeasiblePlan) as info:
        pipeline.plan_to_folder(_side_step(6, thrust_max_n=0.5), tmp_path)
    folder = tmp_path / "side_step"
    assert sorted(p.name for p in folder.iterdir() if not p.name.startswith(".")) == ["summary.json"]
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["feasible"] is False
    first = summary["first_infeasible"]
    assert first["step"] == 0 and first["reason"]
    assert info.value.written


def test_a_feasible_plan_keeps_its_optimised_steps_bound_to_its_trajectory(planned, tmp_path) -> None:
    import shutil

    from jethr1_plan.files.plan_steps import OPTIMISED_STEPS, steps_key, stored_steps
    from tests.files.test_plan_steps import assert_same_steps

    result, summary, folder, _ = planned
    sc = result.scenario
    key = steps_key(sc.text, sc.balance.policy, sc.timing.mode, result.robot, result.method, result.seed)
    doc = json.loads((folder / OPTIMISED_STEPS).read_text())
    assert doc["key"] == key and doc["trajectory_sha256"] == summary["files"]["trajectory.csv"]["sha256"]
    steps, why = stored_steps(folder, summary, key, len(result.robot.joint_names))
    assert why == "" and steps is not None
    assert_same_steps(steps, result.steps)
    # planned again, infeasible: the kept steps go with the plan they were of
    shutil.copytree(folder, tmp_path / "side_step")
    with pytest.raises(InfeasiblePlan):
        pipeline.plan_to_folder(_side_step(6, thrust_max_n=0.5), tmp_path)
    assert not (tmp_path / "side_step" / OPTIMISED_STEPS).exists()
