"""The one reader of a plan folder: complete and consistent before anything runs (every file there,
summary.json bounded and typed, its robot the files' and the scenario's, rows that agree with it),
one line for every problem; verify and simulate say the same."""

from __future__ import annotations

import json
import shutil

import pytest

from jethr1_plan.cli import run
from jethr1_plan.errors import InputError
from jethr1_plan.files.plan_folder import folder_kind
from jethr1_plan.folders.plan import read_plan
from jethr1_plan.io.record import RECORD
from tests.conftest import ROOT, rewritten


def _copy(plan, tmp_path):
    d = tmp_path / "side_step"
    shutil.copytree(plan, d)
    return d


def _summary(d, edit):
    """summary.json edited, the folder made one thing again (``rewritten``: what the reader checks next)."""
    s = json.loads((d / "summary.json").read_text())
    edit(s)
    (d / "summary.json").write_text(json.dumps(s))
    return rewritten(d)


def _csv(d, edit):
    lines = (d / "trajectory.csv").read_text().split("\n")
    rows = [ln for ln in lines[1:] if ln]
    (d / "trajectory.csv").write_text("\n".join([lines[0], *edit(lines[0].split(","), rows)]) + "\n")
    return rewritten(d)


def _cell(header, rows, i, column, value):
    cells = rows[i].split(",")
    cells[header.index(column)] = value
    rows[i] = ",".join(cells)
    return rows


FOLDERS = {  # edit -> (words of the one line, verify's exit code)
    "the MCAP deleted": (lambda d: (d / "trajectory.mcap").unlink(), "trajectory.mcap: missing: a plan folder holds"),
    "the CSV deleted": (lambda d: (d / "trajectory.csv").unlink(), "trajectory.csv: missing: a plan folder holds"),
    "summary.json deleted": (lambda d: (d / "summary.json").unlink(), "summary.json: missing: a plan folder holds"),
    "another robot, its YAML there": (lambda d: _summary(d, lambda s: s.update(
        robot="dyros_jet_like", robot_yaml=str(ROOT / "robots" / "dyros_jet_like" / "dyros_jet_like.yaml"))),
        "summary.json: robot: 'dyros_jet_like', but the scenario names robot 'jethr1'"),
    "another robot by name": (lambda d: _summary(d, lambda s: s.update(robot="jethr1_trunk_fan",
                                                                        robot_yaml="/nowhere.yaml")),
                              "summary.json: robot: 'jethr1_trunk_fan', but the scenario is robot 'jethr1'"),
    "row_count 1e12": (lambda d: _summary(d, lambda s: s.update(row_count=1e12)),
                       "summary.json: row_count: 1000000000000.0 is above the largest allowed, 200000"),
    "rows 1e12": (lambda d: _summary(d, lambda s: s["trajectory"].update(rows=10**12)),
                  "summary.json: trajectory.rows: 1000000000000 is above the largest allowed"),
    "a summary nested 100,000 deep": (lambda d: (d / "summary.json").write_text(
        (d / "summary.json").read_text()[:-2] + ', "deep": ' + "[" * 100_000 + "]" * 100_000 + "}"),
        "summary.json: nested more than 32 levels deep"),
    "terrain not a list": (lambda d: _summary(d, lambda s: s.update(terrain={"cartons": 5})),
                           "summary.json: terrain.cartons: expected array, got 5"),
    "a rate of 0": (lambda d: _summary(d, lambda s: s["trajectory"].update(rate_hz=0)),
                    "summary.json: trajectory.rate_hz: 0: must be more than 0"),
    "the columns of another robot": (lambda d: rewritten((d / "trajectory.csv").write_text(
        (d / "trajectory.csv").read_text().replace("thrust_left_n", "thrust_trunk_n", 1)) and d),
        "trajectory.csv: header: unknown column 'thrust_trunk_n': not the columns of robot 'jethr1'"),
}


@pytest.mark.parametrize("case", list(FOLDERS), ids=list(FOLDERS))
def test_an_incomplete_or_inconsistent_folder_is_one_line(side_step_plan, tmp_path, capsys, case):
    edit, words = FOLDERS[case]
    d = _copy(side_step_plan, tmp_path)
    edit(d)
    with pytest.raises(InputError) as err:
        read_plan(d)
    assert words in str(err.value) and "\n" not in str(err.value)
    for command in (["verify", str(d)], ["simulate", str(d), "--no-progress"]):
        assert run(command) == 2
        out = capsys.readouterr().err
        assert out.strip().splitlines() == [f"jethr1: {err.value}"]
    assert not (d / "simulation.json").exists()


ROWS = {  # simulate refuses these (exit 2); verify finds them (exit 5)
    "two rows swapped": (lambda h, r: [*r[:300], r[301], r[300], *r[302:]], "row 302: time 6 s does not come after "
                         "6.02 s", "time"),
    "a nan cell": (lambda h, r: _cell(h, r, 300, "pelvis_x_m", "nan"), "row 301: pelvis_x_m is empty or not a finite "
                   "number", "not a number"),
    "an empty cell": (lambda h, r: _cell(h, r, 10, "left_knee_rad", ""), "row 11: left_knee_rad is empty", "not a "
                      "number"),
    "cut to 476 rows": (lambda h, r: r[:476], "476 rows, summary.json says 676", "row count"),
    # words and indices no plan has (a support of 'none' was a KeyError in the twin, exit 1; the others ran)
    "a support of none": (lambda h, r: _cell(h, r, 300, "support", "none"),
                          "row 301: support 'none': expected left, right, both", "phase out of order"),
    "a phase of flying": (lambda h, r: _cell(h, r, 300, "phase", "flying"),
                          "row 301: phase 'flying': expected swing, transfer", "phase out of order"),
    "a step of 1e11": (lambda h, r: _cell(h, r, 300, "step", "99999999999"),
                       "row 301: step 99999999999: expected 0 to 1 (summary.json's 1 steps", "phase out of order"),
    "a negative sample": (lambda h, r: _cell(h, r, 300, "sample", "-5"), "row 301: sample -5: expected 0 or more",
                          "phase out of order"),
}


