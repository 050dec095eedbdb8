"""Balance space (Paper A, IV-A, Fig. 5): where the swing sole can be held, with and without thrust.

The support sole is fixed; the swing sole (flat, facing +x) visits every cell of a grid. For each
cell the minimal thrust F* over P_body is found under all of Paper A's constraints: the legs reach
(IK), joint limits (A-8), 0 ≤ F ≤ F_max (A-9), the edge angle (A-10), the ZMP in the support sole
(A-11), with the body yaw of (A-4). The cell is in the space *with* thrust when F* ≤ F_max and in
the space *without* when F* = 0: one sweep gives both.

Two inner searches over P_body:

* ``exhaustive`` (the paper's): a P_body grid over every pelvis position from which both legs
  reach, at ``pbody_resolution_m``, then the six best coarse basins refined on a 1 mm grid (±2 steps),
  then 0.2 and 0.04 mm grids around the best; the best valid posture met is the answer.
* ``continuation`` (default): cells are visited in slices along x, each seeded with the best
  P_body of its neighbour in the previous slice and with generic postures (scored on every cell,
  searched from on every 4th slice or where they already beat the neighbour's); a compass
  (pattern) search then shrinks its step from 32 mm (seeds) or 4 mm (neighbours) to 0.5 mm, polling
  a few directions at a time, the last move's first (``search.compass_search``); Gauss–Seidel
  relaxation sweeps along x, y and z carry better optima between neighbours; last, the cells that
  are members or nearly, with the swing sole 0.15 m or more above the support, are polished by a
  compass polling all 26 directions, with the pitch limits in the projection too (there most optima
  sit where a straight leg meets a joint limit, a ridge the 14 directions of the search can miss).
  A test checks that it agrees with ``exhaustive`` on sampled cells (same membership, thrust within
  0.1 N).

Both search over pelvis positions moved onto the legs' reach balls where they lie beyond, and into
the legs' joint limits (:meth:`~jethr1_plan.optimisers.search.Evaluator.into_reach`): the optimum of most cells
has a leg at full stretch, often against a joint limit, where a grid or a pattern search otherwise
stalls (the CoM moves like the square root of the distance; a joint limit is a wall of penalty).

The objective is compiled (``physics.compiled``: closed-form IK, CoM, thrust, edge angle, reach in
one numba loop, equal to the numpy path of ``kinematics.closed_form`` and ``balance`` to rounding, which
agrees with PlaCo to 1e-9 m); the best posture of every member cell is re-checked by PlaCo forward
kinematics after the sweep. Work is split into blocks of z layers, a fixed partition, so the output does
not depend on the number of workers.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from dataclasses import fields as dataclass_fields

import numpy as np

from jethr1_plan.geometry import other_side
from jethr1_plan.kinematics.closed_form import solve_postures
from jethr1_plan.optimisers.compass import compass_search
from jethr1_plan.optimisers.exhaustive import exhaustive_cell
from jethr1_plan.optimisers.search import (
    DIRECTIONS,
    INTO_JOINT_LIMITS,
    Cells,
    Evaluator,
    SupportStance,
    cube_offsets,
    generic_seeds,
    lens_seeds,
)
from jethr1_plan.physics.balance import NOMINAL, Tolerance
from jethr1_plan.reasons import Reason, balances, has_posture
from jethr1_plan.robot.model import RobotModel, load_robot

__all__ = [
    "CELL_REASONS",
    "LayerResult",
    "SweepResult",
    "SweepSpec",
    "summary",
    "sweep",
    "sweep_layers",
    "verify_members",
]

#: the reasons a cell can have, in the order summary.json counts them
CELL_REASONS = (Reason.OK, Reason.OVERLAP, Reason.UNREACHABLE, Reason.JOINT_LIMIT, Reason.NO_BALANCE,
                Reason.EDGE_ANGLE, Reason.THRUST_MAX)
SEED_EVERY = 4  # continuation: generic seeds on every 4th x slice
RELAX_PASSES = 3  # continuation: rounds of neighbour relaxation
RELAX_SLACK_N = 0.05  # continuation: a neighbour's optimum is searched from when it scores below this above the cell's
#                       (0.15 before: 1.09x the evaluations for the same agreement with exhaustive)
RELAX_GAIN_N = 1e-3  # continuation: ... and replaces it when the search ends at least this much lower (a smaller
#                      gain re-offers the cell's optimum to its neighbours for nothing)
LAYERS_PER_TASK = 4  # the fixed partition of the work: output never depends on the number of workers (the
#                     relaxation also runs along z within a task)
JOIN_GRID_M = 0.001  # continuation: the grid around a member neighbour's optimum offered to a cell that is not
POLISH_ABOVE_N = 1.0  # continuation: cells up to this above the fan's maximum get the final polish
POLISH_STEP_M = 0.004  # ... starting at this compass step
POLISH_FROM_M = 0.15  # ... with the swing sole at least this high above the support
POLISH_LEVEL = INTO_JOINT_LIMITS  # ... moved into every joint limit (search.Evaluator.into_reach)
OFFER_ONCE = True  # relaxation: offer each optimum once per direction (False: every pass, as before; same output)


@dataclass(frozen=True)
class SweepSpec:
    """What to sweep (SI units). Bounds are absolute world coordinates of the swing sole centre.

    ``robot`` may be given by name or path (it is loaded); ``support_xyz`` defaults to where the
    robot stands (its stance width), ``thrust_max_n`` to its fans' maximum.
    """

    robot: RobotModel | str = "jethr1"
    support_side: str = "right"
    support_xyz: tuple[float, float, float] | None = None
    x_range: tuple[float, float] = (-0.8, 0.9)
    y_range: tuple[float, float] = (-0.9, 0.8)
    z_range: tuple[float, float] = (0.0, 0.3)
    resolution_m: float = 0.01
    thrust_max_n: float | None = None
    rho_rad: float = math.radians(5.0)
    sole_margin_m: float = 0.0
    tolerance: Tolerance = NOMINAL  # the robust policy's model errors (balance.thrust_window); zero: Paper A's
    method: str = "continuation"
    pbody_resolution_m: float = 0.01  # exhaustive only
    min_step_m: float = 0.0005  # continuation: final compass step

    def __post_init__(self) -> None:
        if not isinstance(self.robot, RobotModel):
            object.__setattr__(self, "robot", load_robot(self.robot))
        if self.support_xyz is None:
            object.__setattr__(self, "support_xyz", tuple(float(v) for v in self.model.start_feet()[self.support_side]))
        if self.thrust_max_n is None:
            object.__setattr__(self, "thrust_max_n", max((f.max_thrust_n for f in self.model.fans), default=0.0))

    @property
    def model(self) -> RobotModel:
        """The robot (loaded)."""
        assert isinstance(self.robot, RobotModel)
        return self.robot

    @property
    def support(self) -> tuple[float, float, float]:
        """The support sole's centre [m] (resolved)."""
        assert self.support_xyz is not None
        return self.support_xyz

    @property
    def fan_limit_n(self) -> float:
        """The limit on every fan [N] (resolved)."""
        assert self.thrust_max_n is not None
        return self.thrust_max_n

    @property
    def swing_side(self) -> str:
        return other_side(self.support_side)

    def support_stance(self) -> SupportStance:
        """What the searches hold fixed."""
        return SupportStance(self.support_side, self.support, self.rho_rad, self.fan_limit_n, self.sole_margin_m,
                             self.tolerance)

    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Grid coordinates [m] along x, y, z (inclusive bounds, rounded to 1e-9 m)."""
        def ax(lo, hi):
            n = math.floor((hi - lo) / self.resolution_m + 1e-9) + 1
            return np.round(lo + self.resolution_m * np.arange(n), 9)
        return ax(*self.x_range), ax(*self.y_range), ax(*self.z_range)


@dataclass
class LayerResult:
    """Per cell of one z layer (arrays over the cells, in x-major order)."""

    swing: np.ndarray  # (C, 3)
    thrust: np.ndarray  # (C,) F* [N] (inf where nothing balances)
    p_body: np.ndarray  # (C, 3) best posture (NaN where no posture is kinematically valid)
    yaw: np.ndarray  # (C,)
    reason: np.ndarray  # (C,) reason codes
    evaluations: int = 0


def _from_neighbour(ev: Evaluator, c: Cells, idx: np.ndarray, P0: np.ndarray, spec: SweepSpec):
    """A short compass search (from 4 mm) started at a neighbour's optimum."""
    P0 = ev.into_reach(c, idx, P0)
    f0, _, _ = ev(c, idx, P0)
    return compass_search(ev, c, idx, P0, f0, np.full(len(idx), 0.004), spec.min_step_m)


