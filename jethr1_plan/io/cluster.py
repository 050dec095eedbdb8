"""Dask clusters for ``--executor dask``: a local cluster of ``jobs`` worker processes, or the
scheduler at ``--scheduler``, reached within a few seconds or reported as one line."""

from __future__ import annotations

import logging
from contextlib import contextmanager
from typing import Any

from jethr1_plan.errors import InputError, show_notices_as_lines

__all__ = ["CONNECT_TIMEOUT_S", "dask_client"]

CONNECT_TIMEOUT_S = 5.0  # a scheduler that does not answer within this is reported [s]


@contextmanager
def dask_client(scheduler: str | None, jobs: int) -> Any:
    """A ``distributed.Client``: connected to ``scheduler``, else a local cluster of ``jobs`` processes.

    Raises:
        InputError: no scheduler answers at ``scheduler`` within :data:`CONNECT_TIMEOUT_S` (exit 2).
    """
    from distributed import Client

    if scheduler is None:
        # the local cluster's own warnings (a cancelled task, a busy worker killed on Ctrl-C) stay off the
        # user's terminal: the command reports in its own lines
        with Client(processes=True, n_workers=jobs, threads_per_worker=1, silence_logs=logging.ERROR,
                    dashboard_address=":0") as client:  # a free port: two sweeps at once do not collide
            client.run(show_notices_as_lines)  # a worker that compiles the kernels says so in one line
            yield client
        return
    try:
        client = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        problem = str(exc).splitlines()[0][:120] if str(exc) else type(exc).__name__
        raise InputError("--scheduler", scheduler, f"no Dask scheduler answered within {CONNECT_TIMEOUT_S:g} s "
                         f"({problem})") from None
    with client:
        _same_arithmetic(client, scheduler)
        client.run(show_notices_as_lines)
        yield client


def _same_arithmetic(client: Any, scheduler: str) -> None:
    """Refuse a cluster whose workers compute otherwise than this process (``arithmetic.signature``): their
    results would differ from ``-j 1``'s in the last digits, and a sweep's bytes would depend on which worker
    ran which task. (A local cluster's workers inherit this process's pinned environment.)

    Raises:
        InputError: a worker's signature differs from this process's (exit 2).
    """
    import platform

    from jethr1_plan.arithmetic import cpu_flags, pinned_environment, signature

    mine = signature()
    for worker, theirs in sorted(client.run(signature).items()):
        if theirs != mine:
            pins = pinned_environment({}, platform.machine(), cpu_flags())
            how = ("with " + " ".join(f"{k}='{v}'" for k, v in pins.items()) if pins
                   else f"on {platform.machine()} machines of this one's kind")
            raise InputError("--scheduler", scheduler, f"worker {worker} computes with {theirs}, this command with "
                             f"{mine}: its results would differ from -j 1's in the last digits; start the workers "
                             f"{how} (docs/install.md)")
