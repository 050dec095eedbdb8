"""The compass (pattern) search over P_body, compiled: one cell per row, each row run to its end in one loop.

The balance-space sweep's every search (seeds, neighbours, relaxation, polish) and ``compare``'s reference
use it; its objective is ``physics.compiled.objective`` (the evaluator's), its projection
``physics.compiled.reach``.
"""

from __future__ import annotations

import math

import numpy as np

from jethr1_plan.optimisers.search import Cells, Evaluator
from jethr1_plan.physics.compiled.jit import kernel
from jethr1_plan.physics.compiled.objective import objective_into, objective_scratch
from jethr1_plan.physics.compiled.reach import into_reach_one
from jethr1_plan.reasons import Reason

__all__ = ["POLL_CHUNK", "compass_search"]

_OK, _THRUST_MAX = int(Reason.OK), int(Reason.THRUST_MAX)  # compile-time constants
POLL_CHUNK = 3  # compass: directions evaluated together (independent candidates overlap in the CPU; the first
#                 improving chunk wins: 1.3x fewer evaluations than complete polls, same members; bench_balance_space)


def compass_search(ev: Evaluator, c: Cells, idx: np.ndarray, P: np.ndarray, f: np.ndarray, step0: np.ndarray,
                   min_step: float, max_iter: int = 60, give_up_after: int = 10, coarse_until: float = 0.002,
                   axis_dirs: np.ndarray | None = None, fine_dirs: np.ndarray | None = None,
                   chunk: int = POLL_CHUNK, levels: tuple[int, int] | None = None):
    """Compass (pattern) search from P (B, 3) [m] with objective f (B,), one cell per row; returns the
    new (P, f).

    Polls ``axis_dirs`` (default the evaluator's: the 6 axes, mirrored for a left support) while the step is
    at least ``coarse_until`` [m], then ``fine_dirs`` (default the 6 axes and 8 cube corners, so the search can
    slide along a constraint's edge). A poll is opportunistic: directions are tried ``chunk`` at a time, starting
    from the last move's, and the search moves to the best of the first chunk that improves; when none
    does, the step halves (``chunk`` ≥ the number of directions: a complete poll, the best of all).
    Every poll point is moved into the reach balls and joint limits first (:meth:`Evaluator.into_reach`,
    ``levels``: the level of the axis stage, then of the fine stage; default the evaluator's).
    A row stops when its step falls below ``min_step`` [m], when it reaches zero thrust, or, after
    ``give_up_after`` polls of a stage, when it has still found no kinematically valid posture. A row
    that ends on an invalid posture (a penalty a hair above zero) gets the best valid posture it met,
    if any. Compiled: each row runs to its end in one loop (:func:`_compass_rows`).
    """
    P = np.array(P, dtype=float, order="C")
    f = np.array(f, dtype=float)
    counts = np.zeros(len(idx), dtype=np.int64)
    _compass_rows(P, f, np.ascontiguousarray(step0, dtype=float), counts, np.ascontiguousarray(idx, dtype=np.int64),
                  coarse_until, float(min_step), max_iter, give_up_after, int(chunk),
                  ev.axis_dirs if axis_dirs is None else axis_dirs, ev.fine_dirs if fine_dirs is None else fine_dirs,
                  c.centre_w, c.centre_s, ev.search_radius, ev.shapes,
                  *((ev.level, ev.level) if levels is None else levels), c.swing, c.yaw_cs, c.fan, *ev.params)
    ev.evaluations += int(counts.sum())
    return P, f


@kernel
def _compass_rows(P, f, step0, counts, idx, coarse_until, min_step, max_iter, give_up_after, chunk, axis_dirs,
                  fine_dirs, centre_w, centre_s, radius, shapes, level0, level1, swing, yaw_cs, fan, geom, trunk,
                  joints, links, limits, normals, offsets, support, scalars, fans, arcs):
    """:func:`compass_search`'s loop, in place on P and f; ``counts`` (B,) gets each row's evaluations."""
    kmax = max(len(axis_dirs), len(fine_dirs))
    cand, rows = np.empty((kmax, 3)), np.empty(kmax, dtype=np.int64)
    obj, thrust, reason = np.empty(kmax), np.empty(kmax), np.empty(kmax, dtype=np.int8)
    q, cs, fxs, fys, fmax, split = objective_scratch(fans, scalars[2])
    for b in range(len(idx)):
        c = idx[b]
        rows[:] = c
        p0, p1, p2, fb, st = P[b, 0], P[b, 1], P[b, 2], f[b], step0[b]
        k0, k1, k2, f_ok = np.nan, np.nan, np.nan, np.inf  # best valid posture met
        last = 0  # the direction of the last move: polled first
        for stage in range(2):
            dirs = axis_dirs if stage == 0 else fine_dirs
            level = level0 if stage == 0 else level1
            floor = coarse_until if stage == 0 else min_step
            k = len(dirs)
            if stage == 1:  # the fine direction nearest the last move's
                d0, d1, d2 = axis_dirs[last, 0], axis_dirs[last, 1], axis_dirs[last, 2]
                best_dot = -np.inf
                for j in range(k):
                    dot = dirs[j, 0] * d0 + dirs[j, 1] * d1 + dirs[j, 2] * d2
                    if dot > best_dot:
                        best_dot, last = dot, j
            for it in range(max_iter):
                if st < floor or fb <= 0.0 or (it >= give_up_after and fb >= 2000.0):
                    break
                moved = False
                for t0 in range(0, k, chunk):  # a few directions at a time, the last move's first
                    m = min(chunk, k - t0)
                    for t in range(m):
                        j = (last + t0 + t) % k
                        cand[t, 0], cand[t, 1], cand[t, 2] = into_reach_one(
                            p0 + st * dirs[j, 0], p1 + st * dirs[j, 1], p2 + st * dirs[j, 2], c, centre_w, centre_s,
                            radius, shapes, level)
                    objective_into(cand[:m], rows[:m], swing, yaw_cs, fan, geom, trunk, joints, links, limits, normals,
                                   offsets, support, scalars, fans, arcs, obj, thrust, reason, q, cs, fxs, fys, fmax,
                                   split)
                    counts[b] += m
                    jb = 0
                    for t in range(m):
                        if (reason[t] == _OK or reason[t] == _THRUST_MAX) and obj[t] < f_ok:
                            f_ok, k0, k1, k2 = obj[t], cand[t, 0], cand[t, 1], cand[t, 2]
                        if obj[t] < obj[jb]:
                            jb = t
                    if obj[jb] < fb - 1e-12:
                        p0, p1, p2, fb = cand[jb, 0], cand[jb, 1], cand[jb, 2], obj[jb]
                        last, moved = (last + t0 + jb) % k, True
                        break
                if not moved:
                    st *= 0.5
        # the penalties are exact, but a search that ends a hair outside a constraint falls back on the
        # best valid posture it met
        cand[0, 0], cand[0, 1], cand[0, 2] = p0, p1, p2
        objective_into(cand[:1], rows[:1], swing, yaw_cs, fan, geom, trunk, joints, links, limits, normals, offsets,
                       support, scalars, fans, arcs, obj, thrust, reason, q, cs, fxs, fys, fmax, split)
        counts[b] += 1
        if reason[0] != _OK and reason[0] != _THRUST_MAX and math.isfinite(f_ok):
            p0, p1, p2, fb = k0, k1, k2, f_ok
        P[b, 0], P[b, 1], P[b, 2], f[b] = p0, p1, p2, fb


