"""io.csv_table: numbers written as the shortest text that reads back to the same float (NaN as an empty cell),
and tables read back column by column, every malformed table one InputError naming the row and column."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jethr1_plan.errors import InputError
from jethr1_plan.io.csv_table import csv_text, number_text, numbers_text, read_csv_table

KNOWN = {"time_s", "phase", "feasible", "x_m"}.__contains__


def test_numbers_round_trip_exactly() -> None:
    rng = np.random.default_rng(0)
    values = [*rng.normal(size=200) * 10.0 ** rng.integers(-12, 12, size=200), 0.0, -0.0, 1e-300, math.pi]
    texts = numbers_text(values)
    assert texts == [number_text(v) for v in values]
    assert all(float(t) == v for t, v in zip(texts, values, strict=True))
    assert number_text(float("nan")) == "" and number_text(0.0) == "0.0" and number_text(-0.0) == "0.0"


def test_a_table_reads_back_as_written() -> None:
    t = np.array([0.0, 0.02, 0.04])
    x = np.array([0.1, float("nan"), -3e-7])
    text = csv_text(["time_s", "phase", "feasible", "x_m"],
                    zip(numbers_text(t), ["swing", "swing", "transfer"], ["true", "false", "true"], numbers_text(x),
                        strict=True))
    c = read_csv_table(text, "t.csv", KNOWN, text_columns=("phase",), bool_columns=("feasible",))
    assert np.array_equal(c["time_s"], t)
    assert np.array_equal(c["x_m"], x, equal_nan=True)
    assert list(c["phase"]) == ["swing", "swing", "transfer"] and c["feasible"].tolist() == [True, False, True]


@pytest.mark.parametrize("text, key, problem", [
    ("", "header", "empty file"),
    ("time_s,y\n0\n", "header", "unknown column 'y'"),
    ("time_s,time_s\n0,0\n", "header", "appears twice"),
    ("time_s,x_m\n0,1\n0\n", "row 2", "1 cells, the header has 2"),
    ("time_s,x_m\n0,1\n0.02,one\n", "row 2 x_m", "'one' is not a number"),
    ("time_s,feasible\n0,yes\n", "row 1 feasible", "'yes' is not true or false"),
])
def test_a_malformed_table_is_one_error_naming_where(text, key, problem) -> None:
    with pytest.raises(InputError) as info:
        read_csv_table(text, "t.csv", KNOWN, bool_columns=("feasible",))
    message = str(info.value)
    assert "t.csv" in message and key in message and problem in message and "\n" not in message
