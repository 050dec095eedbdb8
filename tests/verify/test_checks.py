"""verify.checks: a module's checks registered in the order they are written, each finding a (row, detail) pair;
verify.plan.CHECKS runs every module's in the order the file, the pose, the balance, the analysis, the timing."""

from __future__ import annotations

import numpy as np

from jethr1_plan.verify import analysis_checks, balance_checks, plan_checks, timing
from jethr1_plan.verify.checks import RowCheck, registrar, rows
from jethr1_plan.verify.plan import CHECKS


def test_a_registrar_keeps_its_checks_in_the_order_written() -> None:
    mine: list[RowCheck] = []
    check = registrar(mine)

    @check("first", "one", needs=("a_col",))
    def _first(x):
        return []

    @check("second", "two", on_empty=True)
    def _second(x):
        return [(0, "always")]

    assert [(c.name, c.what, c.needs, c.on_empty) for c in mine] == [("first", "one", ("a_col",), False),
                                                                     ("second", "two", (), True)]
    assert mine[1].test(None) == [(0, "always")] and _second is mine[1].test  # the function itself is kept


def test_rows_gives_a_finding_for_every_row_where_the_mask_holds() -> None:
    assert rows(np.array([False, True, False, True]), lambda i: f"row {i}") == [(1, "row 1"), (3, "row 3")]
    assert rows(np.zeros(3, dtype=bool), str) == []


def test_every_check_runs_once_in_its_modules_order() -> None:
    modules = (plan_checks, balance_checks, analysis_checks, timing)
    assert [c for m in modules for c in m.CHECKS] == CHECKS
    assert [c.name for c in CHECKS][:3] == ["row count", "infeasible plan", "no rows"]  # the file's own first
