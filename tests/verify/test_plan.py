"""`jethr1 verify`: passes what plan writes, fails a tampered trajectory with a verdict per row."""

from __future__ import annotations

import json
import shutil

import pytest

from jethr1_plan.cli import run
from jethr1_plan.files.plan_csv import columns
from jethr1_plan.robot.load import load_robot
from tests.conftest import rewritten


@pytest.fixture(scope="module")
def planned(side_step_plan):
    return side_step_plan


def _tamper(planned, tmp_path, edit):
    d = tmp_path / "side_step"
    shutil.copytree(planned, d)
    lines = (d / "trajectory.csv").read_text().split("\n")
    header = lines[0].split(",")
    rows = [ln.split(",") for ln in lines[1:] if ln]
    row = edit(header, rows)
    (d / "trajectory.csv").write_text("\n".join([lines[0], *[",".join(r) for r in rows]]) + "\n")
    return rewritten(d), row  # one thing again: its rows are what verify checks


def _loaded_swing_row(header, rows):
    """The swing row with the most thrust."""
    k, ph = header.index("thrust_left_n"), header.index("phase")
    return max((i for i in range(len(rows)) if rows[i][ph] == "swing"), key=lambda i: float(rows[i][k]))


def test_plan_output_verifies(planned, capsys):
    assert run(["verify", str(planned)]) == 0
    assert run(["verify", str(planned / "trajectory.mcap")]) == 0
    capsys.readouterr()
    assert run(["verify", str(planned / "trajectory.csv"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["ok"] is True and doc["failures"] == [] and doc["rows"] > 100


def test_removed_thrust_fails(planned, tmp_path, capsys):
    def edit(header, rows):
        i = _loaded_swing_row(header, rows)
        rows[i][header.index("thrust_left_n")] = "0.0"
        return i

    d, i = _tamper(planned, tmp_path, edit)
    assert run(["verify", str(d), "--json"]) == 5
    doc = json.loads(capsys.readouterr().out)
    checks = {(f["row"], f["check"]) for f in doc["failures"]}
    assert (i, "ZMP outside support") in checks and doc["ok"] is False
    # the row, and the fan commands around it (they lead the thrust by its rate of change)
    assert all(f["row"] == i or (abs(f["row"] - i) == 1 and f["check"] == "fan command column wrong")
               for f in doc["failures"])


def test_moved_joint_fails(planned, tmp_path, capsys):
    def edit(header, rows):
        i = _loaded_swing_row(header, rows)
        k = header.index("left_knee_rad")
        rows[i][k] = repr(float(rows[i][k]) + 0.02)
        return i

    d, i = _tamper(planned, tmp_path, edit)
    assert run(["verify", str(d / "trajectory.csv"), "--json"]) == 5
    doc = json.loads(capsys.readouterr().out)
    assert (i, "swing sole off its sample") in {(f["row"], f["check"]) for f in doc["failures"]}


def test_moved_support_foot_fails(planned, tmp_path, capsys):
    def edit(header, rows):
        i = len(rows) // 2
        for j in (header.index("right_hip_pitch_rad"), header.index("right_ankle_pitch_rad")):
            rows[i][j] = repr(float(rows[i][j]) + 0.01)
        return i

    d, i = _tamper(planned, tmp_path, edit)
    assert run(["verify", str(d), "--json"]) == 5
    doc = json.loads(capsys.readouterr().out)
    assert (i, "support foot moved") in {(f["row"], f["check"]) for f in doc["failures"]}


def test_missing_file_is_exit_2(tmp_path):
    assert run(["verify", str(tmp_path / "nothing")]) == 2


def test_header_is_checked(tmp_path):
    p = tmp_path / "trajectory.csv"
    p.write_text(",".join(columns(load_robot("jethr1"))[:10]) + "\n")
    assert run(["verify", str(p)]) == 2
