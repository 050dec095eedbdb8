"""The sweep on this machine's cores with the least memory: run in a process forked from the command (the *host*),
which loads the compiled kernels and PlaCo once and forks its worker processes from itself, so that they share
those pages instead of each loading its own copy; the sweep's state lives in memory shared with the command.

Why (measured at 1 cm, ``bench/bench_balance_space.py timing``; docs/balance_space.md, "Memory"): a worker
started afresh (a loky process, a Dask worker) imports numpy, PlaCo and numba and loads the kernels: ~116 MB of
proportional set size (PSS) each before any task. A forked worker shares every page of its parent's until it
writes one: after its tasks it holds ~7 MB of its own. The host, not the command, loads the kernels (numba's
compiler state and the kernels' code, ~70 MB) and ends with the sweep: the command builds its files without them.

Forking is safe where no thread of the forking process holds a lock the child needs: the host is forked when
:class:`ForkedSweep` is made (the command makes it before it starts its progress bar) and uses nothing of the
command's but the pipe it reports on; the host forks its workers before it starts any thread
(:class:`concurrent.futures.ProcessPoolExecutor` forks all of them before its manager thread starts).
glibc's malloc in the host and workers gives freed arrays back to the system (``M_MMAP_THRESHOLD`` fixed at
256 kB, trimmed beyond 1 MB): a task's arrays are freed when it ends, not kept for the next one.

The host dies with the command and the workers with the host, however either ends (``io.forked.die_with_parent``):
a command killed by the out-of-memory killer leaves no sweep behind, and a SIGTERM ends every process at once. A
worker killed from outside is :class:`~jethr1_plan.errors.WorkerLost` in the command (exit 7), not a traceback.
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
from jethr1_plan.io.forked import before_fork, die_with_parent, lost_process

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
                                         initializer=die_with_parent, initargs=(os.getpid(),))
        self._pool.submit(int).result()  # forks every worker now, before the pool starts its threads
        self._workers = list((getattr(self._pool, "_processes", None) or {}).values())  # (their exit codes)

    def __call__(self, tasks: Iterable[tuple]) -> Iterator[BlockResult]:
        """The answers of ``tasks``, as they come; one task a worker submitted at a time (a task's arguments are
        made when it is submitted and held until it is done: a round's task carries ~3 MB at 1 cm)."""
        todo = iter(tasks)
        running: set[Future] = set()
        while True:
            for fn, args in todo:
                running.add(self._pool.submit(fn, *args))
                if len(running) >= self.jobs:
                    break
            if not running:
                return
            done, running = wait(running, return_when=FIRST_COMPLETED)
            for f in done:
                try:
                    answer = f.result()
                except BrokenProcessPool:
                    raise WorkerLost(lost_process("a worker process of the balance-space sweep", self._lost())) \
                        from None
                yield answer

    def _lost(self) -> int | None:
        """The exit code of a worker that ended (minus its signal's number), if one is known."""
        codes = [p.exitcode for p in self._workers if p.exitcode]
        return codes[0] if codes else None

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)
        gc.unfreeze()

    def __enter__(self) -> ForkedWorkers:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _in_process(tasks: Iterable[tuple]) -> Iterator[BlockResult]:
    for fn, args in tasks:
        yield fn(*args)


def _host(conn, parent_pid: int, spec: SweepSpec, settings: SearchSettings, jobs: int, state: SweepState) -> None:
    """The host process: the kernels loaded, ``jobs`` workers forked (none: the tasks run here), the sweep run
    into the shared ``state``; reports ("progress", label, done, total), then ("done", times, evaluations) or
    ("error", exception) on ``conn``."""
    die_with_parent(parent_pid)
    signal.signal(signal.SIGTERM, lambda *_: os._exit(1))  # its workers die with it (die_with_parent)
    try:
        load_kernels(spec, settings)

        def progress(label: str, done: int, total: int) -> None:
            conn.send(("progress", label, done, total))

        if jobs > 1:
            with ForkedWorkers(jobs) as workers:
                _, times, evaluations = run_blocks(spec, settings, workers, progress, state)
        else:
            _, times, evaluations = run_blocks(spec, settings, _in_process, progress, state)
        conn.send(("done", times, evaluations))
    except BaseException as exc:  # reported to the command, which raises it
        try:
            conn.send(("error", exc))
        except Exception:  # an exception that cannot be pickled
            conn.send(("error", RuntimeError(f"the balance-space sweep failed: {exc!r}")))
    finally:
        conn.close()


class ForkedSweep:
    """A sweep running in a host process forked from this one (see the module), started when made; its state in
    memory shared with this process. :meth:`result` waits for it. A context manager: closing it ends the host
    (and its workers) if it still runs."""

    def __init__(self, spec: SweepSpec, settings: SearchSettings, jobs: int):
        self.t0 = time.perf_counter()
        shape = tuple(len(a) for a in spec.axes())
        self.state: SweepState | None = SweepState(shape, shared=True)  # type: ignore[arg-type]
        before_fork()  # (and this process's collections leave the objects it shares with the host alone)
        ctx = multiprocessing.get_context("fork")
        self._conn, child = ctx.Pipe(duplex=False)
        self._process = ctx.Process(target=_host, args=(child, os.getpid(), spec, settings, jobs, self.state),
                                    name="jethr1-balance-space")
        self._process.start()
        child.close()

    def result(self, progress: Callable[[str, int, int], None] | None = None) -> tuple[SweepState, TaskTimes, int]:
        """The state, the tasks' times and the evaluations, once the host is done (its progress passed on); this
        object keeps no reference to the state, so that its shared memory goes when the caller drops it.

        Raises:
            the host's exception; WorkerLost: the host or a worker was killed from outside.
        """
        while True:
            try:
                msg = self._conn.recv()
            except EOFError:
                self._process.join()
                raise WorkerLost(lost_process("the balance-space sweep's process", self._process.exitcode)) \
                    from None
            if msg[0] == "progress":
                if progress:
                    progress(*msg[1:])
            elif msg[0] == "error":
                self.close()
                raise msg[1]
            else:
                self._process.join()
                state, self.state = self.state, None  # the caller's alone: freed when it lets go (sweep())
                if state is None:
                    raise RuntimeError("the balance-space sweep's result was taken already")
                return state, msg[1], msg[2]

    def close(self) -> None:
        if self._process.is_alive():
            self._process.terminate()
        self._process.join()
        self._conn.close()
        gc.unfreeze()

    def __enter__(self) -> ForkedSweep:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