@pytest.mark.parametrize("case", list(ROWS), ids=list(ROWS))
def test_rows_that_disagree_are_refused_by_simulate_and_found_by_verify(side_step_plan, tmp_path, capsys, case):
    edit, words, check = ROWS[case]
    d = _csv(_copy(side_step_plan, tmp_path), edit)
    assert run(["simulate", str(d), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and words in err and "Traceback" not in err
    assert not (d / "simulation.json").exists() and not (d / "simulation.mcap").exists()
    assert run(["verify", str(d / "trajectory.csv")]) == 5  # no LinAlgError on the nan cell
    err = capsys.readouterr().err
    assert f": {check}: " in err and "Traceback" not in err


@pytest.mark.parametrize("kind, files, words", [
    ("walk", {"summary.json": '{"kind": "walk"}', "trajectory.csv": "time_s\n", "yaw.png": ""},
     "a walk's folder (jethr1 walk), not a plan's"),
    ("balance-space", {"summary.json": '{"bounds_m": {}}', "balance_space.csv": ""},
     "a balance space's folder (jethr1 balance-space), not a plan's"),
    ("sweep", {"ditch_curve.json": "{}"}, "a study's folder"),
    ("unknown", {"notes.txt": ""}, "not a plan folder"),
])
def test_simulate_names_a_folder_that_is_not_a_plans(tmp_path, capsys, kind, files, words):
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    assert folder_kind(tmp_path, json.loads(files.get("summary.json", "{}"))) == kind
    assert run(["simulate", str(tmp_path), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0] and "simulate rehearses a plan's folder" in err[0]
    assert "feasible" not in err[0]


def test_an_infeasible_plans_folder_says_so(tmp_path, capsys):
    (tmp_path / "summary.json").write_text(json.dumps({"feasible": False, "scenario_yaml": "x"}))
    for command in (["verify", str(tmp_path)], ["simulate", str(tmp_path), "--no-progress"]):
        assert run(command) == 2
        assert "the plan is not feasible and only its summary was written" in capsys.readouterr().err


@pytest.mark.parametrize("path", ["/dev/null", "/dev/zero"])
def test_a_device_is_not_a_plan(capsys, path):
    assert run(["verify", path]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"jethr1: {path}: a character device, not a file or a folder: expected trajectory.csv, "
                   "trajectory.mcap or their folder"]


def test_verify_names_every_file_it_read(side_step_plan, capsys):
    assert run(["verify", str(side_step_plan), "--json"]) == 0
    out, err = capsys.readouterr()
    checked = json.loads(out)["checked"]
    assert checked == [str(side_step_plan / f) for f in ("trajectory.csv", "trajectory.mcap", "summary.json")] + [
        str(ROOT / "configs" / "side_step.yaml")]
    assert f"checked trajectory.csv, trajectory.mcap, summary.json in {side_step_plan}/; and " in err


FOREIGN = {  # the folder's files do not belong together: refused before any is parsed
    "a CSV edited": (lambda d: (d / "trajectory.csv").write_text((d / "trajectory.csv").read_text()[:-40]),
                     "trajectory.csv: not the trajectory.csv that summary.json records"),
    "an MCAP cut": (lambda d: (d / "trajectory.mcap").write_bytes((d / "trajectory.mcap").read_bytes()[:5000]),
                    "trajectory.mcap: not the trajectory.mcap that summary.json records"),
    "an empty MCAP": (lambda d: (d / "trajectory.mcap").write_bytes(b""),
                      "trajectory.mcap: not the trajectory.mcap that summary.json records"),
    "summary.json edited": (lambda d: (d / "summary.json").write_text((d / "summary.json").read_text() + " "),
                            "summary.json: changed since jethr1 wrote it"),
    "summary.json without digests": (lambda d: _earlier(d), "summary.json: files: no digest of trajectory.csv: a plan "
                                     "folder written by an earlier jethr1"),
}


def _earlier(d):
    """The folder as an earlier jethr1 wrote it: no digests, no record."""
    s = json.loads((d / "summary.json").read_text())
    s.pop("files")
    (d / "summary.json").write_text(json.dumps(s))
    (d / RECORD).unlink()


@pytest.mark.parametrize("case", list(FOREIGN), ids=list(FOREIGN))
def test_a_folder_whose_files_do_not_belong_together_is_refused(side_step_plan, tmp_path, capsys, case):
    edit, words = FOREIGN[case]
    d = _copy(side_step_plan, tmp_path)
    edit(d)
    for command in (["verify", str(d)], ["simulate", str(d), "--no-progress"]):
        assert run(command) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0], err
    assert not (d / "simulation.json").exists()
