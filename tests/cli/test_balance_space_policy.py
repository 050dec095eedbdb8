"""``balance-space --policy robust``: the space a plan under the robust policy can use, the one ``jethr1
route`` maps (same cells), smaller than Paper A's minimal one; a tolerance without the robust policy is
bad input."""

from __future__ import annotations

import json
import math

import numpy as np

from jethr1_plan.cli import run
from jethr1_plan.physics.balance import Tolerance
from jethr1_plan.reasons import Reason
from jethr1_plan.robot.load import load_robot
from jethr1_plan.route.balance_map import MapSettings, compute_map

GRID = ["--support-position", "0", "0", "0", "--x-range", "0.4", "0.7", "--y-range", "0.1", "0.3", "--z-range", "0.0",
        "0.05", "--resolution", "0.05", "-j", "1", "--no-progress", "--json"]


def _sweep(tmp_path, capsys, name: str, *extra: str) -> tuple[dict, list[str]]:
    assert run(["balance-space", *GRID, *extra, "-o", str(tmp_path / name)]) == 0
    doc = json.loads(capsys.readouterr().out)
    rows = (tmp_path / name / "balance_space.csv").read_text().strip().split("\n")[1:]
    return doc, [r.rsplit(",", 1)[1] for r in rows]


def test_the_robust_space_is_the_routes_map_and_smaller_than_the_minimal_one(tmp_path, capsys):
    robust, reasons = _sweep(tmp_path, capsys, "robust", "--policy", "robust", "--com-error", "0.008")
    minimal, _ = _sweep(tmp_path, capsys, "minimal")
    assert robust["spec"]["tolerance"] == {"thrust": 0.1, "mass": 0.05, "com_m": 0.008}
    assert minimal["spec"]["tolerance"] == {"thrust": 0.0, "mass": 0.0, "com_m": 0.0}
    assert 0 < robust["with_thrust"]["cells"] < minimal["with_thrust"]["cells"]
    m = compute_map(load_robot("jethr1"), MapSettings("right", 0.05, 23.0, math.radians(5), 0.0,
                                                      Tolerance(0.1, 0.05, 0.008), x_range=(0.4, 0.7),
                                                      y_range=(0.1, 0.3), z_range=(0.0, 0.05)))
    assert int(m.member.sum()) == robust["with_thrust"]["cells"]
    assert np.array_equal(m.member.ravel(), np.array([r == "" for r in reasons]))
    assert m.reason.ravel()[~m.member.ravel()].tolist() != [] and all(
        r != Reason.OK for r in m.reason.ravel()[~m.member.ravel()])


def test_a_tolerance_needs_the_robust_policy(tmp_path, capsys):
    assert run(["balance-space", *GRID, "--mass-error", "0.05", "-o", str(tmp_path / "x")]) == 2
    assert not (tmp_path / "x").exists()
    assert run(["balance-space", *GRID, "--policy", "robust", "--sole-margin", "0.05", "-o", str(tmp_path / "y")]) == 2
