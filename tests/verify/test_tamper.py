"""`jethr1 verify` against every tampering a user or a broken disk can produce: exit 5 (a row fails)
or 2 (not a readable plan), one line per failing row, never a traceback; a fresh plan passes."""

from __future__ import annotations

import json
import os
import shutil

import numpy as np
import pytest
import yaml

from jethr1_plan.cli import run
from tests.conftest import ROOT, rewritten


@pytest.fixture
def planned(side_step_plan):
    return side_step_plan


def _copy(planned, tmp_path):
    d = tmp_path / "side_step"
    shutil.copytree(planned, d)
    return d


def _edit_csv(d, edit):
    lines = (d / "trajectory.csv").read_text().split("\n")
    header, rows = lines[0].split(","), [ln for ln in lines[1:] if ln]
    rows = edit(header, rows)
    (d / "trajectory.csv").write_text("\n".join([lines[0], *rows]) + "\n")
    rewritten(d)  # the folder one thing again: its rows are what verify checks


def _set(header, rows, i, column, value):
    cells = rows[i].split(",")
    cells[header.index(column)] = value
    rows[i] = ",".join(cells)
    return rows


def _verify(target, capsys, *extra):
    code = run(["verify", str(target), *extra])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, err


def test_a_fresh_plan_passes(planned, capsys):
    code, err = _verify(planned, capsys)
    assert code == 0 and "hold" in err


ROW_EDITS = {
    "cut to 476 rows": (lambda h, r: r[:476], "row count"),
    "header only": (lambda h, r: [], "no rows"),
    "two rows swapped": (lambda h, r: [*r[:300], r[301], r[300], *r[302:]], "time"),
    "a row duplicated": (lambda h, r: [*r[:300], r[300], *r[300:]], "time"),
    "every other row dropped": (lambda h, r: r[::2], "time"),
    "time shifted by 0.5 s": (lambda h, r: _set(h, r, 300, "time_s", str(float(r[300].split(",")[0]) + 0.5)), "time"),
    "pelvis_qw = 2": (lambda h, r: _set(h, r, 200, "pelvis_qw", "2.0"), "not a unit quaternion"),
    "a torque of 500 N·m": (lambda h, r: _set(h, r, 200, "right_knee_tau_nm", "500.0"), "torque"),
    "a row marked infeasible": (lambda h, r: _set(h, r, 250, "feasible", "false"), "marked infeasible"),
    "a support row on the other foot": (lambda h, r: _set(h, r, 250, "support", "left"), "phase out of order"),
    "a joint moved by 1 mrad": (lambda h, r: _set(h, r, 250, "right_knee_rad",
                                                  repr(float(r[250].split(",")[h.index("right_knee_rad")]) + 1e-3)),
                                "support foot moved"),
    "a swing sample moved": (lambda h, r: _set(h, r, 250, "swing_y_m", "0.2"), "swing sole off its sample"),
    "thrust cut by 3 %": (lambda h, r: _set(h, r, 350, "thrust_left_n",
                                            repr(0.97 * float(r[350].split(",")[h.index("thrust_left_n")]))),
                          "below the tolerance"),
    "a window widened": (lambda h, r: _set(h, r, 350, "thrust_window_hi_n", "23.0"), "thrust window column wrong"),
    "a servo command edited": (lambda h, r: _set(h, r, 350, "left_knee_cmd_rad", "0.5"), "servo command"),
}


@pytest.mark.parametrize("case", list(ROW_EDITS), ids=list(ROW_EDITS))
def test_a_tampered_csv_fails(planned, tmp_path, capsys, case):
    edit, words = ROW_EDITS[case]
    d = _copy(planned, tmp_path)
    _edit_csv(d, edit)
    code, err = _verify(d / "trajectory.csv", capsys)
    assert code == 5 and words in err, err[-800:]
    lines = err.strip().splitlines()
    assert lines[-2].startswith("checked trajectory.csv")  # verify names what it read
    rows = [ln.split(": row ")[1].split(" ")[0] for ln in lines[:-2]]
    assert len(rows) == len(set(rows))  # one line per failing row
    # the folder form checks the CSV and the MCAP against each other too
    code, err = _verify(d, capsys)
    assert code == 5


