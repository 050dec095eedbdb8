"""The forked sweep (``balance_space.workers``): its host's failure reaches the command, the host ends with the sweep,
the forked workers answer every task."""

from __future__ import annotations

import multiprocessing

import pytest

from jethr1_plan.balance_space import workers
from jethr1_plan.balance_space.spec import SearchSettings, SweepSpec
from jethr1_plan.io.forked import fork_available

pytestmark = pytest.mark.skipif(not fork_available(), reason="the forked sweep needs Linux")
COARSE = SweepSpec(resolution_m=0.1)


def _fails(*args, **kwargs):
    raise ValueError("a task failed")


def test_a_failure_in_the_host_is_raised_in_the_command(monkeypatch):
    monkeypatch.setattr(workers, "run_blocks", _fails)  # (the host is forked: it runs this module as patched)
    host = workers.ForkedSweep(COARSE, SearchSettings(), 2)
    with pytest.raises(ValueError, match="a task failed"):
        host.result()
    assert not host._process.is_alive()


def test_the_host_ends_with_the_sweep():
    with workers.ForkedSweep(COARSE, SearchSettings(), 2) as host:
        _, times, evaluations = host.result()
    assert evaluations > 0 and len(times.stages[0]) >= 1
    assert not host._process.is_alive() and host._process.exitcode == 0
    assert all(p.name != "jethr1-balance-space" for p in multiprocessing.active_children())


def test_forked_workers_answer_every_task():
    with workers.ForkedWorkers(2) as pool:
        answers = sorted(pool((divmod, (n, 3)) for n in range(7)))
    assert answers == sorted(divmod(n, 3) for n in range(7))


def test_the_shared_state_goes_with_the_sweeps_result():
    """The sweep's state (33 bytes a cell: 234 MB at 0.5 cm) is memory shared with the host; once the command
    has the sweep's result, nothing holds that memory while the files are built."""
    import weakref

    from jethr1_plan.balance_space.sweep import sweep

    with workers.ForkedSweep(COARSE, SearchSettings(), 2) as host:
        state = weakref.ref(host.state)
        result = sweep(COARSE, jobs=2, executor="fork", forked=host)
    assert host.state is None and state() is None
    assert result.with_thrust.any()
