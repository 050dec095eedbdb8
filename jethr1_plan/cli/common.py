"""What the ``jethr1`` commands share: the stderr console, the progress bar (or, without a terminal,
a line a minute), finite-number options, ``LO:HI:STEP`` ranges, the bounds a machine sets (cores,
memory), the JSON on stdout and the report of files kept in an output folder."""

from __future__ import annotations

import math
import os
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import click
from rich.console import Console

from jethr1_plan.errors import InputError
from jethr1_plan.io.json_text import json_text

__all__ = ["SEED", "FiniteFloat", "Progress", "StdoutError", "cap_jobs", "check_memory", "check_time", "cores",
           "err_console",
           "memory_available", "print_json", "range_spec", "report_kept", "stdout_errors"]

err_console = Console(stderr=True)
if not err_console.is_terminal:  # logs and CI: no terminal width to respect, keep tables readable
    err_console = Console(stderr=True, width=160)


#: ``--seed``: the bound a scenario's ``seed:`` has (a 64-bit signed integer)
SEED = click.IntRange(0, 2**63 - 1)


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
    """Progress on stderr: a rich bar on a terminal; elsewhere (a log, a pipe) a line when the work
    starts and then at most one a minute, so that a long run is never silent. Off with --no-progress."""

    interval_s = 60.0  # between two lines without a terminal [s]

    def __init__(self, enabled: bool, label: str):
        self.enabled = enabled and err_console.is_terminal
        self.lines = enabled and not err_console.is_terminal
        self.label = label
        self._p = None
        self._t0 = self._last = 0.0

    def __enter__(self):
        self._t0 = self._last = time.monotonic()
        if self.enabled:
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

            self._p = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                               TimeElapsedColumn(), console=err_console, transient=True)
            self._p.__enter__()
            self._task = self._p.add_task(self.label, total=None)
        elif self.lines:
            err_console.print(f"{self.label}: started", markup=False, highlight=False)
        return self

    def __call__(self, label: str, done: int, total: int) -> None:
        if self._p is not None:
            self._p.update(self._task, completed=done, total=total, description=f"{self.label}: {label}")
        elif self.lines:
            now = time.monotonic()
            if now - self._last >= self.interval_s:
                self._last = now
                err_console.print(f"{self.label}: {done}/{total} done after {_duration(now - self._t0)} ({label})",
                                  markup=False, highlight=False)

    def __exit__(self, *exc):
        if self._p is not None:
            self._p.__exit__(*exc)


def _duration(seconds: float) -> str:
    if seconds >= 86400:
        return f"{seconds / 86400:.3g} days"
    if seconds >= 3600:
        return f"{seconds / 3600:.3g} h"
    minutes, s = divmod(int(seconds), 60)
    return f"{minutes} min {s:02d} s" if minutes else f"{s} s"


_CAPPED: list[int] = []  # -j was capped (said once)


def cores() -> int:
    """The cores this process may run on (its CPU affinity, which a container or taskset limits)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def cap_jobs(jobs: int, option: str = "-j") -> int:
    """``jobs`` capped at the cores available; a cap is said once on stderr."""
    n = cores()
    if jobs <= n:
        return jobs
    if not _CAPPED:
        _CAPPED.append(jobs)
        err_console.print(f"jethr1: {option} {jobs}: this machine gives {n} cores; using {n} worker processes",
                          markup=False, highlight=False)
    return n


def memory_available() -> int:
    """Bytes of memory a new job can use: MemAvailable (Linux), else the physical memory."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover
        return 1 << 34


def check_memory(option: str, value: str, need_bytes: float, what: str) -> None:
    """Exit 2 naming ``option`` and the estimate when ``need_bytes`` is more than the memory available."""
    have = memory_available()
    if need_bytes > have:
        raise InputError(option, value, f"{what} need about {_bytes(need_bytes)}; {_bytes(have)} of memory is "
                         "available")


def check_time(option: tuple[str, str], seconds: float, what: str) -> None:
    """Exit 2 naming ``option`` (its name and value) and the estimate where ``seconds`` (a low estimate of the
    wall time on this machine's cores) is more than :data:`~jethr1_plan.scenario.MAX_ESTIMATED_S`."""
    from jethr1_plan.scenario import MAX_ESTIMATED_S

    if seconds > MAX_ESTIMATED_S:
        raise InputError(option[0], option[1], f"{what} would take at least {_duration(seconds)} on this machine's "
                         f"{cores()} cores; at most {_duration(MAX_ESTIMATED_S)} is started")


def _bytes(n: float) -> str:
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n / 1e3:.3g} kB"


class StdoutError(Exception):
    """stdout cannot be written (a closed pipe, a full device): one line, exit 2 (``cli.run``).

    Raised as itself so that click does not turn a closed pipe into a silent exit 1."""

    def __init__(self, error: OSError):
        super().__init__(error.strerror or str(error))
        self.error = error


@contextmanager
def stdout_errors() -> Iterator[None]:
    """Turn an error writing stdout in the block into a :class:`StdoutError`."""
    try:
        yield
        sys.stdout.flush()
    except OSError as exc:
        raise StdoutError(exc) from None


def print_json(doc) -> None:
    """``doc`` as JSON on stdout (flushed: a full or closed stdout is reported here, as one line)."""
    with stdout_errors():
        click.echo(json_text(doc), nl=False)


def warn_minimal_policy(policy: str) -> None:
    """One warning line where a plan was made with the ``minimal`` balance policy (Paper A's least thrust): its
    ZMP sits on the sole's edge, with no margin for a thrust, mass or CoM that differ from the model's."""
    if policy == "minimal":
        err_console.print("[yellow]warning:[/] the minimal policy (Paper A's least thrust) puts the ZMP on the "
                          "sole's edge: a robot whose thrust, mass or CoM differ from the model's tips over (run "
                          "`jethr1 simulate` on it); balance.policy: robust (or --policy robust) plans a margin "
                          "for them", soft_wrap=True)


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


def require_dask(executor: str, scheduler: str | None = None) -> None:
    """Exit 2 with the install hint when --executor dask is asked for without the extra, and when
    --scheduler is given without --executor dask (it would be ignored)."""
    if scheduler is not None and executor != "dask":
        raise InputError("--scheduler", scheduler, "a Dask scheduler needs --executor dask")
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

