"""The sweep cut into blocks: the task count grows with the grid (in y and z), the left support's blocks mirror
the right's, and the output does not depend on the number of workers or the executor, to the bit."""

from __future__ import annotations

import numpy as np
import pytest

from jethr1_plan.balance_space.blocks import SweepState, TaskTimes, makespan, partition
from jethr1_plan.balance_space.continuation import BlockResult
from jethr1_plan.balance_space.spec import SearchSettings, SweepSpec
from jethr1_plan.balance_space.sweep import sweep
from jethr1_plan.io.forked import fork_available
from jethr1_plan.reasons import Reason

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


def test_the_state_gives_back_every_value_written_to_the_bit():
    state = SweepState((3, 4, 5))
    p_body, objective, reason = state.arrays()
    assert np.isnan(p_body).all() and np.isposinf(objective).all() and np.all(reason == Reason.UNREACHABLE)
    rng = np.random.default_rng(3)
    cells = rng.permutation(60)[:40]
    P = rng.normal(size=(40, 3))
    P[::3] = np.nan
    P[1, 1] = -np.nan  # any NaN's bits come back
    f = np.where(rng.random(40) < 0.3, np.inf, rng.normal(size=40))
    f[2] = -0.0
    why = rng.choice([Reason.OK, Reason.UNREACHABLE, Reason.JOINT_LIMIT, Reason.THRUST_MAX], 40).astype(np.int8)
    answer = BlockResult(cells, P, f, why, int(np.count_nonzero(why == Reason.OK)), 0, 0.0)
    state.put(answer, first=True)
    assert state.p_body_at(cells).tobytes() == P.tobytes() and state.objective_at(cells).tobytes() == f.tobytes()
    p_body, objective, reason = state.arrays()
    assert p_body[cells].tobytes() == P.tobytes() and objective[cells].tobytes() == f.tobytes()
    assert reason[cells].tobytes() == why.tobytes()
    rest = np.setdiff1d(np.arange(60), cells)
    assert np.isnan(p_body[rest]).all() and np.isposinf(objective[rest]).all()
    state.put(BlockResult(cells[:5], np.full((5, 3), np.nan), np.full(5, np.inf), np.full(5, Reason.UNREACHABLE,
                                                                                             np.int8), 0, 0, 0.0))
    p_body, objective, reason = state.arrays()  # a later answer overwrites, start values too
    assert np.isnan(p_body[cells[:5]]).all() and np.isposinf(objective[cells[:5]]).all()
    assert np.all(reason[cells[:5]] == Reason.UNREACHABLE)


def test_a_dask_cluster_gives_the_same_bytes(one_process):
    pytest.importorskip("distributed")
    dask = sweep(COARSE, jobs=2, executor="dask", settings=SMALL)
    for name in ("thrust", "p_body", "reason"):
        assert getattr(one_process, name).tobytes() == getattr(dask, name).tobytes()
