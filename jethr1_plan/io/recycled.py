"""Calls made in a child process that is replaced after a number of calls: a long run's memory stays bounded
whatever the work leaves behind in the process that does it (PlaCo keeps about 0.36 MB of every robot model it
loads, ``robot.wrappers``; a design sweep loads one per variant).

:func:`call` sends ``module:function`` and its argument (pickled) to the calling thread's child, a Python process
of its own (``python -m jethr1_plan.io.recycled``), and returns the child's result; the child ends after
``limit`` calls and the next call starts a new one. It works in any process: this command's, a loky worker's, a
Dask worker's (a daemonic process, which ``multiprocessing`` may not give children).

The child dies with the process that started it (``io.pool.worker_start``: the thread that started it, or the
process, ending); it has a session of its own, so Ctrl-C reaches the command alone, which then ends its children
(:func:`stop_all`). Under memory pressure the out-of-memory killer takes the child first: a child that ends
without an answer is :class:`~jethr1_plan.errors.WorkerLost` (exit 7). Whatever the child prints goes to the
command's stderr; its answers go through a pipe of their own.
"""

from __future__ import annotations

import importlib
import os
import pickle
import subprocess
import sys
import threading
import traceback
from pathlib import Path
from typing import Any

from jethr1_plan.errors import WorkerLost

__all__ = ["Child", "call", "stop_all"]


class Child:
    """One child process and the calls it has answered."""

    def __init__(self, limit: int) -> None:
        root = str(Path(__file__).resolve().parents[2])  # the folder holding jethr1_plan, for the child's imports
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join([root] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
        self.limit = limit
        self.calls = 0
        self.proc = subprocess.Popen([sys.executable, "-m", "jethr1_plan.io.recycled", str(os.getpid()), str(limit)],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=env, close_fds=True,
                                     start_new_session=True)

    def call(self, target: str, arg: Any) -> Any:
        """``target`` (``module:function``) called with ``arg`` in the child; its exception, as a RuntimeError
        carrying the child's traceback.

        Raises:
            WorkerLost: the child ended without answering.
        """
        assert self.proc.stdin is not None and self.proc.stdout is not None
        try:
            pickle.dump((target, arg), self.proc.stdin, protocol=pickle.HIGHEST_PROTOCOL)
            self.proc.stdin.flush()
            status, value = pickle.load(self.proc.stdout)
        except (EOFError, BrokenPipeError, pickle.UnpicklingError):
            self.stop()
            raise WorkerLost("a judging process", self.proc.returncode) from None
        self.calls += 1
        if status == "error":
            raise RuntimeError(f"{target} failed in a child process:\n{value}")
        return value

    @property
    def spent(self) -> bool:
        """Whether it has answered its ``limit`` calls (and so ends) or ended already."""
        return self.calls >= self.limit or self.proc.poll() is not None

    def stop(self) -> None:
        """End the child (killed where it has not ended) and reap it."""
        if self.proc.poll() is None and self.calls < self.limit:
            self.proc.kill()
        for f in (self.proc.stdin, self.proc.stdout):
            try:
                if f is not None:
                    f.close()
            except OSError:
                pass
        self.proc.wait()


_local = threading.local()
_lock = threading.Lock()
_children: set[Child] = set()


def call(target: str, arg: Any, limit: int) -> Any:
    """``target(arg)`` (``target``: ``"module:function"``, both picklable) in this thread's child process, a
    new one after every ``limit`` calls (see the module)."""
    child: Child | None = getattr(_local, "child", None)
    if child is not None and child.spent:
        child.stop()
        with _lock:
            _children.discard(child)
        child = None
    if child is None:
        child = _local.child = Child(limit)
        with _lock:
            _children.add(child)
    try:
        return child.call(target, arg)
    except WorkerLost:
        _local.child = None
        with _lock:
            _children.discard(child)
        raise


def stop_all() -> None:
    """End every child this process started (those of every thread)."""
    with _lock:
        children = list(_children)
        _children.clear()
    for child in children:
        child.stop()


def _serve(parent_pid: int, limit: int) -> None:
    """The child: answer ``limit`` calls read from stdin on a pipe of its own, then end."""
    from jethr1_plan.io.pool import worker_start

    worker_start(parent_pid)
    answers = os.fdopen(os.dup(1), "wb")
    requests = os.fdopen(os.dup(0), "rb")
    os.dup2(2, 1)  # what the work prints goes to stderr, not into the answers
    devnull = os.open(os.devnull, os.O_RDONLY)
    os.dup2(devnull, 0)
    for _ in range(limit):
        try:
            target, arg = pickle.load(requests)
        except EOFError:
            return
        module, name = target.split(":")
        try:
            answer: tuple[str, Any] = ("ok", getattr(importlib.import_module(module), name)(arg))
            data = pickle.dumps(answer, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception:
            data = pickle.dumps(("error", traceback.format_exc()), protocol=pickle.HIGHEST_PROTOCOL)
        answers.write(data)
        answers.flush()


if __name__ == "__main__":
    _serve(int(sys.argv[1]), int(sys.argv[2]))
    sys.stdout.flush()
    os._exit(0)
