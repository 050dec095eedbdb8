"""What the ``jethr1`` commands share: the stderr console, the progress bar, finite-number options,
``LO:HI:STEP`` ranges and the report of files kept in an output folder."""

from __future__ import annotations

import math
from pathlib import Path

import click
from rich.console import Console

from jethr1_plan.errors import InputError

__all__ = ["FiniteFloat", "Progress", "err_console", "range_spec", "report_kept"]

err_console = Console(stderr=True)
if not err_console.is_terminal:  # logs and CI: no terminal width to respect, keep tables readable
    err_console = Console(stderr=True, width=160)


class FiniteFloat(click.ParamType):
    """A finite float within [lo, hi] (click's FloatRange lets NaN through: NaN < lo is False)."""

    name = "float"

    def __init__(self, lo: float = -math.inf, hi: float = math.inf, lo_open: bool = False):
        self.lo, self.hi, self.lo_open = lo, hi, lo_open

    def convert(self, value, param, ctx):
        try:
            x = float(value)
        except (TypeError, ValueError):
            self.fail(f"{value!r} is not a number", param, ctx)
        if not math.isfinite(x):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        if x < self.lo or (self.lo_open and x == self.lo) or x > self.hi:
            self.fail(f"{x:g} is outside {'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}]", param, ctx)
        return x


class Progress:
    """A rich progress bar on stderr, off when stderr is not a terminal or with --no-progress."""

    def __init__(self, enabled: bool, label: str):
        self.enabled = enabled and err_console.is_terminal
        self.label = label
        self._p = None

    def __enter__(self):
        if self.enabled:
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

            self._p = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                               TimeElapsedColumn(), console=err_console, transient=True)
            self._p.__enter__()
            self._task = self._p.add_task(self.label, total=None)
        return self

    def __call__(self, label: str, done: int, total: int) -> None:
        if self._p is not None:
            self._p.update(self._task, completed=done, total=total, description=f"{self.label}: {label}")

    def __exit__(self, *exc):
        if self._p is not None:
            self._p.__exit__(*exc)


def report_kept(folder: Path, kept: list[str]) -> None:
    if kept:
        err_console.print(f"kept {', '.join(kept)} in {folder}/ (files jethr1 did not write)", markup=False)


def range_spec(text: str, option: str, max_count: int = 200) -> list[float]:
    """``LO:HI:STEP`` [m] (inclusive) to its values; InputError naming ``option`` when malformed."""
    parts = text.split(":")
    try:
        lo, hi, step = (float(v) for v in parts)
    except ValueError:
        raise InputError(option, text, "expected LO:HI:STEP, three numbers") from None
    if not all(math.isfinite(v) for v in (lo, hi, step)) or step <= 0 or hi < lo or lo <= 0:
        raise InputError(option, text, "expected finite 0 < LO <= HI and STEP > 0")
    count = math.floor((hi - lo) / step + 1e-9) + 1
    if count > max_count:
        raise InputError(option, text, f"{count} values: at most {max_count}")
    return [round(lo + k * step, 9) for k in range(count)]


def require_dask(executor: str) -> None:
    """Exit 2 with the install hint when --executor dask is asked for without the extra."""
    if executor == "dask":
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise InputError("--executor", "dask",
                             "needs the optional extra: pip install 'jethr1-plan[dask]'") from None


def pair_option(ctx, param, value):
    """click callback: a (LOW, HIGH) pair with LOW < HIGH, as floats."""
    if value is None:
        return None
    lo, hi = value
    if not lo < hi:
        raise click.BadParameter(f"expected LOW < HIGH, got {lo} {hi}")
    return (float(lo), float(hi))

