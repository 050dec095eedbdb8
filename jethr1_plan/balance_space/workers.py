"""The sweep on this machine's cores with the least memory: the command loads the compiled kernels and PlaCo
once and forks its worker processes from itself, so that they share those pages instead of each loading its own
copy; the command holds the sweep's state and hands the workers one task at a time.

Why (measured at 1 cm, ``bench/bench_balance_space.py timing``; docs/balance_space.md, "Memory"): a worker
started afresh (a loky process, a Dask worker) imports numpy, PlaCo and numba and loads the kernels: ~116 MB of
proportional set size (PSS) each before any task. A forked worker shares every page of its parent's until it
writes one. The workers are forked from the command itself, not from a process of its own between them: such a
host copied ~23 MB of the command's pages by writing them (Python's reference counts) while the command waited.

Forking is safe where no thread of the forking process holds a lock the child needs: the workers are forked when
:class:`ForkedSweep` is made, which the command does before it starts its progress bar
(:class:`concurrent.futures.ProcessPoolExecutor` forks all of them before its manager thread starts).
glibc's malloc in the command and workers gives freed arrays back to the system (``M_MMAP_THRESHOLD`` fixed at
256 kB, trimmed beyond 1 MB): a task's arrays are freed when it ends, not kept for the next one.

The workers die with the command however it ends (``io.forked.die_with_parent``): a command killed by the
out-of-memory killer leaves no sweep behind, and an error, Ctrl-C or SIGTERM kills them at once. Under memory
pressure the out-of-memory killer takes a worker before the command (``io.forked.be_killed_first``); a worker
killed from outside is :class:`~jethr1_plan.errors.WorkerLost` in the command (exit 7), not a traceback.
"""

from __future__ import annotations

import gc
import multiprocessing
import os
import signal
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

import numpy as np

from jethr1_plan.balance_space.blocks import SweepState, TaskTimes, run_blocks
from jethr1_plan.balance_space.continuation import BlockResult, search_block
from jethr1_plan.balance_space.spec import SearchSettings, SweepSpec
from jethr1_plan.errors import WorkerLost
from jethr1_plan.io.forked import before_fork, lost_process, worker_start

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


class ForkedWorkers:
    """``jobs`` worker processes forked from this one (which should have loaded the kernels: :func:`load_kernels`);
    called with (function, args) tasks, it gives their answers in any order. A context manager: the workers end
    when it closes."""

    def __init__(self, jobs: int):
        before_fork()
        self.jobs = jobs
        self._pool = ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("fork"),
                                         initializer=worker_start, initargs=(os.getpid(),))
        self._pool.submit(int).result()  # forks every worker now, before the pool starts its threads
        self._workers = list((getattr(self._pool, "_processes", None) or {}).values())  # (their exit codes)

    def __call__(self, tasks: Iterable[tuple]) -> Iterator[BlockResult]:
        """The answers of ``tasks``, as they come; one task a worker submitted at a time (a task's arguments are
        made when it is submitted and held until it is done: a round's task carries ~3 MB at 1 cm)."""
        todo = iter(tasks)
        running: set[Future] = set()
        try:
            while True:
                for fn, args in todo:
                    running.add(self._pool.submit(fn, *args))
                    if len(running) >= self.jobs:
                        break
                if not running:
                    return
                done, running = wait(running, return_when=FIRST_COMPLETED)
                for f in done:
                    yield f.result()
        except BrokenProcessPool:  # (from a task's answer, or from a submission once the pool knows)
            self._pool.shutdown(wait=True, cancel_futures=True)  # (the pool ends the others: exit codes known)
            raise WorkerLost(lost_process("a worker process of the balance-space sweep", self._lost())) from None

    def _lost(self) -> int | None:
        """The exit code of the worker that was lost (minus its signal's number), once the pool has ended the
        others (with SIGTERM), if one is known."""
        codes = [p.exitcode for p in self._workers if p.exitcode]
        lost = [c for c in codes if c != -signal.SIGTERM]
        return (lost or codes or [None])[0]

    def close(self, kill: bool = False) -> None:
        """End the workers: when their tasks are done, or at once (``kill``: the answers are no longer wanted)."""
        if kill:
            for proc in self._workers:
                if proc.is_alive():
                    proc.kill()
        self._pool.shutdown(wait=True, cancel_futures=True)
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
