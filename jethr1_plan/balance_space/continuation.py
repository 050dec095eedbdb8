"""The continuation search over one block of cells (``balance_space.blocks``): a block's first pass, and its
re-relaxation from a ring of its neighbours' cells in the boundary rounds.

First pass (:func:`search_block`): cells are visited in slices along x, each seeded with the best P_body of
its neighbour in the previous slice, and on every SEED_EVERY-th slice (or where the neighbour has no valid
posture) with the best of generic postures; a compass (pattern) search then shrinks its
step from 32 mm (seeds) or 4 mm (neighbours) to 0.5 mm, polling a few directions at a time, the last move's
first (``optimisers.compass``); Gauss–Seidel relaxation sweeps along x, y and z carry better optima between
neighbours (a neighbour's optimum, shifted by half the cell offset and moved into every joint limit, is
searched from); last, the cells that are members or nearly, with the swing sole 0.15 m or more above the
support, are polished by a compass polling all 26 directions with the pitch limits in the projection too, and
the cells up to EDGE_ABOVE_N above the fan's maximum (whose membership turns on millinewtons) by one whose step
falls to EDGE_MIN_STEP_M.

Boundary rounds (:func:`relax_box`): the block's cells are offered the optima of a one-cell ring around it
that changed in the previous round (read from that round's state only), relaxed as in the first pass, and
the cells that improved are polished.

Work no search can use is skipped, with the same output: cells at zero thrust (nothing is lower), cells whose
body yaw puts a hip yaw beyond its limits (no posture is valid: ``Evaluator.hip_yaw_allowed``), and the
forward pass's offers again (the relaxation's first +x sweep would search the same cells from the same
starts).

Mirror-exact: for a left support every ordered choice is the mirror of a right support's (the evaluator's
poll directions, seeds and grids, :attr:`~jethr1_plan.optimisers.search.Evaluator.flip`; the relaxation
sweeps y in the mirrored order; the blocks are mirrored), so the space is the mirror image to the bit.
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass

import numpy as np

from jethr1_plan.balance_space.recheck import check_members
from jethr1_plan.balance_space.spec import SearchSettings, SweepSpec
from jethr1_plan.optimisers.compass import compass_search
from jethr1_plan.optimisers.exhaustive import exhaustive_cell
from jethr1_plan.optimisers.search import Cells, Evaluator, generic_seeds, lens_seeds
from jethr1_plan.reasons import Reason, balances, has_posture

__all__ = ["BlockResult", "box_swing", "evaluator", "relax_box", "search_block"]

SEED_EVERY = 4  # generic seeds searched from on every 4th x slice
RELAX_PASSES = 3  # rounds of the relaxation's directional sweeps at most
RELAX_SLACK_N = 0.05  # a neighbour's optimum is searched from when it scores below this above the cell's
#                       (0.15 before: 1.09x the evaluations for the same agreement with exhaustive)
RELAX_GAIN_N = 1e-3  # ... and replaces it when the search ends at least this much lower (a smaller gain re-offers
#                      the cell's optimum to its neighbours for nothing)
JOIN_GRID_M = 0.001  # the grid around a member neighbour's optimum offered to a cell that is not
SEED_STEP_M = 0.032  # the compass's first step from a generic seed
NEIGHBOUR_STEP_M = 0.004  # ... from a neighbour's optimum
POLISH_ABOVE_N = 1.0  # cells up to this above the fan's maximum get the final polish
POLISH_STEP_M = 0.004  # ... starting at this compass step
POLISH_FROM_M = 0.15  # ... with the swing sole at least this high above the support
EDGE_ABOVE_N = 0.02  # cells at most this above the fan's maximum (their membership turns on millinewtons) ...
EDGE_STEP_M = 0.001  # ... get a compass from this step ...
EDGE_MIN_STEP_M = 0.00001  # ... down to this one (0.05 mm left a cell at 23.0006 N that the exhaustive search, its
#                             finest grid 0.04 mm, puts at 22.99999 N; 0.01 mm reaches 22.9998 N)


@functools.lru_cache(maxsize=8)
def evaluator(spec: SweepSpec, level: int) -> Evaluator:
    """The evaluator of ``spec``'s support at projection ``level``, one per process (built in ~5 ms)."""
    return Evaluator(spec.model, spec.support_stance(), level)


