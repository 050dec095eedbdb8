"""A check of a plan's rows: its name (what a failure is called), what it holds the rows to, the columns it
reads; each module of checks registers its own in order (:func:`registrar`), and
:data:`jethr1_plan.verify.plan.CHECKS` runs them all.

Every check reads a :class:`~.plan_rows.RowData` (the written columns and what is recomputed from them)
and returns its findings: ``(row, detail)`` pairs. A check whose columns the file does not have is
skipped; on a file without rows only the file's own checks run.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from jethr1_plan.verify.plan_rows import RowData

__all__ = ["Finding", "RowCheck", "registrar", "rows"]

Finding = tuple[int, str]  # (row, detail)


@dataclass(frozen=True)
class RowCheck:
    """One check: ``name`` is what its failures are called; ``test`` gives the findings."""

    name: str
    what: str  # one line: what it holds the rows to
    test: Callable[[RowData], Iterable[Finding]]
    needs: tuple[str, ...] = ()  # columns it reads beyond every plan's (skipped without them)
    on_empty: bool = False  # runs on a file without rows (the file's own checks)


def registrar(into: list[RowCheck]) -> Callable[..., Callable[[Callable[[RowData], Iterable[Finding]]], Any]]:
    """The decorator ``check(name, what, needs=(), on_empty=False)`` that appends a check to ``into`` (in the order
    they run; a row's failures are listed in this order)."""

    def check(name: str, what: str, needs: tuple[str, ...] = (), on_empty: bool = False):
        def register(fn: Callable[[RowData], Iterable[Finding]]):
            into.append(RowCheck(name, what, fn, needs, on_empty))
            return fn
        return register
    return check


def rows(mask: Any, detail: Callable[..., str]) -> list[Finding]:
    """A finding for every row where ``mask`` holds."""
    return [(int(i), detail(int(i))) for i in np.flatnonzero(mask)]
