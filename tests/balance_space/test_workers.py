"""The forked sweep (``balance_space.workers``): a task's failure reaches the command and ends the workers at once,
the workers end with the sweep, the forked workers answer every task."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from jethr1_plan.balance_space import blocks, workers
from jethr1_plan.balance_space.spec import SearchSettings, SweepSpec
from jethr1_plan.io.forked import OOM_SCORE_ADJ, fork_available

pytestmark = pytest.mark.skipif(not fork_available(), reason="the forked sweep needs Linux")
COARSE = SweepSpec(resolution_m=0.1)


def _fails(*args, **kwargs):
    raise ValueError("a task failed")


def _slow_or_fails(spec, settings, box, flat):
    if box[2].start == 0:
        raise ValueError("a task failed")
    time.sleep(60)  # a task still running when the other fails


def test_a_failure_in_a_worker_is_raised_in_the_command_and_ends_the_others_at_once(monkeypatch):
    monkeypatch.setattr(blocks, "search_block", _slow_or_fails)  # (the workers are forked: they run it as patched)
    prepared = workers.ForkedSweep(COARSE, SearchSettings(block_z_layers=1), 2)
    pool = prepared._workers
    assert pool is not None
    t0 = time.monotonic()
    with pytest.raises(ValueError, match="a task failed"), prepared:
        prepared.result()
    assert time.monotonic() - t0 < 30  # the sleeping task was not waited for
    assert not any(p.is_alive() for p in pool._workers)


def test_the_workers_end_with_the_sweep():
    with workers.ForkedSweep(COARSE, SearchSettings(), 2) as prepared:
        pool = prepared._workers
        assert pool is not None and all(p.is_alive() for p in pool._workers)
        _, times, evaluations = prepared.result()
        assert not any(p.is_alive() for p in pool._workers)  # before the caller builds its files
    assert evaluations > 0 and len(times.stages[0]) >= 1


def _oom_score_adj() -> int:
    return int(Path("/proc/self/oom_score_adj").read_text())


def test_under_memory_pressure_a_worker_is_killed_before_the_command():
    """The out-of-memory killer then leaves the command to say so (exit 7) instead of killing it silently."""
    with workers.ForkedWorkers(2) as pool:
        theirs = list(pool((_oom_score_adj, ()) for _ in range(2)))
    assert theirs == [OOM_SCORE_ADJ] * 2 and _oom_score_adj() < OOM_SCORE_ADJ


def test_forked_workers_answer_every_task():
    with workers.ForkedWorkers(2) as pool:
        answers = sorted(pool((divmod, (n, 3)) for n in range(7)))
    assert answers == sorted(divmod(n, 3) for n in range(7))
