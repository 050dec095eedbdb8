"""The continuation sweep held to its references: the exhaustive search on sampled cells (random ones and the
cells where the two are most likely to disagree), and the mirror image (a left support's space against a right
support's, every cell).

Criterion (issue 28): a cell agrees when both searches put it in the space with thrust or both out, and where
both put it in, their least thrusts are within :data:`AGREE_N`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jethr1_plan.balance_space.spec import SweepSpec
from jethr1_plan.optimisers.exhaustive import exhaustive_cell
from jethr1_plan.optimisers.search import Evaluator
from jethr1_plan.reasons import Reason

__all__ = ["AGREE_N", "REFERENCE_GRID_M", "MirrorReport", "agree", "exhaustive_cells", "mirror_report",
           "suspect_cells"]

AGREE_N = 0.1  # thrusts within this [N] agree
REFERENCE_GRID_M = 0.005  # the exhaustive reference's P_body grid (finer than its default 1 cm, which misses members)
SUSPECT_CAP_N = 5.0  # above the fan's maximum, thrusts count as this much above it when ranking suspects


def agree(thrust_a: np.ndarray, reason_a: np.ndarray, thrust_b: np.ndarray, reason_b: np.ndarray) -> np.ndarray:
    """Per cell: the same membership of the space with thrust, and where both are members, thrusts [N] within
    :data:`AGREE_N`."""
    ma, mb = reason_a == Reason.OK, reason_b == Reason.OK
    both = ma & mb
    gap = np.where(both, np.abs(np.where(both, thrust_a, 0.0) - np.where(both, thrust_b, 0.0)), 0.0)
    return (ma == mb) & (gap <= AGREE_N)


def searchable(spec: SweepSpec, swing: np.ndarray, reason: np.ndarray) -> np.ndarray:
    """The cells a search visits: not over the support sole, and reachable by both legs."""
    ev = Evaluator(spec.model, spec.support_stance())
    return (reason != Reason.OVERLAP) & ev.reach_possible(ev.cells(swing))


def suspect_cells(spec: SweepSpec, thrust: np.ndarray, reason: np.ndarray, n: int) -> np.ndarray:
    """The ``n`` cells of a sweep (flat, x-major over ``spec.axes()``) where the continuation search most likely
    misses the exhaustive search's answer: half ranked by how far a cell's least thrust [N] lies above the lowest of
    its six neighbours' (a basin the search missed shows as a bump; a cell outside the space beside a member far
    below the fan's maximum ranks high: thrusts above the maximum count as at most SUSPECT_CAP_N above it), half
    by how close its least thrust is to the fan's maximum (where membership turns on a few millinewtons)."""
    shape = tuple(len(a) for a in spec.axes())
    fmax = spec.fan_limit_n
    g = np.minimum(thrust, fmax + SUSPECT_CAP_N).reshape(shape)
    lowest = np.full(shape, np.inf)
    for axis in range(3):
        for d in (1, -1):
            moved = np.full(shape, np.inf)
            src = [slice(None)] * 3
            dst = [slice(None)] * 3
            src[axis], dst[axis] = (slice(None, -1), slice(1, None)) if d > 0 else (slice(1, None), slice(None, -1))
            moved[tuple(dst)] = g[tuple(src)]
            lowest = np.minimum(lowest, moved)
    bump = (g - lowest).ravel()
    bump[~np.isfinite(bump)] = -np.inf
    edge = -np.abs(thrust - fmax)
    edge[~np.isfinite(edge)] = -np.inf
    picked: list[int] = []
    for score, k in ((bump, n - n // 2), (edge, n // 2)):
        order = np.argsort(-score, kind="stable")
        order = order[np.isfinite(score[order])]
        order = order[~np.isin(order, picked)]
        picked.extend(int(i) for i in order[:k])
    return np.array(picked, dtype=np.int64)


def _exhaustive_part(spec: SweepSpec, swing: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    ev = Evaluator(spec.model, spec.support_stance())
    cells = ev.cells(swing)
    out = [exhaustive_cell(ev, cells, i, REFERENCE_GRID_M)[1:] for i in range(len(swing))]
    return np.array([o[0] for o in out], dtype=float), np.array([o[1] for o in out], dtype=np.int8)


def exhaustive_cells(spec: SweepSpec, swing: np.ndarray, jobs: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """The exhaustive search's (least thrust [N], reason) at swing soles ``swing`` (k, 3) [m], on ``jobs``
    processes (the same answers on any number)."""
    if jobs == 1 or len(swing) < 2:
        return _exhaustive_part(spec, swing)
    from joblib import Parallel, delayed

    parts = Parallel(n_jobs=jobs)(delayed(_exhaustive_part)(spec, swing[k::jobs]) for k in range(jobs))
    thrust, reason = np.empty(len(swing)), np.empty(len(swing), dtype=np.int8)
    for k, (t, r) in enumerate(parts):
        thrust[k::jobs], reason[k::jobs] = t, r
    return thrust, reason


@dataclass(frozen=True)
class MirrorReport:
    """A left support's sweep against a right support's at the mirror image (y → −y), over every cell."""

    cells: int
    membership_differs: int  # cells in one space with thrust and not in the other
    beyond_n: int  # cells in both whose least thrusts differ by more than AGREE_N
    worst_n: float  # the largest thrust difference [N] of cells in both
    bitwise: int  # cells whose thrust, reason and mirrored posture are the same to the bit


def mirror_report(right: SweepSpec, thrust_r: np.ndarray, reason_r: np.ndarray, p_body_r: np.ndarray,
                  left: SweepSpec, thrust_l: np.ndarray, reason_l: np.ndarray, p_body_l: np.ndarray) -> MirrorReport:
    """Compare every cell of a right support's sweep with the cell at its mirror image in a left support's (the
    left's grid must be the right's mirrored: its y axis the negated right's, reversed)."""
    ar, al = right.axes(), left.axes()
    if not (np.array_equal(ar[0], al[0]) and np.array_equal(ar[2], al[2]) and np.array_equal(ar[1], -al[1][::-1])
            and right.support[1] == -left.support[1] and right.support_side != left.support_side):
        raise ValueError("the left sweep's grid and support are not the mirror image of the right's")
    shape = tuple(len(a) for a in ar)

    def mirrored(a: np.ndarray) -> np.ndarray:
        return a.reshape(*shape, *a.shape[1:])[:, ::-1].reshape(a.shape)

    tl, rl, pl = mirrored(thrust_l), mirrored(reason_l), mirrored(p_body_l) * np.array([1.0, -1.0, 1.0])
    mr, ml = reason_r == Reason.OK, rl == Reason.OK
    both = mr & ml
    gap = np.abs(thrust_r[both] - tl[both])
    same = ((thrust_r == tl) | (np.isnan(thrust_r) & np.isnan(tl))) & (reason_r == rl) & np.all(
        (p_body_r == pl) | (np.isnan(p_body_r) & np.isnan(pl)), axis=1)
    return MirrorReport(cells=len(thrust_r), membership_differs=int(np.count_nonzero(mr != ml)),
                        beyond_n=int(np.count_nonzero(gap > AGREE_N)), worst_n=float(gap.max(initial=0.0)),
                        bitwise=int(np.count_nonzero(same)))