def _best_nearby(ev: Evaluator, c: Cells, idx: np.ndarray, P0: np.ndarray, f0: np.ndarray):
    """Per row the best of P0 (B, 3) [m] (objective f0) and the JOIN_GRID_M grid of 5 × 5 × 5 points around it.

    Where a neighbour is a member and the cell is not, the cell's balanced postures can form a sliver a
    few millimetres wide next to the neighbour's optimum, with the penalty of the postures around it
    (no balance: the CoM's distance to the sole's centre) pointing elsewhere; the compass then
    descends that penalty and misses the sliver.
    """
    offsets = cube_offsets(JOIN_GRID_M, 2)
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


def _relax_slice(ev: Evaluator, c: Cells, spec: SweepSpec, todo: np.ndarray, P_all: np.ndarray, f_all: np.ndarray,
                 src: np.ndarray, dst: np.ndarray, offered: np.ndarray) -> np.ndarray:
    """Cells ``dst`` try their neighbours' (``src``, one cell away) optima; P_all, f_all updated in
    place. Returns the cells that improved.

    A neighbour's optimum is carried over (shifted by half the cell offset) and searched from only
    where it already scores within RELAX_SLACK_N of the cell's own, where it is a member and the
    cell is not, or where it only breaks the edge angle (whose penalty, 50 N per degree, says
    little about how close a valid posture is): thrust varies by up to ~1 N between neighbouring
    cells, so comparing the two cells' optima would retry nearly every cell. The search's result
    replaces the cell's optimum when it is at least RELAX_GAIN_N lower.

    ``offered`` (cells,) marks the cells whose present optimum was already offered in this direction:
    offering it again repeats the same search from the same start, which cannot beat the cell's
    optimum (it only falls).
    """
    ok = todo[dst] & np.isfinite(f_all[src]) & (f_all[src] < 2000) & (~offered[src] if OFFER_ONCE else True)
    offered[src] = True
    none = np.zeros(0, dtype=np.int64)
    if not ok.any():
        return none
    s_idx, d_idx = src[ok], dst[ok]
    P0 = ev.into_reach(c, d_idx, P_all[s_idx] + (c.swing[d_idx] - c.swing[s_idx]) / 2)
    f0, _, r0 = ev(c, d_idx, P0)
    fmax = spec.fan_limit_n
    joins = (f_all[d_idx] > fmax) & (f_all[s_idx] <= fmax)  # a member's optimum offered to a cell that is not
    go = (f0 < f_all[d_idx] + RELAX_SLACK_N) | joins | ((r0 == Reason.EDGE_ANGLE) & (f_all[d_idx] > 0))
    if not go.any():
        return none
    if joins.any():  # the cell's feasible set may be a sliver next to that optimum: a small grid finds it
        P0[joins], f0[joins] = _best_nearby(ev, c, d_idx[joins], P0[joins], f0[joins])
    d_idx, P0, f0 = d_idx[go], P0[go], f0[go]
    P2, f2 = compass_search(ev, c, d_idx, P0, f0, np.full(len(d_idx), 0.004), spec.min_step_m)
    better = f2 < f_all[d_idx] - RELAX_GAIN_N
    P_all[d_idx[better]], f_all[d_idx[better]] = P2[better], f2[better]
    return d_idx[better]


