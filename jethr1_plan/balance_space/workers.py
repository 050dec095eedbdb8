"""The sweep on this machine's cores with the least memory: the command loads the compiled kernels and PlaCo
once and forks its worker processes from itself, so that they share those pages instead of each loading its own
copy; the command holds the sweep's state and hands the workers one task at a time.

Why (docs/balance_space.md, "Memory", measures it): a worker started afresh (a loky process, a Dask worker)
imports numpy, PlaCo and numba and loads the kernels, each its own copy before any task. A forked worker shares
every page of its parent's until it writes one. The workers are forked from the command itself, not from a
process of its own between them: such a host copies the command's pages it writes (Python's reference counts)
while the command waits.

Forking is safe where no thread of the forking process holds a lock the child needs: the workers are forked when
:class:`ForkedSweep` is made, which the command does before it starts its progress bar. Each worker has a pipe of
its own and no thread stands between it and the command (:class:`ForkedWorkers`): a worker that dies is the end
of its pipe, and a worker killed while it sends an answer leaves nothing waiting on the rest of it (a process
pool's result thread can wait for good on a worker killed mid-answer).
glibc's malloc in the command and workers gives freed arrays back to the system (``M_MMAP_THRESHOLD`` fixed at
256 kB, trimmed beyond 1 MB): a task's arrays are freed when it ends, not kept for the next one.

The workers die with the command however it ends (``io.forked.die_with_parent``): a command killed by the
out-of-memory killer leaves no sweep behind, and an error, Ctrl-C or SIGTERM kills them at once. Under memory
pressure the out-of-memory killer takes a worker before the command (``io.forked.be_killed_first``); a worker
killed from outside is :class:`~jethr1_plan.errors.WorkerLost` in the command (exit 7), not a traceback.
"""

from __future__ import annotations

import contextlib
import gc
import multiprocessing
import os
import time
from collections.abc import Callable, Iterable, Iterator
from multiprocessing.connection import Connection, wait

import numpy as np

from jethr1_plan.balance_space.blocks import SweepState, TaskTimes, run_blocks
from jethr1_plan.balance_space.continuation import BlockResult, search_block
from jethr1_plan.balance_space.spec import SearchSettings, SweepSpec
from jethr1_plan.errors import WorkerLost
from jethr1_plan.io.forked import before_fork, worker_start

__all__ = ["ForkedSweep", "ForkedWorkers", "load_kernels"]

WARM_UP_RISE_M = 0.15  # the warm-up row's swing sole this far above the support (cells there get the polish)
WARM_UP_SIDE_M = 0.2  # ... and this far to the swing side of it (most of its cells are members: PlaCo re-checks)


def load_kernels(spec: SweepSpec, settings: SearchSettings) -> BlockResult:
    """Load every kernel a sweep's task runs, and PlaCo, into this process: the search of one row of cells of
    ``spec``'s grid along x (the whole x axis at one y and one z near a member's), whose answer is discarded."""
    ax, ay, az = spec.axes()
    sup = np.asarray(spec.support)
    side = 1.0 if spec.swing_side == "left" else -1.0
    j = int(np.argmin(np.abs(ay - (sup[1] + side * WARM_UP_SIDE_M))))
    k = int(np.argmin(np.abs(az - (sup[2] + WARM_UP_RISE_M))))
    return search_block(spec, settings, (slice(None), slice(j, j + 1), slice(k, k + 1)), np.arange(len(ax)))


def _serve(conn: Connection, parent_pid: int) -> None:
    """A forked worker: (function, args) tasks from ``conn``, each answered on it as (True, answer) or (False, the
    exception), until ``conn`` closes or sends None."""
    worker_start(parent_pid)
    while True:
        try:
            task = conn.recv()
        except EOFError:
            return
        if task is None:
            return
        fn, args = task
        try:
            answer: tuple = (True, fn(*args))
        except Exception as exc:  # (raised in the parent)
            answer = (False, exc)
        try:
            conn.send(answer)
        except Exception as exc:  # an answer or exception that cannot be pickled
            conn.send((False, RuntimeError(f"a balance-space task's answer could not be sent: {exc!r}")))


