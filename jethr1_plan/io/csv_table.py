"""Wide CSV tables, written and read by the ``csv`` module: one header row, one row per sample,
units as column-name suffixes; numbers as their shortest round-tripping text, empty where there is
no value (NaN); text cells quoted where they need it."""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Callable, Iterable, Sequence

import numpy as np

from jethr1_plan.errors import InputError

__all__ = ["MAX_CSV_BYTES", "csv_text", "number_text", "numbers_text", "read_csv_table"]

MAX_CSV_BYTES = 200_000_000  # a trajectory is ~1 MB per 1,000 rows; anything larger is not one


def number_text(x: float) -> str:
    """Shortest round-tripping text of a float; empty for NaN (no value, e.g. no swing foot)."""
    x = float(x)
    if math.isnan(x):
        return ""
    return repr(x) if x != 0 else "0.0"


def csv_text(header: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    """The CSV text of ``header`` and ``rows`` (cells already text), ``\\n`` line ends."""
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(header)
    w.writerows(rows)
    return out.getvalue()


def read_csv_table(text: str, source: str, known: Callable[[str], bool], text_columns: Sequence[str] = (),
                   bool_columns: Sequence[str] = ()) -> dict[str, np.ndarray]:
    """Columns of a CSV text whose header names are all ``known`` (a predicate): text columns as
    object arrays, true/false columns as bool, the others as floats (NaN where empty).

    Raises:
        InputError: a header that is not this format's, a row with the wrong number of cells (a file
            cut mid-line), a number that does not parse, a boolean that is not true/false.
    """
    if len(text) > MAX_CSV_BYTES:
        raise InputError(source, "", f"{len(text)} characters: larger than any trajectory ({MAX_CSV_BYTES})")
    try:
        lines = list(csv.reader(io.StringIO(text, newline="")))
    except csv.Error as exc:
        raise InputError(source, "", f"not a CSV table ({exc})") from None
    if not lines:
        raise InputError(source, "header", "empty file")
    header = lines[0]
    unknown = [h for h in header if not known(h)]
    if unknown:
        raise InputError(source, "header", f"unknown column {_short(unknown[0])!r}")
    if len(set(header)) != len(header):
        raise InputError(source, "header", "a column appears twice")
    cells = lines[1:]
    for n, row in enumerate(cells, start=1):
        if len(row) != len(header):
            raise InputError(source, f"row {n}", f"{len(row)} cells, the header has {len(header)} (a cut or "
                             "edited line?)")
    out: dict[str, np.ndarray] = {}
    for k, name in enumerate(header):
        col = [r[k] for r in cells]
        if name in text_columns:
            out[name] = np.array(col, dtype=object)
        elif name in bool_columns:
            bad = next((i for i, v in enumerate(col) if v not in ("true", "false")), None)
            if bad is not None:
                raise InputError(source, f"row {bad + 1} {name}", f"{_short(col[bad])!r} is not true or false")
            out[name] = np.array([v == "true" for v in col], dtype=bool)
        else:
            out[name] = _numbers(col, source, name)
    return out


def _numbers(col: list[str], source: str, name: str) -> np.ndarray:
    """A column's cells as floats (NaN where empty), each read as Python's ``float`` reads it.

    Raises:
        InputError: the first cell that is not a number.
    """
    try:  # the whole column at once (numpy reads each text as float() does)
        return np.array([float(v) if v != "" else np.nan for v in col], dtype=float)
    except ValueError:
        pass
    for i, v in enumerate(col):
        try:
            float(v) if v != "" else None
        except ValueError:
            raise InputError(source, f"row {i + 1} {name}", f"{_short(v)!r} is not a number") from None
    raise AssertionError("unreachable")  # pragma: no cover


def numbers_text(values: Iterable[float]) -> list[str]:
    """:func:`number_text` of every value (the same texts, without a call per value)."""
    return ["" if x != x else (repr(x) if x != 0 else "0.0") for x in map(float, values)]


def _short(text: str, limit: int = 40) -> str:
    """At most ``limit`` characters of ``text`` (error messages never print a long value)."""
    return text if len(text) <= limit else text[:limit] + "..."
