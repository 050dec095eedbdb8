"""Paper A's exhaustive inner search over P_body for one cell: a grid over every pelvis position from which
both legs reach, refined around its best basins (the balance space's ``exhaustive`` method and the reference
every continuation search is measured against)."""

from __future__ import annotations

import numpy as np

from jethr1_plan.optimisers.search import INTO_JOINT_LIMITS, Cells, Evaluator, pelvis_box
from jethr1_plan.reasons import Reason, balances

__all__ = ["REFINE_BASINS", "ZOOM_STEPS_M", "exhaustive_cell"]

REFINE_BASINS = 6  # exhaustive: coarse basins refined on the 1 mm grid
ZOOM_STEPS_M = (2e-4, 4e-5)  # exhaustive: then grids of these steps (±5) around the best


def exhaustive_cell(ev: Evaluator, c: Cells, i: int, resolution_m: float, basins: int = REFINE_BASINS
                    ) -> tuple[np.ndarray, float, int]:
    """The paper's exhaustive inner search: a P_body grid, then a 1 mm grid (±2 coarse steps) around
    each of the ``basins`` best coarse points that lie at least 2.5 coarse steps apart (a thin
    feasible sliver can hold the optimum in a basin whose best coarse point is not the best), last
    grids of 0.2 and 0.04 mm (±5 steps) around the best valid point (ZOOM_STEPS_M: on a ridge the
    1 mm grid left up to 0.13 N).

    Grid points beyond a leg's reach or joint limits are moved onto its reach ball and into its limits
    (:meth:`Evaluator.into_reach`, INTO_JOINT_LIMITS): the optimum usually has a leg at full stretch,
    on the ball's surface, often against a joint limit, which a plain grid only approaches to within
    its spacing while the thrust changes like the square root of the distance there (without the
    reach ball, up to 0.8 N and whole members were missed on 300 sampled cells; with it but without
    the limits, on 1,000 cells 209 answers were higher, by up to 5.8 N).

    The answer is the best valid posture met (the penalties are exact, but a grid point a hair
    outside a constraint can score below every valid one); the best score where none is valid. Every grid is
    mirrored for a left support (:attr:`Evaluator.flip`): its answer is the mirror of a right support's."""
    grid = pelvis_box(ev, c, i, resolution_m)
    if not len(grid):
        return np.full(3, np.nan), np.inf, int(Reason.UNREACHABLE)
    grid = ev.into_reach(c, np.full(len(grid), i), grid, level=INTO_JOINT_LIMITS)
    scored = [ev(c, np.full(len(chunk), i), chunk) for chunk in (grid[s:s + 20000] for s in range(0, len(grid), 20000))]
    obj = np.concatenate([o for o, _, _ in scored])
    valid = np.where(balances(np.concatenate([rr for _, _, rr in scored])), obj, np.inf)
    r = resolution_m
    order = np.argsort(obj, kind="stable")
    centres: list[np.ndarray] = []
    for j in order:
        if centres and obj[j] >= 2000:  # only kinematically valid, balanced points beyond the first
            break
        if all(np.max(np.abs(grid[j] - q)) > 2.5 * r for q in centres):
            centres.append(grid[j])
            if len(centres) == basins:
                break
    best_p, best_f = centres[0], float(obj[order[0]])
    j = int(np.argmin(valid))
    best_valid_p, best_valid_f = grid[j], float(valid[j])
    fine = np.arange(-2 * r, 2 * r + 1e-12, 0.001)
    offsets = np.stack(np.meshgrid(fine, fine, fine, indexing="ij"), axis=-1).reshape(-1, 3) * ev.flip  # mirrored
    for q in centres:
        local = ev.into_reach(c, np.full(len(offsets), i), q + offsets, level=INTO_JOINT_LIMITS)
        o, _, rr = ev(c, np.full(len(local), i), local)
        j = int(np.argmin(o))
        if o[j] < best_f:
            best_f, best_p = float(o[j]), local[j]
        v = np.where(balances(rr), o, np.inf)
        j = int(np.argmin(v))
        if v[j] < best_valid_f:
            best_valid_f, best_valid_p = float(v[j]), local[j]
    # zoom: finer grids around the best valid point (a thin ridge of the feasible set can hold 0.1 N within
    # a millimetre)
    for zoom in (ev.offsets(step, 5) for step in ZOOM_STEPS_M) if np.isfinite(best_valid_f) else ():
        local = ev.into_reach(c, np.full(len(zoom), i), best_valid_p + zoom, level=INTO_JOINT_LIMITS)
        o, _, rr = ev(c, np.full(len(local), i), local)
        v = np.where(balances(rr), o, np.inf)
        j = int(np.argmin(v))
        if v[j] < best_valid_f:
            best_valid_f, best_valid_p = float(v[j]), local[j]
    if np.isfinite(best_valid_f):
        best_p = best_valid_p
    _, t, rr = ev(c, np.array([i]), best_p[None])
    return best_p, float(t[0]), int(rr[0])
