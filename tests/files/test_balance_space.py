"""balance_space.csv, built column-wise, against the same rows written one at a time by the csv module."""

from __future__ import annotations

import csv
import io

import numpy as np

from jethr1_plan.balance_space.sweep import SweepResult, SweepSpec
from jethr1_plan.files.balance_space import BALANCE_SPACE_COLUMNS, balance_space_csv
from jethr1_plan.io.csv_table import number_text
from jethr1_plan.reasons import Reason


def test_the_csv_is_the_rows_written_one_at_a_time():
    spec = SweepSpec(resolution_m=0.1)
    n = int(np.prod([len(a) for a in spec.axes()]))
    rng = np.random.default_rng(3)
    reason = rng.choice([Reason.OK, Reason.THRUST_MAX, Reason.UNREACHABLE, Reason.EDGE_ANGLE, Reason.OVERLAP],
                        n).astype(np.int8)
    thrust = np.where(reason == Reason.OK, rng.uniform(0, 23, n), np.inf)
    thrust[np.flatnonzero(reason == Reason.OK)[:5]] = 0.0  # written 0.0
    thrust[reason == Reason.THRUST_MAX] = rng.uniform(23, 40, np.count_nonzero(reason == Reason.THRUST_MAX))
    p_body = np.where((reason == Reason.OK)[:, None], rng.normal(0, 0.3, (n, 3)), np.nan)
    r = SweepResult(spec, thrust=thrust, p_body=p_body, reason=reason, evaluations=0)
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(BALANCE_SPACE_COLUMNS)
    for i in range(n):
        xyz = [number_text(v) for v in r.swing[i]]
        if reason[i] == Reason.OK:
            w.writerow([*xyz, number_text(thrust[i]), *(number_text(v) for v in p_body[i]), number_text(r.yaw[i]), ""])
        else:
            text = Reason(int(reason[i])).message + (f" ({thrust[i]:.2f} N needed)" if np.isfinite(thrust[i]) else "")
            w.writerow([*xyz, "", "", "", "", "", text])
    assert balance_space_csv(r) == out.getvalue()
    rows = [ln.split(",") for ln in out.getvalue().splitlines()[1:]]
    assert sum(row[3] == "0.0" for row in rows) == 5 and any("N needed)" in row[8] for row in rows)
