"""Expected failures, each with the exit code the CLI maps it to."""

from __future__ import annotations

__all__ = ["ExpectationFailed", "InfeasiblePlan", "InputError", "Jethr1Error", "RobotModelError", "SelfCheckFailed"]


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


class SelfCheckFailed(Exception):
    """The planner's own output failed the independent re-check before it was written: a bug (exit 1).

    Deliberately not a :class:`Jethr1Error`: nothing a user did causes it."""