def sweep_layers(spec: SweepSpec, zs: tuple[float, ...]) -> LayerResult:
    """Every cell of the layers at swing heights ``zs`` [m] (``continuation`` or ``exhaustive``).

    Layers are independent; sweeping a few together only makes the numpy batches larger.
    """
    robot = spec.model
    ev = Evaluator(robot, spec.support_stance())
    xs, ys, _ = spec.axes()
    X, Y, Z = np.meshgrid(xs, ys, np.asarray(zs, dtype=float), indexing="ij")
    swing = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    n = len(swing)
    c = ev.cells(swing)
    reason = np.full(n, Reason.UNREACHABLE, dtype=np.int8)
    thrust = np.full(n, np.inf)
    best_p = np.full((n, 3), np.nan)
    sup = ev.support
    overlap = (np.abs(swing[:, 0] - sup[0]) < robot.sole_length_m) & (np.abs(swing[:, 1] - sup[1]) < robot.sole_width_m)
    reason[overlap] = Reason.OVERLAP
    todo = ~overlap & ev.reach_possible(c)
    if spec.method == "exhaustive":
        for i in np.flatnonzero(todo):
            best_p[i], thrust[i], reason[i] = exhaustive_cell(ev, c, i, spec.pbody_resolution_m)
    else:
        per_slice = len(ys) * len(zs)
        slices = [np.arange(ix * per_slice, (ix + 1) * per_slice) for ix in range(len(xs))]
        P_all = np.full((n, 3), np.nan)
        f_all = np.full(n, np.inf)
        shift = np.array([spec.resolution_m / 2, 0.0, 0.0])
        # forward pass along +x: every cell starts from its -x neighbour's optimum; cells without one,
        # and every SEED_EVERY-th slice, also start from the best generic seed (new basins enter there)
        for ix, sl in enumerate(slices):
            idx = sl[todo[sl]]
            if not len(idx):
                continue
            P = np.full((len(idx), 3), np.nan)
            f = np.full(len(idx), np.inf)
            if ix > 0:
                nb = idx - per_slice
                has = np.isfinite(f_all[nb]) & (f_all[nb] < 2000)
                if has.any():
                    P[has], f[has] = _from_neighbour(ev, c, idx[has], P_all[nb[has]] + shift, spec)
            # generic seeds, scored on every cell: searched from on every SEED_EVERY-th slice, where
            # the neighbour gave nothing, and wherever a seed already scores below the cell's optimum
            seeds = np.concatenate([generic_seeds(ev, c, idx), lens_seeds(ev, c, idx)], axis=1)
            b, k = seeds.shape[:2]
            rows_k = np.repeat(idx, k)
            seeds = ev.into_reach(c, rows_k, seeds.reshape(-1, 3)).reshape(b, k, 3)
            obj = ev(c, rows_k, seeds.reshape(-1, 3))[0].reshape(b, k)
            j = np.argmin(obj, axis=1)
            best_seed, best_obj = seeds[np.arange(b), j], obj[np.arange(b), j]
            fresh = ~np.isfinite(f) | (f >= 2000) | (ix % SEED_EVERY == 0) | (best_obj < f)
            if fresh.any():
                P2, f2 = compass_search(ev, c, idx[fresh], best_seed[fresh], best_obj[fresh],
                                        np.full(int(fresh.sum()), 0.032), spec.min_step_m)
                better = f2 < f[fresh]
                rows = np.flatnonzero(fresh)[better]
                P[rows], f[rows] = P2[better], f2[better]
            P_all[idx], f_all[idx] = P, f
        # relaxation: Gauss-Seidel sweeps along -x, +y, -y, +x, +z, -z, slice by slice, so a better optimum
        # found anywhere can travel across the whole grid in one sweep; until no cell improves or
        # RELAX_PASSES rounds are done
        grid = np.arange(n).reshape(len(xs), len(ys), len(zs))
        directions = ((0, -1), (1, 1), (1, -1), (0, 1)) + (((2, 1), (2, -1)) if len(zs) > 1 else ())
        offered = np.zeros((len(directions), n), dtype=bool)  # per direction: the cell's optimum was offered
        for _ in range(RELAX_PASSES):
            improved = 0
            for (axis, d), off in zip(directions, offered, strict=True):
                order = range(grid.shape[axis]) if d > 0 else range(grid.shape[axis] - 1, -1, -1)
                for k in list(order)[1:]:
                    better = _relax_slice(ev, c, spec, todo, P_all, f_all, np.take(grid, k - d, axis=axis).ravel(),
                                          np.take(grid, k, axis=axis).ravel(), off)
                    offered[:, better] = False  # a new optimum: offer it in every direction again
                    improved += len(better)
            if not improved:
                break
        # polish: the cells that are members or nearly, polled in all 26 directions, moved into every joint
        # limit (the optimum of most sits where a straight leg meets a joint limit, a ridge the 14 directions
        # can miss)
        near = np.flatnonzero(todo & (f_all <= spec.fan_limit_n + POLISH_ABOVE_N) & (f_all > 0)
                              & (swing[:, 2] - ev.support[2] >= POLISH_FROM_M))
        if len(near):
            P2, f2 = compass_search(ev, c, near, P_all[near], f_all[near], np.full(len(near), POLISH_STEP_M),
                                    spec.min_step_m, axis_dirs=DIRECTIONS, fine_dirs=DIRECTIONS,
                                    levels=(POLISH_LEVEL, POLISH_LEVEL))
            better = f2 < f_all[near] - 1e-9
            P_all[near[better]], f_all[near[better]] = P2[better], f2[better]
        idx = np.flatnonzero(todo)
        if len(idx):
            _, t, r = ev(c, idx, P_all[idx])
            thrust[idx], reason[idx] = t, r
            valid = has_posture(r)
            best_p[idx[valid]] = P_all[idx[valid]]
    return LayerResult(swing=swing, thrust=np.where(balances(reason), thrust, np.inf),
                       p_body=np.where(has_posture(reason)[:, None], best_p, np.nan), yaw=c.yaw, reason=reason,
                       evaluations=ev.evaluations)


