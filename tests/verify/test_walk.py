"""``jethr1 verify`` of a walk folder by its own second central differences of the written rows (issue
26): a fresh walk holds and agrees with pinocchio; a one-row jolt of the trunk and a one-period knee
reversal written into the CSV are named by row."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from jethr1_plan.cli import run
from tests.conftest import ROOT
from tests.oracles.walk_audit import audit_walk

DYROS_WALK = ROOT / "configs" / "walks" / "dyros_walk.yaml"


@pytest.fixture(scope="module")
def walked(tmp_path_factory):
    out = tmp_path_factory.mktemp("walk")
    f = out / "straight.yaml"
    f.write_text(DYROS_WALK.read_text().replace("mode: paper_b", "mode: none"))
    assert run(["walk", str(f), "-o", str(out), "--no-rehearse"]) == 0
    return out / "straight"


def _edit(folder, tmp_path, name, change):
    """A copy of ``folder`` whose CSV rows are changed by ``change(header, rows)`` (lists of cells);
    the MCAP is dropped (it holds the joints too)."""
    bad = tmp_path / name
    shutil.copytree(folder, bad)
    (bad / "trajectory.mcap").unlink()
    lines = (bad / "trajectory.csv").read_text().splitlines()
    header, rows = lines[0].split(","), [line.split(",") for line in lines[1:]]
    change(header, rows)
    (bad / "trajectory.csv").write_text("\n".join([",".join(header), *(",".join(r) for r in rows)]) + "\n")
    return bad


def test_a_fresh_walk_holds_and_pinocchio_agrees(walked, capsys):
    assert run(["verify", str(walked)]) == 0
    audit = audit_walk(walked)
    assert audit.clean and audit.worst["zmp_margin_m"] > 0.05


def test_a_one_row_jolt_of_the_trunk_is_named(walked, tmp_path, capsys):
    """The trunk (and with it the written soles and CoM) 0.1 mm forward at one single-support row: the
    ground must push it back at 2 m/s² there; the recomputed ZMP leaves the written one, at that row."""
    def change(header, rows):
        k = 500
        assert rows[k][header.index("support")] in ("left", "right")
        for col in ("pelvis_x_m", "left_foot_x_m", "right_foot_x_m", "com_x_m"):
            j = header.index(col)
            rows[k][j] = repr(float(rows[k][j]) + 1e-4)

    bad = _edit(walked, tmp_path, "jolt", change)
    capsys.readouterr()
    assert run(["verify", str(bad)]) == 5
    err = capsys.readouterr().err
    assert "row 500" in err and "ZMP" in err and "recomputed" in err
    assert "feet" not in err and "CoM: written" not in err  # the pose itself is consistent


def test_a_knee_reversal_within_one_period_is_named(walked, tmp_path, capsys):
    """A right knee that dips at 3 rad/s and turns back within one period: its second central
    difference (600 rad/s² at the corner) breaks the walk's 100 rad/s²."""
    def change(header, rows):
        j = header.index("R_KneePitch_rad")
        for k in range(500, 513):
            rows[k][j] = repr(float(rows[k][j]) - 0.03 * (6 - abs(k - 506)))

    bad = _edit(walked, tmp_path, "knee", change)
    capsys.readouterr()
    assert run(["verify", str(bad)]) == 5
    err = capsys.readouterr().err
    assert "acceleration: R_KneePitch accelerates at" in err and "row 506" in err
    np.testing.assert_array_less(100.0, np.nanmax(np.abs(audit_walk(bad).qdd)))


def test_every_failing_row_of_a_walk_is_counted(walked, tmp_path, capsys):
    """A trunk quaternion of norm 2 on 120 rows: the first 50 are listed, and the count is all 120."""
    def change(header, rows):
        j = header.index("pelvis_qw")
        for k in range(300, 420):
            rows[k][j] = "2.0"

    bad = _edit(walked, tmp_path, "quat", change)
    capsys.readouterr()
    assert run(["verify", str(bad)]) == 5
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert "120 failing rows of" in last and "listed" in last, last
