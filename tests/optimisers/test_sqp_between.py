"""sqp's checks between samples (the 50 Hz rows interpolate P_body linearly between the optimised samples): a repair
that pushes the failing segment on along the path goes on until the path passes, and the (A-10) cone is held
between samples exactly as the rows are held to it. Both were found by robot variants whose plans failed mid-swing
over narrow ditches Jet-HR1 crosses with room to spare (``jethr1 design``)."""

from __future__ import annotations

import numpy as np
import pytest

from jethr1_plan.planning.plan import plan
from jethr1_plan.planning.report import share_summary
from jethr1_plan.records.plan_rows import RowField
from jethr1_plan.robot.load import ROBOTS_DIR, forget_robots, load_robot
from jethr1_plan.robot.variant import FanDesign, VariantDesign, variant_files
from jethr1_plan.studies.ditch_curve import default_base, ditch_scenario


def moved_fans(tmp_path, fore_m: float, outboard_m: float):
    """Jet-HR1 with its fans (23 N, 0.232 kg) moved to (fore, ±outboard, 0.035) m in the sole frames."""
    folder = tmp_path / "moved"
    folder.mkdir()
    design = VariantDesign((FanDesign("left", "left_foot", (fore_m, outboard_m, 0.035), 23.0, 0.232),
                            FanDesign("right", "right_foot", (fore_m, -outboard_m, 0.035), 23.0, 0.232)))
    for name, data in variant_files(ROBOTS_DIR / "jethr1" / "jethr1.yaml", design, "moved").items():
        (folder / name).write_bytes(data)
    forget_robots()
    return load_robot(folder)


@pytest.mark.parametrize("fore_m, outboard_m, gap_m, least", [
    (-0.05, 0.15, 0.20, 1.0),  # the repair walked the failing segment from 17 to 40: 24 rounds (12 before)
    (0.10, 0.15, 0.34, 0.8),  # a row 1e-6 rad beyond the cone passed the check between samples (SLSQP's slack)
])
def test_a_narrow_ditch_plans_where_the_rows_once_failed_the_cone(tmp_path, fore_m, outboard_m, gap_m, least):
    """Every swing row inside the (A-10) cone and holding at least the share it reports; the plan feasible but
    for the soles' grip (the first design's swing bends its trunk's path so sharply between two samples that
    a row needs 0.91 of the soles' friction, more than μ / 2: refused, as a robot would slip)."""
    from jethr1_plan.physics.balance import edge_angle_excess

    robot = moved_fans(tmp_path, fore_m, outboard_m)
    base = default_base(robot)
    scenario = ditch_scenario(base, gap_m, base.balance.robust, robot.sole_length_m)
    result = plan(scenario, keep_going=True)
    rows = result.rows
    assert rows is not None
    reasons = {str(r) for r, ok in zip(rows.array(RowField.REASON), rows.array(RowField.FEASIBLE), strict=True)
               if not ok}
    assert all("friction ratio" in r for r in reasons), reasons
    assert share_summary(rows, scenario.balance.tolerance)["least"] >= least
    swing = np.flatnonzero(rows.array(RowField.PHASE) == "swing")
    support = np.array([0.0, -0.1125])
    com = rows.array(RowField.COM_M)[swing, :2]
    swing_xy = rows.array(RowField.SWING_M)[swing, :2]
    excess = np.array([float(edge_angle_excess(support, c, s, scenario.balance.rho_rad))
                       for c, s in zip(com, swing_xy, strict=True)])
    assert excess.max() <= 0.0
