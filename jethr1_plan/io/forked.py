"""Work in processes forked from this one: how to fork without copying what parent and child share, and a file
made by a forked child while this process goes on.

A forked child shares every page of its parent's until one of them writes it. Two things write pages nobody
meant to change: Python's garbage collector (a collection writes to every object it examines) and glibc's
malloc keeping freed memory. :func:`before_fork` settles both; the balance-space sweep's workers
(``balance_space.workers``) and :class:`ForkedFile` fork after it.

Forking is safe where no other thread of the forking process holds a lock the child needs: fork before a
thread starts, or after it ends (the commands' progress bars are threads).

A forked child ends with the process that forked it, however that one ends (:func:`die_with_parent`): a command
killed by the out-of-memory killer or ``kill -9`` leaves no sweep running on without it. Under memory pressure the
out-of-memory killer takes a child before the command (:func:`be_killed_first`), which then says so.
"""

from __future__ import annotations

import ctypes
import gc
import multiprocessing
import os
import signal
import sys
import traceback
from collections.abc import Callable
from pathlib import Path

from jethr1_plan.errors import WorkerLost

__all__ = ["MMAP_THRESHOLD_B", "OOM_SCORE_ADJ", "TRIM_THRESHOLD_B", "ForkedFile", "be_killed_first", "before_fork",
           "die_with_parent", "fork_available", "give_back_freed_memory", "worker_start"]

MMAP_THRESHOLD_B = 256 * 1024  # glibc: arrays from this size get their own mapping, given back when freed
TRIM_THRESHOLD_B = 1024 * 1024  # glibc: free memory at the heap's top beyond this is given back


def fork_available() -> bool:
    """Whether work can be forked here: Linux (fork, glibc) only."""
    return sys.platform.startswith("linux") and "fork" in multiprocessing.get_all_start_methods()


def give_back_freed_memory() -> None:
    """glibc's malloc: fixed thresholds (:data:`MMAP_THRESHOLD_B`, :data:`TRIM_THRESHOLD_B`), and the free memory
    of the heap given back now."""
    try:
        libc = ctypes.CDLL("libc.so.6")
    except OSError:  # not glibc: nothing to tune
        return
    libc.mallopt(-3, MMAP_THRESHOLD_B)  # M_MMAP_THRESHOLD (fixing it also stops glibc raising it)
    libc.mallopt(-1, TRIM_THRESHOLD_B)  # M_TRIM_THRESHOLD
    libc.malloc_trim(0)


PR_SET_PDEATHSIG = 1  # Linux prctl(2): the signal this process gets when the thread that forked it ends


def die_with_parent(parent_pid: int) -> None:
    """Call first thing in a child forked from process ``parent_pid``: the child is killed (SIGKILL) when its
    parent ends, however the parent ends, even by SIGKILL (Linux ``PR_SET_PDEATHSIG``; the parent's forking
    thread must live as long as the child is meant to). Where the parent ended already, the child ends now."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    except (OSError, AttributeError):  # not Linux: a child ends when it finds its pipe closed
        return
    if os.getppid() != parent_pid:  # the parent ended before the signal was asked for
        os._exit(1)


OOM_SCORE_ADJ = 1000  # a forked child: the first the out-of-memory killer takes (-1000..1000; 1000: before any other)


def be_killed_first() -> None:
    """Under memory pressure, the out-of-memory killer takes this process before its parent (Linux
    ``/proc/self/oom_score_adj``, raised as any process may raise its own): a worker killed is one line and exit 7
    from the command that forked it, where the command killed could not say anything."""
    try:
        with open("/proc/self/oom_score_adj", "w") as f:
            f.write(str(OOM_SCORE_ADJ))
    except OSError:  # not Linux
        pass


def worker_start(parent_pid: int) -> None:
    """The first thing a forked worker does: :func:`die_with_parent`, :func:`be_killed_first`; and the signals
    its parent's handlers would turn into exceptions set back: SIGTERM ends it at once, silently, and Ctrl-C is
    left to the parent, which ends its workers itself."""
    die_with_parent(parent_pid)
    be_killed_first()
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def before_fork() -> None:
    """Before forking: garbage collected, and every object left moved out of the collector's sight
    (:func:`gc.freeze`), so that a collection in a child, which writes to the objects it examines, does not copy
    the pages it shares with its parent; the free memory given back. (:func:`gc.unfreeze` when done forking.)"""
    gc.collect()
    gc.freeze()
    give_back_freed_memory()


def _child(conn, parent_pid: int, path: Path, make: Callable[[], bytes]) -> None:
    worker_start(parent_pid)
    try:
        path.write_bytes(make())
        conn.send(None)
    except BaseException as exc:  # reported to the parent, which raises it
        text = f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}"
        try:
            conn.send((exc, text))
        except Exception:  # an exception that cannot be pickled
            conn.send((None, text))
    finally:
        conn.close()


class ForkedFile:
    """``make()``'s bytes written to ``path`` by a child process forked from this one, while this process goes on
    (on two cores, the balance space's PNG is drawn while the CSV and the MCAP are written). Where forking is not
    available the file is made here, at once. :meth:`wait` raises what the child raised; a context manager:
    leaving it ends the child if it still runs (an interrupt, an error here).

    ``make`` runs on a copy of this process's memory as it was when the child was forked: what this process
    changes afterwards, the child does not see.
    """

    def __init__(self, path: Path, make: Callable[[], bytes]):
        self.path = Path(path)
        self._process = None
        if not fork_available():
            self.path.write_bytes(make())
            return
        before_fork()
        ctx = multiprocessing.get_context("fork")
        self._conn, child = ctx.Pipe(duplex=False)
        self._process = ctx.Process(target=_child, args=(child, os.getpid(), self.path, make),
                                    name="jethr1-file")
        self._process.start()
        child.close()

    def wait(self) -> None:
        """Wait for the file.

        Raises:
            OSError: the child could not write the file (a full disk: as this process would have raised it).
            RuntimeError: the child failed otherwise (its exception and traceback in the message).
            WorkerLost: the child was killed from outside (the out-of-memory killer, a signal).
        """
        if self._process is None:
            return
        try:
            failure = self._conn.recv()
        except EOFError:
            self._process.join()
            code = self._process.exitcode
            self.close()
            raise WorkerLost(f"the process making {self.path.name}", code, "run again with more memory") from None
        self._process.join()
        self.close()
        if failure is not None:
            exc, text = failure
            if isinstance(exc, OSError):
                raise exc
            raise RuntimeError(f"making {self.path.name} failed: {text}") from exc

    def close(self) -> None:
        if self._process is None:
            return
        if self._process.is_alive():
            self._process.terminate()
        self._process.join()
        self._conn.close()
        self._process = None
        gc.unfreeze()

    def __enter__(self) -> ForkedFile:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
