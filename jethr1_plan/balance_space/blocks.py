"""The sweep cut into blocks, so that the number of tasks grows with the grid and the output does not depend on
the number of workers, their order or the executor.

A block is the whole x axis (the forward continuation along +x stays intact: cutting x loses members) times
``block_y_cells`` cells of y and ``block_z_layers`` layers of z (``SearchSettings``); for a left support the
y blocks are counted from the far end, the mirror image of a right support's. The sweep runs in stages, each
a set of independent tasks:

1. every block searched on its own (``continuation.search_block``);
2. boundary rounds: every block whose one-cell ring holds an optimum that changed in the previous stage is
   re-relaxed from that ring, read from the previous stage's state only (``continuation.relax_box``); the
   improvements of all blocks are applied together at the round's end (a Jacobi step over blocks), and the
   rounds repeat until no cell changes (``max_rounds`` at most).

The parent holds the state: per cell the posture (3 float64), the search's objective (float64) and the reason
(int8), written in place in grid order, 33 bytes a cell at most (:class:`SweepState`). The tasks' arguments are
made as they are handed out.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field

import numpy as np

from jethr1_plan.balance_space.continuation import BlockResult, relax_box, search_block
from jethr1_plan.balance_space.spec import SearchSettings, SweepSpec
from jethr1_plan.reasons import Reason

__all__ = ["Block", "SweepState", "TaskTimes", "makespan", "partition", "run_blocks"]


@dataclass(frozen=True)
class Block:
    """One block: the whole x axis, the y and z index ranges ``y``, ``z`` (stop exclusive)."""

    y: tuple[int, int]
    z: tuple[int, int]

    @property
    def box(self) -> tuple[slice, slice, slice]:
        return slice(None), slice(*self.y), slice(*self.z)

    def ring(self, shape: tuple[int, int, int]) -> tuple[tuple[slice, slice, slice], np.ndarray]:
        """The block with a one-cell ring in y and z (within the grid; x is whole already), and which of the
        box's cells (x-major) are the block's."""
        ylo, yhi = max(self.y[0] - 1, 0), min(self.y[1] + 1, shape[1])
        zlo, zhi = max(self.z[0] - 1, 0), min(self.z[1] + 1, shape[2])
        inner = np.zeros((shape[0], yhi - ylo, zhi - zlo), dtype=bool)
        inner[:, self.y[0] - ylo:self.y[1] - ylo, self.z[0] - zlo:self.z[1] - zlo] = True
        return (slice(None), slice(ylo, yhi), slice(zlo, zhi)), inner.ravel()


def partition(shape: tuple[int, int, int], settings: SearchSettings, mirror: bool) -> list[Block]:
    """The grid of ``shape`` (x, y, z cells) cut into blocks; ``mirror`` (a left support): the y blocks counted
    from the far end."""
    ny, nz = shape[1], shape[2]
    by, bz = settings.block_y_cells, settings.block_z_layers
    ys = [(j, min(j + by, ny)) for j in range(0, ny, by)]
    if mirror:
        ys = [(ny - hi, ny - lo) for lo, hi in reversed(ys)]
    return [Block(y, (k, min(k + bz, nz))) for y in ys for k in range(0, nz, bz)]


def flat_indices(shape: tuple[int, int, int], box: tuple[slice, slice, slice]) -> np.ndarray:
    """The x-major flat indices of the cells of ``box``, in the box's own x-major order."""
    ranges = [np.arange(n)[s] for n, s in zip(shape, box, strict=True)]
    return np.ravel_multi_index(np.meshgrid(*ranges, indexing="ij"), shape).ravel()


_NAN_BITS = np.uint64(0x7FF8_0000_0000_0000)  # the bits of a posture's start, numpy's NaN (no posture)
_INF_BITS = np.uint64(0x7FF0_0000_0000_0000)  # the bits of an objective's start, +inf (no search)


def _encoded(values: np.ndarray, start: np.uint64) -> np.ndarray:
    """float64 ``values``' bits XOR ``start``'s: zero where a value is still the start value (exact both ways)."""
    return np.ascontiguousarray(values, dtype=np.float64).view(np.uint64) ^ start


class SweepState:
    """Per cell of the grid: the best posture [m] (NaN: none), the search's objective (the least thrust [N] for a
    member; inf where no search ran) and the reason (UNREACHABLE where no task said otherwise); written in place
    as tasks answer.

    Stored XOR their start values, so that a cell no task changed is zero bytes and a page of cells none changed
    (most of the grid is out of reach or beyond the hip yaw's limits) is never written, and holds no memory
    (33 bytes a cell at most; about 18 of them written at 1 cm: numpy's zeros are pages the system maps only when
    written)."""

    def __init__(self, shape: tuple[int, int, int]):
        n = int(np.prod(shape))
        self.shape = shape
        self._p, self._f, self._r = np.zeros((n, 3), np.uint64), np.zeros(n, np.uint64), np.zeros(n, np.int8)

    def p_body_at(self, cells: np.ndarray) -> np.ndarray:
        """The postures [m] of ``cells`` (flat indices), (k, 3)."""
        return (self._p[cells] ^ _NAN_BITS).view(np.float64)

    def objective_at(self, cells: np.ndarray) -> np.ndarray:
        """The objectives of ``cells`` (flat indices)."""
        return (self._f[cells] ^ _INF_BITS).view(np.float64)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every cell's posture (N, 3) [m], objective (N,) and reason (N,) int8, as new arrays."""
        return ((self._p ^ _NAN_BITS).view(np.float64), (self._f ^ _INF_BITS).view(np.float64),
                self._r ^ np.int8(Reason.UNREACHABLE))

    def put(self, r: BlockResult, first: bool = False) -> None:
        """A task's answer written in; every member in it was re-checked by PlaCo in the task. ``first``: no task
        wrote these cells before (the first pass: its blocks do not overlap), so values equal to the start values
        need not be written."""
        if r.checked != int(np.count_nonzero(r.reason == Reason.OK)):
            raise AssertionError(f"a task re-checked {r.checked} of its {np.count_nonzero(r.reason == Reason.OK)} "
                                 "members")
        p = _encoded(r.p_body, _NAN_BITS)
        f = _encoded(r.objective, _INF_BITS)
        q = np.asarray(r.reason, dtype=np.int8) ^ np.int8(Reason.UNREACHABLE)
        if not first:
            self._p[r.cells], self._f[r.cells], self._r[r.cells] = p, f, q
            return
        rows = p.any(axis=1)
        self._p[r.cells[rows]] = p[rows]
        self._f[r.cells[f != 0]] = f[f != 0]
        self._r[r.cells[q != 0]] = q[q != 0]