@dataclass
class SweepResult:
    spec: SweepSpec
    swing: np.ndarray
    thrust: np.ndarray
    p_body: np.ndarray
    yaw: np.ndarray
    reason: np.ndarray
    evaluations: int
    wall_s: float = 0.0
    extra: dict = field(default_factory=dict)

    @property
    def with_thrust(self) -> np.ndarray:
        return self.reason == Reason.OK

    @property
    def without_thrust(self) -> np.ndarray:
        return (self.reason == Reason.OK) & (self.thrust == 0.0)


def sweep(spec: SweepSpec, jobs: int = 1, executor: str = "loky", scheduler: str | None = None,
          progress=None) -> SweepResult:
    """The whole sweep, one z layer per task. The result does not depend on ``jobs`` or the executor."""
    import time

    from joblib import Parallel, delayed, parallel_config

    t0 = time.perf_counter()
    _, _, zs = spec.axes()
    chunks = [tuple(float(z) for z in zs[k:k + LAYERS_PER_TASK]) for k in range(0, len(zs), LAYERS_PER_TASK)]
    tasks = [delayed(sweep_layers)(spec, chunk) for chunk in chunks]
    if executor == "dask":
        from jethr1_plan.io.cluster import dask_client

        with dask_client(scheduler, jobs), parallel_config(backend="dask"):
            layers = list(Parallel()(tasks))
    elif jobs == 1:
        layers = []
        for k, task in enumerate(tasks):
            fn, args, kwargs = task
            layers.append(fn(*args, **kwargs))
            if progress:
                progress(f"layers z = {chunks[k][0]:.3f}..{chunks[k][-1]:.3f} m", k + 1, len(tasks))
    else:
        layers = []
        for k, layer in enumerate(Parallel(n_jobs=jobs, return_as="generator")(tasks)):
            layers.append(layer)
            if progress:
                progress(f"layers z = {chunks[k][0]:.3f}..{chunks[k][-1]:.3f} m", k + 1, len(tasks))
    cat = {f: np.concatenate([getattr(layer, f) for layer in layers]) for f in ("swing", "thrust", "p_body", "yaw",
                                                                             "reason")}
    order = np.lexsort((cat["swing"][:, 2], cat["swing"][:, 1], cat["swing"][:, 0]))
    return SweepResult(spec, swing=cat["swing"][order], thrust=cat["thrust"][order], p_body=cat["p_body"][order],
                       yaw=cat["yaw"][order], reason=cat["reason"][order],
                       evaluations=sum(layer.evaluations for layer in layers), wall_s=time.perf_counter() - t0)


