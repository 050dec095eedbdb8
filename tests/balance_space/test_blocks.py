"""The sweep cut into blocks: the task count grows with the grid (in y and z), the left support's blocks mirror
the right's, and the output does not depend on the number of workers or the executor, to the bit."""

from __future__ import annotations

import numpy as np
import pytest

from jethr1_plan.balance_space.blocks import SweepState, TaskTimes, makespan, partition
from jethr1_plan.balance_space.spec import SearchSettings, SweepSpec
from jethr1_plan.balance_space.sweep import sweep
from jethr1_plan.balance_space.workers import fork_available

# a coarse grid cut into many small blocks, so that boundary rounds run between them
SMALL = SearchSettings(block_y_cells=6, block_z_layers=2)
COARSE = SweepSpec(resolution_m=0.05)


def test_the_task_count_grows_with_the_grid():
    default = SearchSettings()
    one_cm = partition((171, 171, 31), default, mirror=False)
    half_cm = partition((341, 341, 61), default, mirror=False)
    assert len(one_cm) == 4 * 4 and len(half_cm) == 8 * 8
    for blocks, shape in ((one_cm, (171, 171, 31)), (half_cm, (341, 341, 61))):
        covered = np.zeros(shape[1:], dtype=int)
        for b in blocks:
            assert b.y[1] - b.y[0] <= default.block_y_cells and b.z[1] - b.z[0] <= default.block_z_layers
            covered[slice(*b.y), slice(*b.z)] += 1
        assert np.all(covered == 1)  # every cell in exactly one block
    mirrored = partition((171, 171, 31), default, mirror=True)
    assert sorted((171 - b.y[1], 171 - b.y[0], b.z) for b in mirrored) == sorted((b.y[0], b.y[1], b.z)
                                                                                for b in one_cm)


def test_makespan_schedules_each_stage_greedily():
    times = TaskTimes(stages=[[4.0, 3.0, 2.0, 1.0], [5.0]])
    assert makespan(times, 1) == 15.0
    assert makespan(times, 2) == 5.0 + 5.0  # 4 | 3 then 2 onto the 3's worker (5), 1 onto the 4's (5)
    assert makespan(times, 16) == times.critical_path_s == 9.0


@pytest.fixture(scope="module")
def one_process():
    return sweep(COARSE, jobs=1, settings=SMALL)


def test_many_blocks_and_rounds_give_the_same_bytes_on_any_number_of_workers(one_process):
    times = one_process.extra["task_times"]
    assert len(times.stages[0]) == 6 * 4 and len(times.stages) >= 2  # boundary rounds ran between the blocks
    assert np.count_nonzero(one_process.with_thrust) > 100
    two = sweep(COARSE, jobs=2, settings=SMALL)
    for name in ("thrust", "p_body", "reason"):
        assert getattr(one_process, name).tobytes() == getattr(two, name).tobytes()
    assert two.evaluations == one_process.evaluations


@pytest.mark.skipif(not fork_available(), reason="the forked sweep needs Linux")
@pytest.mark.parametrize("jobs", [1, 2])
def test_the_forked_sweep_gives_the_same_bytes(one_process, jobs):
    forked = sweep(COARSE, jobs=jobs, executor="fork", settings=SMALL)
    for name in ("thrust", "p_body", "reason"):
        assert getattr(one_process, name).tobytes() == getattr(forked, name).tobytes()
    assert forked.evaluations == one_process.evaluations
    assert [len(s) for s in forked.extra["task_times"].stages] == [len(s) for s in
                                                                   one_process.extra["task_times"].stages]


def test_a_shared_state_starts_as_a_private_one():
    a, b = SweepState((3, 4, 5)), SweepState((3, 4, 5), shared=True)
    for name in ("p_body", "objective", "reason"):
        assert getattr(a, name).tobytes() == getattr(b, name).tobytes()
        assert getattr(a, name).dtype == getattr(b, name).dtype


def test_a_dask_cluster_gives_the_same_bytes(one_process):
    pytest.importorskip("distributed")
    dask = sweep(COARSE, jobs=2, executor="dask", settings=SMALL)
    for name in ("thrust", "p_body", "reason"):
        assert getattr(one_process, name).tobytes() == getattr(dask, name).tobytes()