@dataclass
class TaskTimes:
    """The CPU time [s] of every task of every stage (pass 1, then each round), in the order they were defined."""

    stages: list[list[float]] = field(default_factory=list)
    improved: list[int] = field(default_factory=list)  # cells improved by each round

    @property
    def critical_path_s(self) -> float:
        """With unlimited workers: the longest task of each stage, summed."""
        return float(sum(max(s, default=0.0) for s in self.stages))

    @property
    def total_s(self) -> float:
        return float(sum(sum(s) for s in self.stages))


def makespan(times: TaskTimes, workers: int) -> float:
    """The wall time [s] of the stages on ``workers`` workers, each stage scheduled greedily in task order (each
    task to the first worker free, as a scheduler does) and waited for before the next."""
    total = 0.0
    for stage in times.stages:
        free = np.zeros(workers)
        for t in stage:
            k = int(np.argmin(free))
            free[k] += t
        total += float(free.max(initial=0.0))
    return total


Runner = Callable[[Iterable[tuple]], Iterable[BlockResult]]


def _pass1(task: int, spec: SweepSpec, settings: SearchSettings, box, flat) -> BlockResult:
    r = search_block(spec, settings, box, flat)
    r.task = task
    return r


def _round(task: int, spec: SweepSpec, settings: SearchSettings, box, inner, flat, P_box, f_box,
           changed) -> BlockResult:
    r = relax_box(spec, settings, box, inner, flat, P_box, f_box, changed)
    r.task = task
    return r


def run_blocks(spec: SweepSpec, settings: SearchSettings, run: Runner,
               progress: Callable[[str, int, int], None] | None = None,
               state: SweepState | None = None) -> tuple[SweepState, TaskTimes, int]:
    """The sweep's stages over the blocks, each through ``run`` ((function, args) tasks → their answers, in
    any order), into ``state`` (a new one by default: as it starts). Returns the state, the tasks' times and the
    evaluations."""
    shape = tuple(len(a) for a in spec.axes())
    assert len(shape) == 3
    nx, ny, nz = shape
    state = state or SweepState((nx, ny, nz))
    blocks = partition((nx, ny, nz), settings, spec.support_side == "left")
    times = TaskTimes()
    evaluations = 0
    tasks = ((_pass1, (k, spec, settings, b.box, flat_indices(state.shape, b.box))) for k, b in enumerate(blocks))
    stage = [0.0] * len(blocks)
    for k, r in enumerate(run(tasks)):
        state.put(r, first=True)
        stage[r.task] = r.cpu_s
        evaluations += r.evaluations
        if progress:
            progress(f"blocks ({len(blocks)})", k + 1, len(blocks))
    times.stages.append(stage)
    if spec.method == "exhaustive":
        return state, times, evaluations
    changed = np.ones(int(np.prod(state.shape)), dtype=bool)
    for rnd in range(settings.max_rounds):
        due = [b for b in blocks if _due(b, state, changed)]
        if not due:
            break
        # tasks made as workers take them (only those in flight hold a copy of their box); the answers are
        # applied together once all are in: every task reads the previous stage's state
        answers = list(run(_round_tasks(spec, settings, due, state, changed)))
        changed[:] = False
        stage, improved = [0.0] * len(due), 0
        for r in answers:
            state.put(r)
            changed[r.cells] = True
            stage[r.task] = r.cpu_s
            evaluations += r.evaluations
            improved += len(r.cells)
        times.stages.append(stage)
        times.improved.append(improved)
        if progress:
            progress(f"boundary round {rnd + 1}: {improved} cells improved", rnd + 1, settings.max_rounds)
        if not improved:
            break
    return state, times, evaluations


def _due(block: Block, state: SweepState, changed: np.ndarray) -> bool:
    """Whether a block has cells to search and its ring an optimum that changed (one that may be offered)."""
    box, inner = block.ring(state.shape)
    flat = flat_indices(state.shape, box)
    objective = state.objective_at(flat)
    return bool(np.any(changed[flat] & ~inner & (objective < 2000)) and np.isfinite(objective[inner]).any())


def _round_tasks(spec, settings, blocks: list[Block], state: SweepState, changed: np.ndarray) -> Iterator[tuple]:
    for k, b in enumerate(blocks):
        box, inner = b.ring(state.shape)
        flat = flat_indices(state.shape, box)
        yield _round, (k, spec, settings, box, inner, flat, state.p_body_at(flat), state.objective_at(flat),
                       changed[flat])
