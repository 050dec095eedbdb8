"""io.recycled: calls answered by a child process that a new one replaces after ``limit`` calls; a child killed
mid-call is WorkerLost (exit 7), an exception in it a RuntimeError carrying its traceback."""

from __future__ import annotations

import os
import signal
import threading

import pytest

from jethr1_plan.errors import WorkerLost
from jethr1_plan.io import recycled


@pytest.fixture(autouse=True)
def _stop_children():
    yield
    recycled.stop_all()


def _pid(limit: int) -> int:
    """The answering child's pid: its process group's id (it leads a session of its own)."""
    return recycled.call("os:getpgid", 0, limit)


def test_a_child_answers_its_limit_of_calls_then_a_new_one_takes_over() -> None:
    pids = [_pid(2) for _ in range(5)]
    assert pids[0] == pids[1] != pids[2] == pids[3] != pids[4]
    assert os.getpid() not in pids
    assert not os.path.exists(f"/proc/{pids[0]}")  # the spent child ended and was reaped
    assert recycled.call("math:hypot", 3.0, 2) == 3.0


def test_an_exception_in_the_child_is_a_runtime_error_with_its_traceback() -> None:
    with pytest.raises(RuntimeError, match=r"math:sqrt failed in a child process:(.|\n)*ValueError"):
        recycled.call("math:sqrt", -1.0, 5)
    assert recycled.call("math:sqrt", 4.0, 5) == 2.0  # the same child goes on


def test_a_child_killed_mid_call_is_worker_lost_and_the_next_call_has_a_new_one() -> None:
    pid = _pid(10)
    threading.Timer(0.5, os.kill, (pid, signal.SIGKILL)).start()
    with pytest.raises(WorkerLost, match="killed by SIGKILL"):
        recycled.call("time:sleep", 30.0, 10)
    assert _pid(10) not in (pid, os.getpid())


def test_stop_all_ends_every_thread_s_child() -> None:
    """Two threads, each with its child, both threads still running: stop_all ends both children."""
    pids: list[int] = []
    release = threading.Event()

    def work() -> None:
        pids.append(_pid(10))
        release.wait(30)

    threads = [threading.Thread(target=work) for _ in range(2)]
    for t in threads:
        t.start()
    while len(pids) < 2:
        release.wait(0.01)
    assert len(set(pids)) == 2 and all(os.path.exists(f"/proc/{p}") for p in pids)
    recycled.stop_all()
    assert not any(os.path.exists(f"/proc/{p}") for p in pids)
    release.set()
    for t in threads:
        t.join()
