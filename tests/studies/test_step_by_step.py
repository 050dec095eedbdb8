"""`jethr1 simulate` of a plan of several steps: executed step by step, its files, its trials; and
`jethr1 replan-steps`, the alias that plans a scenario first."""

from __future__ import annotations

import json

import pytest

from jethr1_plan.cli import run
from jethr1_plan.io.json_text import json_text
from jethr1_plan.sim.stepwise import MODES
from tests.conftest import rewritten
from tests.sim.test_stepwise import TWO_STEPS


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("steps")
    (out / "two_steps.yaml").write_text(TWO_STEPS)
    assert run(["plan", str(out / "two_steps.yaml"), "-o", str(out), "--no-progress"]) == 0
    return out / "two_steps"


def test_simulate_executes_a_plan_of_several_steps_step_by_step(folder, capsys):
    assert run(["simulate", str(folder), "--controller", "feedback", "--json", "--no-progress"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["mode"] == "step_by_step" and doc["law"] == "imu_tilt_pid"
    assert doc["sensors"]["soles"] is None and doc["sensors"]["imu"]["delay_s"] > 0
    (r,) = doc["runs"]
    steps = r["step_by_step"]["steps"]
    assert [s["step"] for s in steps] == [0, 1] and all(s["landing_error_m"] < 0.01 for s in steps)
    # each step's mode, and the steps counted per mode (every mode named, the counts summing to the steps)
    modes = r["step_by_step"]["modes"]
    assert set(modes) == set(MODES) and sum(modes.values()) == 2
    assert all(modes[s["mode"]] >= 1 and s["path_samples"] >= 2 and s["swing_s"] > 0 for s in steps)
    # the judge's landings (the viewers' /sim/steps labels) name the scenario's steps, not each segment's first
    assert [s["step"] for s in r["steps"]] == [0, 1]
    assert {"inherited", "support_slip", "servo_sag", "thrust", "touchdown", "slide"} == set(
        steps[0]["judge"]["parts_xy_m"])
    assert json.loads((folder / "simulation.json").read_text()) == doc
    # the executed steps: a plan folder verify accepts
    assert doc["executed"]["feasible"] and run(["verify", str(folder / "executed")]) == 0


def test_whole_replays_the_plan_in_one_go(folder, capsys):
    assert run(["simulate", str(folder), "--whole", "--json", "--no-progress"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["mode"] == "whole" and "step_by_step" not in doc["runs"][0] and doc["law"] is None


def test_step_by_step_trials_do_not_depend_on_jobs(folder, capsys):
    texts = []
    for jobs in ("1", "2"):
        assert run(["simulate", str(folder), "--controller", "feedback", "--trials", "2", "--seed", "4", "-j", jobs,
                    "--json", "--no-progress"]) in (0, 6)
        doc = json.loads(capsys.readouterr().out)
        doc.pop("timing")
        for r in doc["runs"]:
            r.pop("wall_s")
        texts.append(json_text(doc))
    assert texts[0] == texts[1]
    cert = doc["certificate"]
    assert cert["trials"] == 2 and all(r["perturbation"]["sensors"] is not None for r in doc["runs"])
    assert [f["trial"] for f in cert["failures"]] == [k for k, r in enumerate(doc["runs"]) if not r["survived"]]


def test_a_folder_its_scenario_does_not_plan_is_exit_2(folder, tmp_path, capsys):
    import shutil

    copy = tmp_path / "changed"
    shutil.copytree(folder, copy, ignore=shutil.ignore_patterns("simulation.*", "executed"))  # the plan alone
    # a row's knee moved by a microradian: no longer the plan the scenario makes
    lines = (copy / "trajectory.csv").read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[200].split(",")
    k = header.index("left_knee_rad")
    cells[k] = repr(float(cells[k]) + 1e-6)
    lines[200] = ",".join(cells)
    (copy / "trajectory.csv").write_text("\n".join(lines) + "\n")
    rewritten(copy)  # its files made one thing again: what is left to catch is a plan its scenario does not make
    before = sorted(p.name for p in copy.iterdir())
    assert run(["simulate", str(copy), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "not the plan its scenario makes now" in err and "Traceback" not in err
    assert sorted(p.name for p in copy.iterdir()) == before


def test_replan_steps_plans_then_executes_step_by_step(tmp_path, capsys):
    (tmp_path / "two_steps.yaml").write_text(TWO_STEPS)
    assert run(["replan-steps", str(tmp_path / "two_steps.yaml"), "-o", str(tmp_path / "out"), "--json",
                "--no-progress"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["mode"] == "step_by_step" and len(doc["runs"][0]["step_by_step"]["steps"]) == 2
    assert (tmp_path / "out" / "two_steps" / "executed" / "trajectory.csv").is_file()
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nsteps: 3\n")
    assert run(["replan-steps", str(bad), "-o", str(tmp_path / "none"), "--no-progress"]) == 2
    assert not (tmp_path / "none").exists()
