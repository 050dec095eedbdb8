"""The route's incremental planning (route/incremental.py): remembered steps and rows are those planned
afresh, bit for bit, and a refused row stops the optimisation of the steps after it."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from jethr1_plan.planning.plan import plan
from jethr1_plan.planning.sequence import SequenceBuilder
from jethr1_plan.records.infeasible import InfeasibleAt
from jethr1_plan.route import incremental
from jethr1_plan.route.incremental import RouteMemo, plan_route
from jethr1_plan.scenario import load_scenario_text
from tests.planning.test_plan import _small_two_step


def _same_rows(a, b) -> None:
    assert set(a.columns) == set(b.columns)
    for name, col in b.columns.items():
        x, y = np.asarray(a.columns[name]), np.asarray(col)
        assert x.shape == y.shape and np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), name


def _same_first_step(tmp_path):
    """The small two-step scenario, and a scenario with the same first step and another second landing."""
    text = _small_two_step(tmp_path).read_text()
    doc = yaml.safe_load(text)
    doc["steps"][1]["landing_m"] = [0.46, -0.1125, 0.0]
    return load_scenario_text(text, "small"), load_scenario_text(yaml.safe_dump(doc), "other")


def _count_optimised(monkeypatch) -> list[int]:
    calls: list[int] = []
    real = incremental.optimise_step
    monkeypatch.setattr(incremental, "optimise_step", lambda job, *a, **k: calls.append(job.index) or real(job, *a,
                                                                                                          **k))
    return calls


def test_a_remembered_step_is_the_step_planned_afresh(tmp_path, monkeypatch):
    """A re-planned route whose first step is unchanged re-uses it and optimises only the changed one;
    its rows are those of the planner's own plan of that scenario."""
    first, other = _same_first_step(tmp_path)
    calls = _count_optimised(monkeypatch)
    memo = RouteMemo()
    plan_route(first, memo)
    with_memo = plan_route(other, memo)
    assert calls == [0, 1, 1] and len(memo.steps) == 3
    _same_rows(with_memo.rows, plan(other).rows)


def test_remembered_rows_are_the_rows_built_afresh(tmp_path, monkeypatch):
    """A re-planned route whose first step is unchanged does not build that step's rows again, and its rows
    are those of a plan made without any memo, bit for bit."""
    first, other = _same_first_step(tmp_path)
    built: list[int] = []
    real = SequenceBuilder.swing
    monkeypatch.setattr(SequenceBuilder, "swing", lambda self, step, *a, **k: built.append(step) or real(self, step,
                                                                                                        *a, **k))
    memo = RouteMemo()
    plan_route(first, memo)
    with_memo = plan_route(other, memo)
    assert built[:2] == [0, 1] and 0 not in built[2:] and 1 in built[2:]
    _same_rows(with_memo.rows, plan(other).rows)


def test_a_refused_row_optimises_no_further_and_is_the_plans_refusal(tmp_path, monkeypatch):
    """Where step 0's rows are refused, step 1 is never optimised, and the refusal the route gets (the
    exception's record, not a summary parsed back) is the one the planner reports."""
    sc = load_scenario_text(_small_two_step(tmp_path).read_text(), "small")
    real_swing = SequenceBuilder.swing

    def refused(self, step, *a, **k):  # step 0's swing rows refused (as a row past rho would be)
        real_swing(self, step, *a, **k)
        if step == 0:
            self.mark(0, "swing", 7, "refused here")

    monkeypatch.setattr(SequenceBuilder, "swing", refused)
    calls = _count_optimised(monkeypatch)
    with pytest.raises(InfeasibleAt) as route_exc:
        plan_route(sc, RouteMemo())
    assert calls == [0]
    with pytest.raises(InfeasibleAt) as plan_exc:
        plan(sc)
    assert route_exc.value.first == plan_exc.value.first
    assert (route_exc.value.first.step, route_exc.value.first.reason) == (0, "refused here")
    assert route_exc.value.summary["first_infeasible"] == route_exc.value.first.to_dict()


def test_parallel_steps_are_the_steps_of_one_process(tmp_path):
    """With two processes the route's plan (steps optimised in workers, rows built after) has the rows of
    the one-process plan (steps and rows built one at a time), and fills the same step memo."""
    sc, _ = _same_first_step(tmp_path)
    one, two = RouteMemo(), RouteMemo()
    a, b = plan_route(sc, one), plan_route(sc, two, jobs=2)
    _same_rows(a.rows, b.rows)
    assert set(one.steps) == set(two.steps) and len(one.rows) == 2 and not two.rows