@pytest.mark.parametrize("case, edit, words", [
    ("cut mid-line", lambda t: t[: len(t) // 2], "cells"),
    ("text in a number", lambda t: t.replace("0.0,", "zero,", 1), "is not a number"),
    ("an unknown column", lambda t: "colour," + t, "unknown column"),
    ("not UTF-8", lambda t: t[:100] + "\udce9" + t[100:], "not UTF-8"),
])
def test_a_malformed_csv_is_exit_2(planned, tmp_path, capsys, case, edit, words):
    d = _copy(planned, tmp_path)
    text = (d / "trajectory.csv").read_text()
    (d / "trajectory.csv").write_bytes(edit(text).encode("utf-8", "surrogateescape"))
    code, err = _verify(d / "trajectory.csv", capsys)  # not the file summary.json records
    assert code == 2 and "not the trajectory.csv that summary.json records" in err
    assert len(err.strip().splitlines()) == 1
    code, err = _verify(rewritten(d) / "trajectory.csv", capsys)  # recorded: what is wrong with it
    assert code == 2 and words in err and len(err.strip().splitlines()) == 1


def test_a_corrupt_mcap_is_exit_2(planned, tmp_path, capsys):
    d = _copy(planned, tmp_path)
    (d / "trajectory.mcap").write_bytes(np.random.default_rng(0).bytes(1000))
    code, err = _verify(d, capsys)
    assert code == 2 and "not the trajectory.mcap that summary.json records" in err
    code, err = _verify(rewritten(d), capsys)
    assert code == 2 and "not a valid MCAP" in err
    data = (planned / "trajectory.mcap").read_bytes()
    (d / "trajectory.mcap").write_bytes(data[: len(data) * 2 // 3])  # cut
    code, err = _verify(d / "trajectory.mcap", capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1


def test_the_csv_and_the_mcap_must_agree(planned, tmp_path, capsys):
    """The CSV changed in a way it holds by itself (the CoM column is recomputed exactly, the
    yaw momentum is not): the MCAP disagrees."""
    d = _copy(planned, tmp_path)
    _edit_csv(d, lambda h, r: _set(h, r, 100, "yaw_momentum_nms", "0.123"))
    assert _verify(d / "trajectory.csv", capsys)[0] == 0
    code, err = _verify(d, capsys)
    assert code == 5 and "CSV and MCAP differ" in err and "yaw_momentum_nms" in err


def test_an_infeasible_plan_written_anyway_fails(tmp_path, capsys):
    doc = yaml.safe_load((ROOT / "configs" / "side_step.yaml").read_text())
    doc["balance"]["thrust_max_n"] = 0.0
    doc["balance"]["policy"] = "minimal"
    doc["steps"][0]["path"]["samples"] = 6  # as infeasible as with 60, and found sooner
    path = tmp_path / "nofan.yaml"
    path.write_text(yaml.safe_dump(doc))
    assert run(["plan", str(path), "-o", str(tmp_path), "--no-progress", "--write-infeasible"]) == 3
    capsys.readouterr()
    code, err = _verify(tmp_path / "nofan", capsys)
    assert code == 5 and "marked infeasible" in err and "outside [0, 0] N" in err


def test_the_scenario_is_found_and_checked(planned, tmp_path, capsys, monkeypatch):
    # a mistyped --scenario is bad input, not a silent pass
    code, err = _verify(planned, capsys, "--scenario", str(tmp_path / "nope.yaml"))
    assert code == 2 and "nope.yaml" in err
    # the right scenario, its landing moved by 2 cm: the swing path and the landing no longer match
    doc = yaml.safe_load((ROOT / "configs" / "side_step.yaml").read_text())
    doc["steps"][0]["landing_m"] = [0.02, 0.35, 0.0]
    moved = tmp_path / "moved.yaml"
    moved.write_text(yaml.safe_dump(doc))
    code, err = _verify(planned, capsys, "--scenario", str(moved))
    assert code == 5 and "sole not where the scenario puts it" in err and "swing sole off its path" in err
    # the plan folder copied elsewhere and checked from another directory: the scenario comes from
    # summary.json (the file it names, else the copy it holds) and is checked
    d = _copy(planned, tmp_path)
    s = json.loads((d / "summary.json").read_text())
    s["scenario_file"] = "configs/side_step.yaml"  # relative: as a user might have typed it
    (d / "summary.json").write_text(json.dumps(s))
    code, err = _verify(d, capsys)  # an edited summary.json: not the one jethr1 wrote with these files
    assert code == 2 and "summary.json: changed since jethr1 wrote it" in err
    rewritten(d)
    monkeypatch.chdir(tmp_path)
    assert not (tmp_path / "configs" / "side_step.yaml").exists()
    code, err = _verify(d, capsys)
    assert code == 0
    s = json.loads((d / "summary.json").read_text())
    s["scenario_yaml"] = s["scenario_yaml"].replace("[0.0, 0.35, 0.0]", "[0.02, 0.35, 0.0]")
    (d / "summary.json").write_text(json.dumps(s))
    code, err = _verify(d, capsys)
    assert code == 5 and "sole not where the scenario puts it" in err


def test_a_corrupt_summary_is_exit_2(planned, tmp_path, capsys):
    d = _copy(planned, tmp_path)
    (d / "summary.json").write_text("{not json")
    code, err = _verify(d, capsys)
    assert code == 2 and "summary.json" in err


def test_verify_reads_only_what_was_written(planned, tmp_path, capsys):
    """A plan folder moved to a place where the robot YAML path in summary.json does not exist still
    verifies (the scenario names the robot)."""
    d = _copy(planned, tmp_path)
    s = json.loads((d / "summary.json").read_text())
    s["robot_yaml"] = "/nowhere/jethr1.yaml"
    (d / "summary.json").write_text(json.dumps(s))
    assert _verify(rewritten(d), capsys)[0] == 0
    assert os.path.exists(d / "trajectory.mcap")


def test_verify_counts_every_failing_row_beyond_those_it_lists(planned, tmp_path, capsys):
    """80 rows marked infeasible: the first 50 failures are listed, one line each, and the last line counts all 80
    (not the 50 listed); --json says so too."""
    d = _copy(planned, tmp_path)
    marked = list(range(200, 280))

    def edit(header, rows):
        for i in marked:
            rows = _set(header, rows, i, "feasible", "false")
        return rows

    _edit_csv(d, edit)
    code, err = _verify(d / "trajectory.csv", capsys)
    lines = err.strip().splitlines()
    listed = {int(ln.split(": row ")[1].split(" ")[0]) for ln in lines[:-2]}
    assert code == 5 and len(listed) == 50 and listed <= set(marked)
    assert "80 failing rows of" in lines[-1] and "the first 50 listed" in lines[-1], lines[-1]
    code = run(["verify", str(d / "trajectory.csv"), "--json"])
    doc = json.loads(capsys.readouterr().out)
    assert code == 5 and doc["failing_rows"] == 80 and len(doc["failures"]) == 50
