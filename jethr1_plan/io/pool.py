"""Worker pools (joblib's, on loky's processes) whose workers die with the command that started them.

A loky worker is a process of its own, started afresh; left alone it outlives a command killed from outside
(``kill -9``, the out-of-memory killer): it finishes its task, writes its plan, and waits minutes for the next.
Every pool of jethr1 is made by :func:`parallel`, whose workers run :func:`worker_start` first:

* the kernel kills the worker when the thread that started it ends (Linux ``PR_SET_PDEATHSIG``, as the
  forked workers of ``io.forked`` do), and a thread of the worker watches its parent and ends the worker
  the moment it is gone (whichever thread of the command started it, and where there is no
  ``PR_SET_PDEATHSIG``);
* under memory pressure the out-of-memory killer takes a worker before the command (``io.forked``).
"""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from jethr1_plan.errors import show_notices_as_lines
from jethr1_plan.io.forked import be_killed_first

__all__ = ["WATCH_INTERVAL_S", "parallel", "pool_config", "worker_start"]

WATCH_INTERVAL_S = 0.1  # how often a worker looks for its parent [s]


def _end_now() -> None:
    os.kill(os.getpid(), signal.SIGKILL)


def _watch(parent_pid: int) -> None:
    while os.getppid() == parent_pid:
        time.sleep(WATCH_INTERVAL_S)
    _end_now()


def worker_start(parent_pid: int) -> None:
    """The first thing a pool's worker does (loky's ``initializer``): die with process ``parent_pid`` (see the
    module), be the first the out-of-memory killer takes, and show a compile notice as one line."""
    if os.getppid() != parent_pid:  # the command ended before this worker started
        _end_now()
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not Linux: the watching thread alone
        pass
    if os.getppid() != parent_pid:
        _end_now()
    threading.Thread(target=_watch, args=(parent_pid,), name="jethr1-parent-watch", daemon=True).start()
    be_killed_first()
    show_notices_as_lines()  # a worker that compiles the kernels says so as the command does


def parallel(n_jobs: int, **kwargs: Any):
    """``joblib.Parallel(n_jobs, **kwargs)`` whose loky workers die with this process (:func:`worker_start`)."""
    from joblib import Parallel

    return Parallel(n_jobs=n_jobs, initializer=worker_start, initargs=(os.getpid(),), **kwargs)


@contextmanager
def pool_config() -> Iterator[None]:
    """Within the block, every ``joblib.Parallel`` on loky (the default backend) starts its workers with
    :func:`worker_start` (for pools made by code that does not call :func:`parallel`: the balance-space sweep)."""
    from joblib import parallel_config

    with parallel_config(backend="loky", initializer=worker_start, initargs=(os.getpid(),)):
        yield