def box_swing(spec: SweepSpec, box: tuple[slice, slice, slice]) -> np.ndarray:
    """The swing sole centres [m] of the grid's cells in ``box`` (slices of the x, y, z axes), x-major: (n, 3)."""
    axes = spec.axes()
    X, Y, Z = np.meshgrid(*(a[s] for a, s in zip(axes, box, strict=True)), indexing="ij")
    return np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)


def _shape(spec: SweepSpec, box: tuple[slice, slice, slice]) -> tuple[int, int, int]:
    nx, ny, nz = (len(a[s]) for a, s in zip(spec.axes(), box, strict=True))
    return nx, ny, nz


@dataclass
class BlockResult:
    """A task's answer: per cell of its block (first pass) or per improved cell (a round), in its order."""

    cells: np.ndarray  # (k,) flat indices into the whole grid (x-major)
    p_body: np.ndarray  # (k, 3) best posture [m] (NaN where none is kinematically valid)
    objective: np.ndarray  # (k,) the search's objective there (the least thrust [N] for a member; inf: not searched)
    reason: np.ndarray  # (k,) reason codes (int8)
    checked: int  # members re-checked by PlaCo (recheck.check_members)
    evaluations: int
    cpu_s: float  # the task's CPU time [s] (one process)
    task: int = -1  # its place in its stage's task list (blocks.run_blocks)


