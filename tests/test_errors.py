"""errors: every expected failure carries its exit code, each listed in EXIT_CODES; bad input is one line naming
the file, the key and the problem; an interrupt or a lost worker is found behind the exceptions it caused."""

from __future__ import annotations

import signal
from concurrent.futures.process import BrokenProcessPool

from jethr1_plan.errors import (
    EXIT_CODES,
    ExpectationFailed,
    InfeasiblePlan,
    InputError,
    Jethr1Error,
    RobotModelError,
    SelfCheckFailed,
    WorkerLost,
    interrupt_behind,
    lost_worker_behind,
)


def test_every_failure_class_has_a_listed_code_of_its_own() -> None:
    classes = (Jethr1Error, InputError, RobotModelError, InfeasiblePlan, ExpectationFailed, WorkerLost)
    assert all(c.exit_code in EXIT_CODES for c in classes)
    assert [InputError.exit_code, InfeasiblePlan.exit_code, ExpectationFailed.exit_code] == [2, 3, 4]
    assert RobotModelError.exit_code == InputError.exit_code
    assert not issubclass(SelfCheckFailed, Jethr1Error)  # a bug, not a user's doing: exit 1
    assert {130, 143} <= set(EXIT_CODES) and 128 + signal.SIGINT == 130 and 128 + signal.SIGTERM == 143


def test_bad_input_is_one_line_naming_the_file_and_the_key() -> None:
    e = InputError("scenario.yaml", "timing.rate_hz", "below 10 Hz")
    assert str(e) == "scenario.yaml: timing.rate_hz: below 10 Hz"
    assert (e.source, e.key, e.problem) == ("scenario.yaml", "timing.rate_hz", "below 10 Hz")
    assert str(InputError("out/", "", "not a folder")) == "out/: not a folder"


def test_a_lost_worker_names_the_signal_that_ended_it() -> None:
    assert "killed by SIGKILL" in str(WorkerLost("a sweep worker", -signal.SIGKILL))
    assert "ended (exit code 3)" in str(WorkerLost("a sweep worker", 3))
    assert "was killed before" in str(WorkerLost("a sweep worker"))


def test_an_interrupt_and_a_lost_worker_are_found_behind_what_they_caused() -> None:
    def raised(exc: BaseException, cause: BaseException | None = None) -> BaseException:
        try:
            raise exc from cause
        except BaseException as e:  # (the chain is what is tested)
            return e

    stop = KeyboardInterrupt()
    wrapped = raised(SystemError("CPUDispatcher returned a result with an exception set"), stop)
    assert interrupt_behind(wrapped) is stop
    assert interrupt_behind(raised(ValueError("x"))) is None
    broken = BrokenProcessPool("a worker died")
    assert lost_worker_behind(raised(RuntimeError("pool"), broken)) is broken
    assert lost_worker_behind(raised(RuntimeError("pool"), ValueError())) is None
    loop = ValueError("a")
    loop.__context__ = ValueError("b")
    loop.__context__.__context__ = loop  # a cycle of contexts ends the search
    assert interrupt_behind(loop) is None
