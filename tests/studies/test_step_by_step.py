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


def _plan_alone(folder, to):
    import shutil

    shutil.copytree(folder, to, ignore=shutil.ignore_patterns("simulation.*", "executed"))
    return to


def _comparable(doc: dict, folder) -> str:
    """simulation.json with its wall times and its folder's path aside."""
    doc = json.loads(json_text(doc).replace(str(folder), "<plan>"))
    doc.pop("timing")
    for r in doc["runs"]:
        r.pop("wall_s")
    return json_text(doc)


class Optimised(Exception):
    pass


def _no_optimiser(*_args, **_kwargs):
    raise Optimised


def test_simulate_executes_the_plans_kept_steps_without_optimising_them(folder, tmp_path, monkeypatch, capsys):
    from jethr1_plan.files.plan_steps import OPTIMISED_STEPS
    from jethr1_plan.io.record import RECORD
    from jethr1_plan.studies import step_by_step

    kept = _plan_alone(folder, tmp_path / "kept")
    monkeypatch.setattr(step_by_step, "plan", _no_optimiser)
    assert run(["simulate", str(kept), "--json", "--no-progress"]) == 0
    out = capsys.readouterr()
    assert "optimising the plan's steps again" not in out.err
    with_kept = _comparable(json.loads(out.out), kept)
    monkeypatch.undo()
    # a kept file that does not read: the steps optimised again, said in one line naming the file and the key,
    # and the same run to the byte (the planner's samples are those the file kept)
    bad = _plan_alone(folder, tmp_path / "bad")
    doc = json.loads((bad / OPTIMISED_STEPS).read_text())
    doc["steps"][1]["samples"]["q_rad"][4][2] = "x"
    (bad / OPTIMISED_STEPS).write_text(json.dumps(doc))
    (bad / RECORD).unlink()  # as a copy without its hidden files
    assert run(["simulate", str(bad), "--json", "--no-progress"]) == 0
    out = capsys.readouterr()
    (line,) = [x for x in out.err.splitlines() if "again" in x]
    assert line == (f"simulate: {bad / OPTIMISED_STEPS}: steps[1].samples.q_rad: 'x' is not a number (\"inf\", "
                    "\"-inf\" or \"nan\" only); optimising the plan's steps again")
    assert _comparable(json.loads(out.out), bad) == with_kept


def test_the_kept_steps_are_those_the_planner_optimises(folder):
    from jethr1_plan.planning.plan import plan
    from jethr1_plan.sim.rehearsal import load_plan
    from jethr1_plan.studies.step_by_step import nominal_plan
    from tests.files.test_plan_steps import assert_same_steps

    summary = json.loads((folder / "summary.json").read_text())
    scenario, kept = nominal_plan(folder, summary, load_plan(folder), note=pytest.fail)
    assert_same_steps(kept, plan(scenario, method=summary["optimiser"], seed=summary["seed"]).steps)


@pytest.mark.parametrize("change", ["missing", "key", "trajectory", "policy"])
def test_kept_steps_not_of_the_folders_plan_are_optimised_again(folder, tmp_path, monkeypatch, change):
    from jethr1_plan.files.plan_steps import OPTIMISED_STEPS
    from jethr1_plan.io.record import RECORD
    from jethr1_plan.sim.rehearsal import load_plan
    from jethr1_plan.studies import step_by_step

    copy = _plan_alone(folder, tmp_path / "copy")
    steps = copy / OPTIMISED_STEPS
    summary = json.loads((copy / "summary.json").read_text())
    if change == "missing":  # a folder of an earlier jethr1
        steps.unlink()
    elif change == "key":  # optimised for another scenario, robot or optimiser
        steps.write_text(steps.read_text().replace(json.loads(steps.read_text())["key"], "0" * 64))
    elif change == "trajectory":  # another plan's file
        steps.write_text(steps.read_text().replace(summary["files"]["trajectory.csv"]["sha256"], "0" * 64))
    else:  # the plan is of another policy than the one the steps were optimised for
        summary["balance"]["policy"] = "minimal"
    (copy / RECORD).unlink()
    notes: list[str] = []
    monkeypatch.setattr(step_by_step, "plan", _no_optimiser)
    with pytest.raises(Optimised):
        step_by_step.nominal_plan(copy, summary, load_plan(copy), note=notes.append)
    (note,) = notes
    assert note.startswith(f"{steps}: ") and note.endswith("optimising the plan's steps again")
    assert {"missing": "missing", "key": ": key: ", "trajectory": "trajectory_sha256",
            "policy": ": key: "}[change] in note