class _Search:
    """The continuation search over the cells of one box of the grid (swing, x-major, ``shape``)."""

    def __init__(self, spec: SweepSpec, settings: SearchSettings, swing: np.ndarray, shape: tuple[int, int, int]):
        self.spec, self.settings, self.shape = spec, settings, shape
        self.ev = evaluator(spec, settings.search_level)
        self.evaluations0 = self.ev.evaluations
        self.c: Cells = self.ev.cells(swing)
        self.grid = np.arange(len(swing)).reshape(shape)
        m = int(self.ev.mirror)
        # Gauss-Seidel sweeps along -x, +y, -y, +x, +z, -z (y mirrored for a left support)
        self.directions = ((0, -1), (1, m), (1, -m), (0, 1)) + (((2, 1), (2, -1)) if shape[2] > 1 else ())

    @property
    def evaluations(self) -> int:
        return self.ev.evaluations - self.evaluations0

    def compass(self, idx, P, f, step, **kw):
        return compass_search(self.ev, self.c, idx, P, f, np.full(len(idx), step), self.spec.min_step_m,
                              chunk=self.settings.poll_chunk, **kw)

    def shifted(self, src: np.ndarray, dst: np.ndarray, P_all: np.ndarray) -> np.ndarray:
        """The optima of cells ``src`` offered to their neighbours ``dst``: shifted by half the cell offset and
        moved into every joint limit (a neighbour's optimum often sits on a hip or ankle pitch limit: moved into
        the roll and knee limits only it scores a penalty, though a search from it reaches the optimum)."""
        return self.ev.into_reach(self.c, dst, P_all[src] + (self.c.swing[dst] - self.c.swing[src]) / 2,
                                  self.settings.offer_level)

    def best_nearby(self, idx: np.ndarray, P0: np.ndarray, f0: np.ndarray):
        """Per row the best of P0 (B, 3) [m] (objective f0) and the JOIN_GRID_M grid of 5 × 5 × 5 points around it.

        Where a neighbour is a member and the cell is not, the cell's balanced postures can form a sliver a
        few millimetres wide next to the neighbour's optimum, with the penalty of the postures around it
        (no balance: the CoM's distance to the sole's centre) pointing elsewhere; the compass then
        descends that penalty and misses the sliver.
        """
        ev, c = self.ev, self.c
        offsets = ev.offsets(JOIN_GRID_M, 2)
        k = len(offsets)
        rows = np.repeat(idx, k)
        cand = ev.into_reach(c, rows, (P0[:, None, :] + offsets[None]).reshape(-1, 3))
        obj = ev(c, rows, cand)[0].reshape(len(idx), k)
        j = np.argmin(obj, axis=1)
        best = obj[np.arange(len(idx)), j]
        take = best < f0
        P, f = P0.copy(), f0.copy()
        P[take], f[take] = cand.reshape(len(idx), k, 3)[take, j[take]], best[take]
        return P, f

    def forward(self, todo: np.ndarray, P_all: np.ndarray, f_all: np.ndarray) -> np.ndarray:
        """The forward pass along +x, in place on P_all, f_all: every cell starts from its -x neighbour's
        optimum (:meth:`shifted`); cells without one, and every SEED_EVERY-th slice, also from the best
        generic seed (new basins enter there: the relaxation carries them on). Returns the cells whose optimum
        served as a start (the +x relaxation would repeat those searches while it stays the same)."""
        ev, c = self.ev, self.c
        started = np.zeros(len(f_all), dtype=bool)
        for ix in range(self.shape[0]):
            sl = self.grid[ix].ravel()
            idx = sl[todo[sl]]
            if not len(idx):
                continue
            P = np.full((len(idx), 3), np.nan)
            f = np.full(len(idx), np.inf)
            if ix > 0:
                nb = self.grid[ix - 1].ravel()[todo[sl]]
                has = np.isfinite(f_all[nb]) & (f_all[nb] < 2000)
                if has.any():
                    P0 = self.shifted(nb[has], idx[has], P_all)
                    f0, _, _ = ev(c, idx[has], P0)
                    P[has], f[has] = self.compass(idx[has], P0, f0, NEIGHBOUR_STEP_M)
                    started[nb[has]] = True
            # generic seeds on every SEED_EVERY-th slice and where the neighbour gave no valid posture, but not
            # at zero thrust: the compass searches from the best (scoring them on every cell, to search from them
            # where they beat the neighbour's optimum, cost 6 % of the evaluations and changed nothing measured)
            fresh = ~np.isfinite(f) | (f >= 2000) | (ix % SEED_EVERY == 0)
            if self.settings.skip_zero:
                fresh &= f > 0.0
            if fresh.any():
                rows_o = idx[fresh]
                seeds = np.concatenate([generic_seeds(ev, c, rows_o), lens_seeds(ev, c, rows_o)], axis=1)
                b, k = seeds.shape[:2]
                rows_k = np.repeat(rows_o, k)
                seeds = ev.into_reach(c, rows_k, seeds.reshape(-1, 3)).reshape(b, k, 3)
                obj = ev(c, rows_k, seeds.reshape(-1, 3))[0].reshape(b, k)
                j = np.argmin(obj, axis=1)
                P2, f2 = self.compass(rows_o, seeds[np.arange(b), j], obj[np.arange(b), j], SEED_STEP_M)
                better = f2 < f[fresh]
                rows = np.flatnonzero(fresh)[better]
                P[rows], f[rows] = P2[better], f2[better]
            P_all[idx], f_all[idx] = P, f
        return started

    def relax_slice(self, todo, P_all, f_all, src, dst, offered, forward) -> np.ndarray:
        """Cells ``dst`` try their neighbours' (``src``, one cell away) optima; P_all, f_all updated in
        place. Returns the cells that improved.

        A neighbour's optimum is carried over (:meth:`shifted`) and searched from only where it already scores
        within RELAX_SLACK_N of the cell's own, where it is a member and the cell is not, or where it only
        breaks the edge angle (whose penalty, 50 N per degree, says little about how close a valid posture
        is): thrust varies by up to ~1 N between neighbouring cells, so comparing the two cells' optima would
        retry nearly every cell. The search's result replaces the cell's optimum when it is at least
        RELAX_GAIN_N lower.

        ``offered`` (cells,) marks the cells whose present optimum was already offered in this direction:
        offering it again repeats the same search from the same start, which cannot beat the cell's optimum
        (it only falls). ``forward`` (the +x direction only): the optima the forward pass started from, whose
        offers it made already, but for a member's to a cell that is not (whose sliver grid it did not search).
        """
        fmax = self.spec.fan_limit_n
        ok = todo[dst] & np.isfinite(f_all[src]) & (f_all[src] < 2000)
        if self.settings.skip_zero:
            ok &= f_all[dst] > 0.0
        joins_all = (f_all[dst] > fmax) & (f_all[src] <= fmax)  # a member's optimum offered to a cell that is not
        if self.settings.offer_once:
            fresh = ~offered[src]
            if forward is not None:
                fresh &= ~forward[src] | joins_all
            ok &= fresh
        offered[src] = True
        if forward is not None:
            forward[src] = False
        none = np.zeros(0, dtype=np.int64)
        if not ok.any():
            return none
        s_idx, d_idx = src[ok], dst[ok]
        ev, c = self.ev, self.c
        P0 = self.shifted(s_idx, d_idx, P_all)
        f0, _, r0 = ev(c, d_idx, P0)
        joins = joins_all[ok]
        go = (f0 < f_all[d_idx] + RELAX_SLACK_N) | joins | ((r0 == Reason.EDGE_ANGLE) & (f_all[d_idx] > 0))
        if not go.any():
            return none
        if joins.any():  # the cell's feasible set may be a sliver next to that optimum: a small grid finds it
            P0[joins], f0[joins] = self.best_nearby(d_idx[joins], P0[joins], f0[joins])
        d_idx, P0, f0 = d_idx[go], P0[go], f0[go]
        P2, f2 = self.compass(d_idx, P0, f0, NEIGHBOUR_STEP_M)
        better = f2 < f_all[d_idx] - RELAX_GAIN_N
        P_all[d_idx[better]], f_all[d_idx[better]] = P2[better], f2[better]
        return d_idx[better]

    def relax(self, todo, P_all, f_all, offered: np.ndarray, forward: np.ndarray | None = None) -> None:
        """Gauss-Seidel sweeps along each of :attr:`directions`, slice by slice, so a better optimum found
        anywhere can travel across the whole box in one sweep; until no cell improves or RELAX_PASSES rounds
        are done. ``offered`` (directions, cells): see :meth:`relax_slice`; ``forward``: the forward pass's
        starts (the +x direction's)."""
        for _ in range(RELAX_PASSES):
            improved = 0
            for (axis, d), off in zip(self.directions, offered, strict=True):
                n = self.shape[axis]
                order = range(1, n) if d > 0 else range(n - 2, -1, -1)
                fwd = forward if (axis, d) == (0, 1) else None
                for k in order:
                    better = self.relax_slice(todo, P_all, f_all, np.take(self.grid, k - d, axis=axis).ravel(),
                                              np.take(self.grid, k, axis=axis).ravel(), off, fwd)
                    offered[:, better] = False  # a new optimum: offer it in every direction again
                    if forward is not None:
                        forward[better] = False
                    improved += len(better)
            if not improved:
                break

    def polish(self, cells: np.ndarray, P_all: np.ndarray, f_all: np.ndarray) -> None:
        """The cells that are members or nearly, polled in all 26 directions, moved into every joint limit (the
        optimum of most sits where a straight leg meets a joint limit, a ridge the 14 directions can miss)."""
        near = cells[(f_all[cells] <= self.spec.fan_limit_n + POLISH_ABOVE_N) & (f_all[cells] > 0)
                     & (self.c.swing[cells, 2] - self.ev.support[2] >= POLISH_FROM_M)]
        if len(near):
            lv = self.settings.polish_level
            P2, f2 = self.compass(near, P_all[near], f_all[near], POLISH_STEP_M, axis_dirs=self.ev.all_dirs,
                                  fine_dirs=self.ev.all_dirs, levels=(lv, lv))
            better = f2 < f_all[near] - 1e-9
            P_all[near[better]], f_all[near[better]] = P2[better], f2[better]
        fmax = self.spec.fan_limit_n
        edge = cells[(f_all[cells] > fmax) & (f_all[cells] <= fmax + EDGE_ABOVE_N)]
        if len(edge):
            lv = self.settings.polish_level
            P2, f2 = compass_search(self.ev, self.c, edge, P_all[edge], f_all[edge], np.full(len(edge), EDGE_STEP_M),
                                    EDGE_MIN_STEP_M, axis_dirs=self.ev.all_dirs, fine_dirs=self.ev.all_dirs,
                                    chunk=self.settings.poll_chunk, levels=(lv, lv))
            better = f2 < f_all[edge] - 1e-9
            P_all[edge[better]], f_all[edge[better]] = P2[better], f2[better]

    def finish(self, idx: np.ndarray, P_all: np.ndarray, f_all: np.ndarray):
        """The cells ``idx``'s answer: posture (NaN where none is valid), objective, reason; members re-checked
        by PlaCo. Returns (P, f, reason, checked)."""
        P = P_all[idx].copy()
        f = np.full(len(idx), np.inf)
        reason = np.full(len(idx), Reason.UNREACHABLE, dtype=np.int8)
        searched = np.isfinite(f_all[idx])
        if searched.any():
            f[searched], _, reason[searched] = self.ev(self.c, idx[searched], P[searched])
        P[~has_posture(reason)] = np.nan
        member = reason == Reason.OK
        checked = check_members(self.spec, self.c.swing[idx[member]], P[member], self.c.yaw[idx[member]])
        return P, f, reason, checked


