"""Expected failures, each with the exit code the CLI maps it to."""

from __future__ import annotations

from collections.abc import Callable

__all__ = ["EXIT_CODES", "EXIT_REHEARSAL_FELL", "EXIT_VERIFY_FINDING", "EXIT_WORKER_LOST", "CompileNotice",
           "ExpectationFailed",
           "InfeasiblePlan", "InputError", "Jethr1Error", "RobotModelError", "SelfCheckFailed", "WorkerLost",
           "interrupt_behind", "lost_worker_behind"]

EXIT_VERIFY_FINDING = 5
"""``jethr1 verify`` found rows or files that do not hold."""
EXIT_REHEARSAL_FELL = 6
"""``jethr1 simulate``: at least one rehearsal run fell or ended off the cartons."""
EXIT_WORKER_LOST = 7
"""A worker process was killed from outside (the out-of-memory killer, a signal) before the command finished."""

EXIT_CODES: dict[int, str] = {
    0: "done: the output was written (and, for verify and simulate, everything held)",
    1: "a bug in jethr1 (a traceback, or the planner's self-check refused its own output): please report it",
    2: "bad input: one line naming the file, the key and the problem; nothing written",
    3: "infeasible: no plan (or route) exists under the scenario's policy; the first infeasible sample and its reason",
    4: "batch: a scenario's `expect:` block did not hold",
    EXIT_VERIFY_FINDING: "verify: a row or file failed an independent check (each named on stderr)",
    EXIT_REHEARSAL_FELL: "simulate: a rehearsal run fell or ended off the cartons",
    EXIT_WORKER_LOST: "a worker process was killed from outside (the out-of-memory killer, a signal): "
                      "nothing partial left; run again with fewer --jobs or more memory",
    130: "interrupted (Ctrl-C): workers stopped, nothing partial left",
    143: "terminated (SIGTERM): workers stopped, nothing partial left",
}
"""Every exit code a ``jethr1`` command returns, and what it means (docs/contract.md is generated from it)."""


class Jethr1Error(Exception):
    """Base of every expected failure. ``exit_code`` is what the CLI returns."""

    exit_code = 1


class InputError(Jethr1Error):
    """Bad input: unreadable or invalid file, bad option (exit 2).

    The message is one line naming the file, the key path and the problem.
    """

    exit_code = 2

    def __init__(self, source: str, key: str, problem: str) -> None:
        self.source, self.key, self.problem = source, key, problem
        where = f"{source}: {key}" if key else source
        super().__init__(f"{where}: {problem}")


class RobotModelError(InputError):
    """A robot directory, URDF or robot YAML that cannot be used (exit 2)."""


class InfeasiblePlan(Jethr1Error):
    """No balanced posture exists for some sample (exit 3)."""

    exit_code = 3

    def __init__(self, message: str, summary: dict | None = None) -> None:
        super().__init__(message)
        self.summary = summary
        self.written: tuple | None = None  # (folder, files of the user's kept) where summary.json was written


class ExpectationFailed(Jethr1Error):
    """A batch scenario's ``expect:`` block did not hold (exit 4)."""

    exit_code = 4


class WorkerLost(Jethr1Error):
    """A process of the command's (a worker, a file's maker) was killed from outside before it answered: the
    out-of-memory killer, a signal (exit 7). Not a bug of jethr1's, nor the user's input.

    ``what``: the process; ``exitcode``: its exit code, minus the signal's number where a signal ended it (None:
    not known); ``advice``: what to do."""

    exit_code = EXIT_WORKER_LOST

    def __init__(self, what: str, exitcode: int | None = None,
                 advice: str = "run again with fewer --jobs, or with more memory") -> None:
        import signal

        if exitcode is not None and exitcode < 0 and -exitcode in signal.valid_signals():
            how = f"killed by {signal.Signals(-exitcode).name}"
        else:
            how = "killed" if exitcode is None else f"ended (exit code {exitcode})"
        super().__init__(f"{what} was {how} before it finished, by the out-of-memory killer or a signal from "
                         f"outside: {advice}")


class CompileNotice(UserWarning):
    """A notice, not a failure: this process compiles the planner's kernels (numba), once per machine and version;
    the command line shows it as one line on stderr (``jethr1 warm-up`` compiles them ahead)."""


def show_notices_as_lines() -> None:
    """From now on this process shows a :class:`CompileNotice` as one line on stderr ("jethr1: …"), and other
    warnings as Python does: the command line and its pool workers call it first."""
    import sys
    import warnings

    python_shows = warnings.showwarning
    if getattr(python_shows, "jethr1_notices", False):
        return

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        if issubclass(category, CompileNotice):
            print(f"jethr1: {message}", file=sys.stderr, flush=True)
            return
        python_shows(message, category, filename, lineno, file, line)

    show.jethr1_notices = True  # type: ignore[attr-defined]
    warnings.showwarning = show


class SelfCheckFailed(Exception):
    """The planner's own output failed the independent re-check before it was written: a bug (exit 1).

    Deliberately not a :class:`Jethr1Error`: nothing a user did causes it."""


def _behind(exc: BaseException, test: Callable[[BaseException], bool]) -> BaseException | None:
    """The first of ``exc`` and its causes and contexts (followed in turn) that passes ``test``, if any."""
    seen: set[int] = set()
    e: BaseException | None = exc
    while e is not None and id(e) not in seen:
        if test(e):
            return e
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return None


def interrupt_behind(exc: BaseException) -> BaseException | None:
    """The Ctrl-C (or SIGTERM: a KeyboardInterrupt) behind ``exc``, if any, following its causes and contexts.

    An interrupt that lands while a compiled kernel runs comes out of it as ``SystemError: CPUDispatcher(...)
    returned a result with an exception set``, the KeyboardInterrupt its cause: that is the user stopping the
    run, not a bug."""
    return _behind(exc, lambda e: isinstance(e, KeyboardInterrupt))


def lost_worker_behind(exc: BaseException) -> BaseException | None:
    """The lost worker behind ``exc``, if any, following its causes and contexts: a broken process pool
    (``concurrent.futures``'s, and loky's, which derives from it: a worker killed while tasks were pending) or
    Dask's ``KilledWorker``."""
    from concurrent.futures import BrokenExecutor

    return _behind(exc, lambda e: isinstance(e, BrokenExecutor) or type(e).__name__ == "KilledWorker")