def verify_members(result: SweepResult) -> int:
    """Re-check every member cell's best posture by PlaCo forward kinematics; return the count checked.

    Raises:
        AssertionError: a posture whose soles are not where the sweep says (a bug).
    """
    robot = result.spec.model
    spec = result.spec
    wrapper = robot.wrapper()
    support = np.asarray(spec.support_xyz)
    idx = np.flatnonzero(result.with_thrust)
    feet = {spec.support_side: (support, 0.0), spec.swing_side: (result.swing[idx], 0.0)}
    qs, coms, statuses = solve_postures(robot, result.p_body[idx], result.yaw[idx], feet)
    for k, i in enumerate(idx):
        q, com, status = qs[k:k + 1], coms[k:k + 1], statuses[k:k + 1]
        T = np.eye(4)
        cy, sy = math.cos(result.yaw[i]), math.sin(result.yaw[i])
        T[:2, :2] = [[cy, -sy], [sy, cy]]
        T[:3, 3] = result.p_body[i]
        wrapper.set_T_world_fbase(T)
        wrapper.state.q[7:] = q[0]
        wrapper.update_kinematics()
        err_s = np.linalg.norm(wrapper.get_T_world_frame(robot.legs[spec.support_side].sole)[:3, 3] - support)
        err_w = np.linalg.norm(wrapper.get_T_world_frame(robot.legs[spec.swing_side].sole)[:3, 3] - result.swing[i])
        if status[0] != Reason.OK or max(err_s, err_w) > 1e-9 or np.linalg.norm(wrapper.com_world() - com[0]) > 1e-9:
            raise AssertionError(f"balance-space cell {result.swing[i]} fails its PlaCo re-check")
    return len(idx)