def _unsearched(spec: SweepSpec, ev: Evaluator, c: Cells, swing: np.ndarray, settings: SearchSettings):
    """Reasons of the cells no search visits (OVERLAP, UNREACHABLE, JOINT_LIMIT by the hip yaw gate), and the
    cells to search."""
    robot = spec.model
    n = len(swing)
    reason = np.full(n, Reason.UNREACHABLE, dtype=np.int8)
    sup = ev.support
    overlap = (np.abs(swing[:, 0] - sup[0]) < robot.sole_length_m) & (np.abs(swing[:, 1] - sup[1]) < robot.sole_width_m)
    reason[overlap] = Reason.OVERLAP
    todo = ~overlap & ev.reach_possible(c)
    allowed = ev.hip_yaw_allowed(c) if settings.hip_yaw_gate else None
    if allowed is not None:
        reason[todo & ~allowed] = Reason.JOINT_LIMIT
        todo &= allowed
    return reason, todo


def search_block(spec: SweepSpec, settings: SearchSettings, box: tuple[slice, slice, slice],
                 flat: np.ndarray) -> BlockResult:
    """The first pass over the cells of ``box`` (slices of the x, y, z axes; ``flat``: their indices in the whole
    grid): the continuation search (``spec.method``; or the exhaustive one, cell by cell)."""
    t0 = time.process_time()
    swing = box_swing(spec, box)
    search = _Search(spec, settings, swing, _shape(spec, box))
    ev, c = search.ev, search.c
    n = len(swing)
    reason0, todo = _unsearched(spec, ev, c, swing, settings)
    P_all = np.full((n, 3), np.nan)
    f_all = np.full(n, np.inf)
    if spec.method == "exhaustive":
        for i in np.flatnonzero(todo):
            p, _, _ = exhaustive_cell(ev, c, i, spec.pbody_resolution_m)
            if np.all(np.isfinite(p)):
                P_all[i], f_all[i] = p, ev(c, np.array([i]), p[None])[0][0]
    elif todo.any():
        started = search.forward(todo, P_all, f_all)
        offered = np.zeros((len(search.directions), n), dtype=bool)
        search.relax(todo, P_all, f_all, offered, started if settings.forward_marks else None)
        search.polish(np.flatnonzero(todo), P_all, f_all)
    idx = np.flatnonzero(todo)
    P, f, reason, checked = search.finish(idx, P_all, f_all)
    out_P = np.full((n, 3), np.nan)
    out_f = np.full(n, np.inf)
    out_P[idx], out_f[idx], reason0[idx] = P, f, reason
    return BlockResult(flat, out_P, out_f, reason0, checked, search.evaluations, time.process_time() - t0)


