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
        client.run(show_notices_as_lines)
        yield client
