"""balance_space.csv, built column-wise, against the same rows written one at a time by the csv module; the PNG's
views against the least thrust of each column of cells found one cell at a time."""

from __future__ import annotations

import csv
import io

import numpy as np

from jethr1_plan.balance_space.sweep import SweepResult, SweepSpec
from jethr1_plan.files.balance_space import (
    BALANCE_SPACE_COLUMNS,
    balance_space_csv,
    balance_space_png,
    least_thrust_columns,
)
from jethr1_plan.io.csv_table import number_text
from jethr1_plan.reasons import Reason


def _random_result(seed: int) -> SweepResult:
    spec = SweepSpec(resolution_m=0.1)
    n = int(np.prod([len(a) for a in spec.axes()]))
    rng = np.random.default_rng(seed)
    reason = rng.choice([Reason.OK, Reason.THRUST_MAX, Reason.UNREACHABLE, Reason.EDGE_ANGLE, Reason.OVERLAP],
                        n).astype(np.int8)
    thrust = np.where(reason == Reason.OK, rng.uniform(0, 23, n), np.inf)
    thrust[np.flatnonzero(reason == Reason.OK)[:5]] = 0.0  # written 0.0
    thrust[reason == Reason.THRUST_MAX] = rng.uniform(23, 40, np.count_nonzero(reason == Reason.THRUST_MAX))
    p_body = np.where((reason == Reason.OK)[:, None], rng.normal(0, 0.3, (n, 3)), np.nan)
    return SweepResult(spec, thrust=thrust, p_body=p_body, reason=reason, evaluations=0)


def test_the_csv_is_the_rows_written_one_at_a_time():
    r = _random_result(3)
    n, reason, thrust, p_body = len(r.reason), r.reason, r.thrust, r.p_body
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


def test_each_view_shows_the_least_thrust_of_its_column_of_cells():
    r = _random_result(5)
    shape = tuple(len(a) for a in r.spec.axes())
    for without, mask in ((False, r.with_thrust), (True, r.without_thrust)):
        for hidden in range(3):
            image = least_thrust_columns(r, mask, hidden)
            kept = [k for k in range(3) if k != hidden]
            assert image.shape == (shape[kept[0]], shape[kept[1]])
            expected = np.full(image.shape, np.nan)
            for flat in np.flatnonzero(mask):  # one cell at a time
                ijk = np.unravel_index(flat, shape)
                a, b = ijk[kept[0]], ijk[kept[1]]
                t = r.thrust[flat]
                expected[a, b] = t if np.isnan(expected[a, b]) else min(expected[a, b], t)
            assert np.array_equal(image, expected, equal_nan=True)
            assert np.isfinite(image).any()
            if without:  # five cells at 0 N: columns without one are empty (NaN)
                assert 1 <= np.count_nonzero(np.isfinite(image)) <= 5 and np.nanmax(image) == 0.0


def test_the_png_is_a_picture_of_the_grid():
    png = balance_space_png(_random_result(7), 0.16, 0.1)
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
    assert (width, height) == (1210, 990)  # 11 x 9 inches at 110 dpi