def relax_box(spec: SweepSpec, settings: SearchSettings, box: tuple[slice, slice, slice], inner: np.ndarray,
              flat: np.ndarray, P_box: np.ndarray, f_box: np.ndarray, changed: np.ndarray) -> BlockResult:
    """A boundary round for one block: the cells of ``box`` (the block and a one-cell ring around it; ``inner``
    marks the block's, ``flat`` their indices in the whole grid) from the previous round's postures ``P_box``
    and objectives ``f_box``; the ring's optima that changed in that round (``changed``) are offered to the
    block's cells, the relaxation runs as in the first pass, and the cells that improved are polished.
    Returns the block's cells that improved."""
    t0 = time.process_time()
    search = _Search(spec, settings, box_swing(spec, box), _shape(spec, box))
    P_all, f_all = P_box.copy(), f_box.copy()
    todo = inner & np.isfinite(f_all)
    offered = np.tile(~(changed & ~inner), (len(search.directions), 1))
    search.relax(todo, P_all, f_all, offered)
    improved = np.flatnonzero(inner & (f_all < f_box))
    search.polish(improved, P_all, f_all)
    P, f, reason, checked = search.finish(improved, P_all, f_all)
    return BlockResult(flat[improved], P, f, reason, checked, search.evaluations, time.process_time() - t0)


def balanced_thrust(objective: np.ndarray, reason: np.ndarray) -> np.ndarray:
    """The least thrust [N] of every cell from the search's objective: the objective where the posture balances
    (a member, or one above the fan's maximum: no edge penalty there), inf elsewhere."""
    return np.where(balances(reason), objective, np.inf)