class ForkedWorkers:
    """``jobs`` worker processes forked from this one (which should have loaded the kernels: :func:`load_kernels`),
    each with a pipe of its own; called with (function, args) tasks, it gives their answers in any order. A worker
    that dies is seen at once (its pipe's end: :class:`~jethr1_plan.errors.WorkerLost`), and killing the workers
    leaves nothing waiting on a half-sent answer. A context manager: the workers end when it closes, at once when
    it is left on an exception."""

    def __init__(self, jobs: int):
        before_fork()
        ctx = multiprocessing.get_context("fork")
        self._conns: list[Connection] = []
        self._workers: list[multiprocessing.process.BaseProcess] = []
        try:
            for _ in range(jobs):
                mine, theirs = ctx.Pipe()
                proc = ctx.Process(target=_serve, args=(theirs, os.getpid()), name="jethr1-balance-space-worker")
                proc.start()
                theirs.close()  # (so that the worker's death is the pipe's end here)
                self._conns.append(mine)
                self._workers.append(proc)
        except BaseException:
            self.close(kill=True)
            raise

    def __call__(self, tasks: Iterable[tuple]) -> Iterator[BlockResult]:
        """The answers of ``tasks``, as they come; one task a worker at a time (a task's arguments are made when it
        is handed out and dropped once sent: a round's task carries ~3 MB at 1 cm).

        Raises:
            what a task raised; WorkerLost: a worker died before it answered.
        """
        todo = iter(tasks)
        idle = list(range(len(self._workers)))[::-1]  # (worker 0 takes the first task)
        busy: dict[Connection, int] = {}
        while True:
            while idle:
                task = next(todo, None)
                if task is None:
                    break
                k = idle.pop()
                try:
                    self._conns[k].send(task)
                except OSError:  # (a broken pipe: it died)
                    raise self._lost(k) from None
                del task
                busy[self._conns[k]] = k
            if not busy:
                return
            ready = wait(list(busy))
            for conn in [c for c in busy if c in ready]:
                k = busy.pop(conn)
                try:
                    ok, answer = conn.recv()
                except (EOFError, OSError):
                    raise self._lost(k) from None
                idle.append(k)
                if not ok:
                    raise answer
                yield answer

    def _lost(self, k: int) -> WorkerLost:
        """Worker ``k``'s death, once it is reaped (its exit code: minus the signal that ended it)."""
        self._workers[k].join(5.0)
        return WorkerLost("a worker process of the balance-space sweep", self._workers[k].exitcode)

    def close(self, kill: bool = False) -> None:
        """End the workers: once they have their last task done, or at once (``kill``: the answers are no longer
        wanted)."""
        for proc, conn in zip(self._workers, self._conns, strict=False):
            if kill:
                if proc.is_alive():
                    proc.kill()
            else:
                with contextlib.suppress(OSError):  # (one that died is joined all the same)
                    conn.send(None)
        for proc in self._workers:
            proc.join()
        for conn in self._conns:
            conn.close()
        self._workers, self._conns = [], []
        gc.unfreeze()

    def __enter__(self) -> ForkedWorkers:
        return self

    def __exit__(self, exc_type, *exc) -> None:
        self.close(kill=exc_type is not None)


class ForkedSweep:
    """A sweep run by this process with ``jobs`` workers forked from it (see the module), prepared when made: the
    kernels loaded here and the workers forked, so make it before any thread starts (the command makes it before
    its progress bar). :meth:`result` runs the sweep and ends the workers. A context manager: leaving it on an
    exception (an error, Ctrl-C, SIGTERM) kills the workers at once."""

    def __init__(self, spec: SweepSpec, settings: SearchSettings, jobs: int):
        self.t0 = time.perf_counter()
        self.spec, self.settings = spec, settings
        load_kernels(spec, settings)
        # (one job too runs in a worker: the memory its tasks leave behind goes with it, before the files)
        self._workers: ForkedWorkers | None = ForkedWorkers(jobs)

    def result(self, progress: Callable[[str, int, int], None] | None = None) -> tuple[SweepState, TaskTimes, int]:
        """The state, the tasks' times and the evaluations of the sweep, run now (``progress`` called as stages
        advance); the workers end with it, before the caller builds anything from it.

        Raises:
            what a task raised; WorkerLost: a worker was killed from outside.
        """
        if self._workers is None:
            raise RuntimeError("this sweep was run already")
        try:
            return run_blocks(self.spec, self.settings, self._workers, progress)
        except BaseException:
            self.close(kill=True)
            raise
        finally:
            self.close()

    def close(self, kill: bool = False) -> None:
        if self._workers is not None:
            self._workers.close(kill)
            self._workers = None

    def __enter__(self) -> ForkedSweep:
        return self

    def __exit__(self, exc_type, *exc) -> None:
        self.close(kill=exc_type is not None)
