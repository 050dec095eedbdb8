"""What every re-check shares: a failure of one row, and the tolerances of written numbers."""

from __future__ import annotations

import os
import stat
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

__all__ = ["TOL_M", "TOL_RAD", "TOL_T", "Failure", "Failures", "csv_header", "is_walk"]

TOL_M = 1e-6  # written against recomputed positions [m] (the IK tolerance; floats round-trip exactly)
TOL_RAD = 1e-6  # written against recomputed angles [rad]
TOL_T = 1e-9  # times are written rounded to 1e-9 s [s]


@dataclass
class Failure:
    """One row that fails one check (``row`` counts from 0; ``time_s`` its time)."""

    row: int
    time_s: float
    check: str
    detail: str

    def __str__(self) -> str:
        return f"row {self.row} (t = {self.time_s:.3f} s): {self.check}: {self.detail}"


class Failures(list[Failure]):
    """The failures a verifier reports (the first ones in row order: a long list is cut short) and
    ``rows``, every row that fails a check, whether or not its failures are listed."""

    def __init__(self, listed: Iterable[Failure] = (), rows: Iterable[int] = ()) -> None:
        items = list(listed)
        super().__init__(items)
        self.rows: frozenset[int] = frozenset(rows) | {f.row for f in items}


def csv_header(path: Path) -> list[str] | None:
    """The first line of a CSV split at commas (None: no such regular file, or not text)."""
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):  # a FIFO or a device: never opened
            return None
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
        with os.fdopen(fd, "rb") as f:
            return f.readline(100_000).decode("utf-8").strip().split(",")
    except (OSError, UnicodeDecodeError):
        return None


def is_walk(summary: dict | None, header: list[str] | None = None) -> bool:
    """Whether a folder's files are a walk's (summary kind, or a walk's CSV header)."""
    if summary is not None:
        return summary.get("kind") == "walk"
    return header is not None and "yaw_ref_rad" in header
