"""The records layer: the plan's rows take their fixed fields and no other, the first infeasible sample
round-trips through summary.json's form, and the column and topic names are those the files carry."""

from __future__ import annotations

import json

import numpy as np
import pytest

from jethr1_plan.errors import InfeasiblePlan
from jethr1_plan.records.infeasible import Infeasible, InfeasibleAt, ShareAt
from jethr1_plan.records.plan_columns import FIXED_COLUMNS, SHARED_WORDS, columns, is_plan_column
from jethr1_plan.records.plan_rows import ANALYSIS_FIELDS, ROW_FIELDS, RowField, Rows
from jethr1_plan.records.topics import PER_ROW, PLAN_TOPICS


def _row(rows: Rows, k: int, **over) -> None:
    values = dict(time_s=0.02 * k, step=0, phase="swing", sample=k, support="right", feasible=True, ground_z_m=0.0,
                  p_body_m=np.array([0.0, 0.0, 0.5 + k]), yaw_rad=0.1, q_rad=np.zeros(12), swing_m=np.ones(3),
                  com_m=np.zeros(3), zmp_m=np.zeros(2), window_n=(1.0, 2.0), zmp_margin_m=0.01,
                  tolerance_share=np.nan, thrust_n=np.array([3.0 + k, 0.0]), reason="")
    values.update(over)
    rows.append(**values)


def test_rows_take_every_field_and_no_other():
    rows = Rows(fans=("left", "right"))
    for k in range(3):
        _row(rows, k)
    assert len(rows) == 3 and set(rows.columns) == set(ROW_FIELDS)
    assert rows.fan_array().shape == (3, 2) and rows.fan("left").tolist() == [3.0, 4.0, 5.0]
    assert rows.array(RowField.P_BODY_M)[:, 2].tolist() == [0.5, 1.5, 2.5]
    with pytest.raises(TypeError):
        _row(rows, 3, thrust_left=1.0)  # a key the rows do not have
    with pytest.raises(TypeError):
        rows.append(time_s=0.0)  # fields left out
    rows.truncate(1)
    assert len(rows) == 1 and all(len(v) == 1 for v in rows.columns.values())
    assert not rows.analysed
    rows.set_analysis(np.zeros((1, 12)), np.ones((1, 2)), np.zeros(1), np.zeros((1, 12)), np.zeros((1, 2)))
    assert rows.analysed and set(rows.columns) == set(ROW_FIELDS) | set(ANALYSIS_FIELDS)


def test_a_refused_sample_round_trips_through_summary_json():
    bad = Infeasible(1, "swing", 7, "no thrust can balance", p_body_m=(0.1, 0.2, 0.5), swing_m=(0.3, 0.0, 0.05),
                     thrust_n=None, share=ShareAt(0.25, 0.025, 0.0125, 0.0025, 0.5))
    d = json.loads(json.dumps(bad.to_dict()))
    assert list(d) == ["step", "phase", "sample", "swing_m", "p_body_m", "thrust_n", "reason", "tolerance_share"]
    assert Infeasible.from_dict(d) == bad
    text = bad.describe()
    assert text.startswith("infeasible at step 1 swing sample 7 (swing sole at [0.3, 0.0, 0.05] m)")
    assert "holds 25.0 % of the tolerance (±2.5 % thrust, ±1.2 % mass, 2.5 mm of CoM error)" in text


def test_a_refused_row_round_trips_and_is_the_exceptions_record():
    bad = Infeasible(0, "transfer", 3, "ZMP outside the hull of both soles", time_s=1.26, p_body_m=(0.0, 0.0, 0.5))
    d = bad.to_dict()
    assert list(d) == ["time_s", "step", "phase", "sample", "reason", "p_body_m"]
    assert Infeasible.from_dict(d) == bad and bad.describe() == ("infeasible at step 0 transfer sample 3: ZMP outside "
                                                                 "the hull of both soles")
    row = Infeasible.at_row(12, "fell")
    assert row.to_dict() == {"row": 12, "reason": "fell"} and Infeasible.from_dict(row.to_dict()) == row
    exc = InfeasibleAt(bad, {"first_infeasible": d})
    assert isinstance(exc, InfeasiblePlan) and exc.exit_code == 3 and exc.first is bad and str(exc) == bad.describe()


def test_columns_and_topics(robot):
    header = columns(robot)
    assert len(header) == len(set(header)) and set(header) >= FIXED_COLUMNS and all(map(is_plan_column, header))
    assert set(SHARED_WORDS) <= FIXED_COLUMNS
    assert all(t in PLAN_TOPICS for t in PER_ROW) and all(t.startswith("/") for t in PLAN_TOPICS)
    assert PLAN_TOPICS["/thrust"].type == "jethr1_msgs/msg/Thrust"