def summary(result: SweepResult) -> dict:
    """summary.json of a sweep."""
    spec = result.spec
    res = spec.resolution_m
    sup = np.asarray(spec.support_xyz)
    out = {
        "support": {"side": spec.support_side, "position_m": list(spec.support)},
        "swing": spec.swing_side,
        "robot": spec.model.name,
        "sole": {"length_m": spec.model.sole_length_m, "width_m": spec.model.sole_width_m},
        "bounds_m": {"x": list(spec.x_range), "y": list(spec.y_range), "z": list(spec.z_range)},
        "resolution_m": res,
        "method": spec.method,
        "thrust_max_n": spec.thrust_max_n,
        "cells": len(result.swing),
        "evaluations": int(result.evaluations),
        "wall_s": float(result.wall_s),
    }
    side = 1.0 if spec.swing_side == "left" else -1.0
    for name, mask in (("with_thrust", result.with_thrust), ("without_thrust", result.without_thrust)):
        pts = result.swing[mask]
        out[name] = {
            "cells": int(mask.sum()),
            "volume_m3": float(mask.sum() * res ** 3),
            "max_forward_m": float((pts[:, 0] - sup[0]).max()) if len(pts) else None,
            "max_sideways_m": float((side * (pts[:, 1] - sup[1])).max()) if len(pts) else None,
            "max_reach_m": float(np.linalg.norm(pts[:, :2] - sup[:2], axis=1).max()) if len(pts) else None,
        }
    out["reasons"] = {k.message or "member": int(np.sum(result.reason == k)) for k in CELL_REASONS}
    fields = {f.name: getattr(spec, f.name) for f in dataclass_fields(spec)}
    fields["robot"] = spec.model.name
    fields["tolerance"] = asdict(spec.tolerance)
    out["spec"] = {k: (list(v) if isinstance(v, tuple) else v) for k, v in fields.items()}
    return out
