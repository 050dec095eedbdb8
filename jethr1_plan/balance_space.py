"""Balance space (Paper A, IV-A, Fig. 5): where the swing sole can be held, with and without thrust.

The support sole is fixed; the swing sole (flat, facing +x) visits every cell of a grid. For each
cell the minimal thrust F* over P_body is found under all of Paper A's constraints: the legs reach
(IK), joint limits (A-8), 0 ≤ F ≤ F_max (A-9), the edge angle (A-10), the ZMP in the support sole
(A-11), with the body yaw of (A-4). The cell is in the space *with* thrust when F* ≤ F_max and in
the space *without* when F* = 0: one sweep gives both.

Two inner searches over P_body:

* ``exhaustive`` (the paper's): a P_body grid over every pelvis position from which both legs
  reach, at ``pbody_resolution_m``, then the six best coarse basins refined on a 1 mm grid (±2 steps);
  the best valid posture met is the answer.
* ``continuation`` (default): cells are visited in slices along x, each seeded with the best
  P_body of its neighbour in the previous slice and with generic postures (scored on every cell,
  searched from on every 4th slice or where they already beat the neighbour's); a compass
  (pattern) search then shrinks its step from 32 mm (seeds) or 4 mm (neighbours) to 0.5 mm;
  Gauss–Seidel relaxation sweeps carry better optima between neighbours. A test checks that it
  agrees with ``exhaustive`` on sampled cells (same membership, thrust within 0.1 N).

Both search over pelvis positions moved onto the legs' reach balls where they lie beyond
(:meth:`_Evaluator.into_reach`): the optimum of most cells has a leg at full stretch, where a
grid or a pattern search otherwise stalls (the CoM moves like the square root of the distance).

The objective is compiled (``balance_kernel``: closed-form IK, CoM, thrust, edge angle, reach in
one numba loop, equal to the numpy path of ``leg_kinematics`` and ``balance`` to rounding, which
agrees with PlaCo to 1e-9 m); the best posture of every member cell is re-checked by PlaCo forward
kinematics after the sweep. Work is split into z layers, a fixed partition, so the output does not
depend on the number of workers.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from jethr1_plan.kinematics.closed_form import check_structure, kernel_params, solve_postures
from jethr1_plan.kinematics.placo import OK
from jethr1_plan.physics.balance import NOMINAL, Tolerance, body_yaw_eq4, sole_polygon
from jethr1_plan.physics.compiled import (
    ABOVE_MAX,
    EDGE,
    LIMITS,
    MEMBER,
    NO_BALANCE,
    OUT_OF_REACH,
    OVERLAP,
    balance_objective,
    into_reach,
)
from jethr1_plan.robot.model import GRAVITY, RobotModel, load_robot, reach_centre

REASONS = {MEMBER: "", OVERLAP: "overlaps the support sole", OUT_OF_REACH: "out of reach",
           LIMITS: "joint limits", NO_BALANCE: "no thrust can balance", EDGE: "edge angle (A-10)",
           ABOVE_MAX: "thrust above its maximum"}
SEED_EVERY = 4  # continuation: generic seeds on every 4th x slice
RELAX_PASSES = 3  # continuation: rounds of neighbour relaxation
RELAX_SLACK_N = 0.3  # continuation: a neighbour's optimum is searched from when it scores below this above the cell's
EDGE_PENALTY_N_PER_DEG = 50.0  # far above dF/dθ (about 1 N per degree), so the penalty is exact
REFINE_BASINS = 6  # exhaustive: coarse basins refined on the 1 mm grid
REACH_MARGIN_M = 1e-4  # searches stay this far [m] inside a leg's full stretch (sqp_optimiser keeps ~0.13 mm)
LAYERS_PER_TASK = 2  # the fixed partition of the work: output never depends on the number of workers


def feasible(reason: np.ndarray) -> np.ndarray:
    """Postures that meet every constraint but perhaps the thrust limit (members and ABOVE_MAX)."""
    return (reason == MEMBER) | (reason == ABOVE_MAX)


def has_posture(reason: np.ndarray) -> np.ndarray:
    """Cells whose best P_body is a kinematically valid posture (legs reach, within limits)."""
    return (reason == MEMBER) | (reason >= NO_BALANCE)


AXIS_DIRECTIONS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)
DIRECTIONS = np.array([d for d in np.ndindex(3, 3, 3) if d != (1, 1, 1)], dtype=float) - 1.0  # 26 neighbours
# the compass's fine polls: the 6 axes and the 8 cube corners (the 12 edge directions as well cost 1.5x
# the evaluations for no measured gain in agreement with the exhaustive search)
FINE_DIRECTIONS = DIRECTIONS[np.abs(DIRECTIONS).sum(axis=1) != 2]


@dataclass(frozen=True)
class SweepSpec:
    """What to sweep (SI units). Bounds are absolute world coordinates of the swing sole centre."""

    robot: str = "jethr1"
    support_side: str = "right"
    support_xyz: tuple[float, float, float] = (0.0, -0.1125, 0.0)
    x_range: tuple[float, float] = (-0.8, 0.9)
    y_range: tuple[float, float] = (-0.9, 0.8)
    z_range: tuple[float, float] = (0.0, 0.3)
    resolution_m: float = 0.01
    thrust_max_n: float = 23.0
    rho_rad: float = math.radians(5.0)
    sole_margin_m: float = 0.0
    tolerance: Tolerance = NOMINAL  # the robust policy's model errors (balance.thrust_window); zero: Paper A's
    method: str = "continuation"
    pbody_resolution_m: float = 0.01  # exhaustive only
    min_step_m: float = 0.0005  # continuation: final compass step

    @property
    def swing_side(self) -> str:
        return "left" if self.support_side == "right" else "right"

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


@dataclass
class _Cells:
    """Per-candidate data of the cells being searched."""

    swing: np.ndarray  # (C, 3) swing sole centres [m]
    yaw: np.ndarray  # (C,) body yaw (A-4) [rad]
    fan: np.ndarray  # (C, 2) thrust point [m]
    centre_s: np.ndarray  # (C, 3) centre of the support leg's reach ball (robot_model.reach_centre) [m]
    centre_w: np.ndarray  # (C, 3) centre of the swing leg's reach ball [m]


class _Evaluator:
    """Vectorised objective over candidates of many cells at once."""

    def __init__(self, robot: RobotModel, spec: SweepSpec):
        self.robot, self.spec = robot, spec
        self.geom = check_structure(robot)
        self.support = np.asarray(spec.support_xyz, dtype=float)
        self.poly = sole_polygon(self.support[:2], 0.0, robot.sole_length_m, robot.sole_width_m, spec.sole_margin_m)
        self.fan_offset = np.asarray(robot.fan_for(spec.swing_side).offset_in_foot_m[:2])
        self.evaluations = 0
        self.params = kernel_params(robot, spec.support_side, self.support, self.poly, spec.rho_rad,
                                    spec.thrust_max_n, robot.mass_kg * GRAVITY, EDGE_PENALTY_N_PER_DEG, spec.tolerance)

    def cells(self, swing: np.ndarray) -> _Cells:
        swing = np.ascontiguousarray(swing, dtype=float)
        fan = np.ascontiguousarray(swing[:, :2] + self.fan_offset)
        yaw = body_yaw_eq4(self.support[:2], fan, self.spec.support_side)
        centre_s = reach_centre(self.geom, self.spec.support_side, np.broadcast_to(self.support, swing.shape), yaw)
        centre_w = reach_centre(self.geom, self.spec.swing_side, swing, yaw)
        return _Cells(swing, yaw, fan, np.ascontiguousarray(centre_s), np.ascontiguousarray(centre_w))

    def into_reach(self, c: _Cells, idx: np.ndarray, P: np.ndarray) -> np.ndarray:
        """P (M, 3) [m] moved onto the nearest point of both legs' reach balls where it lies beyond them.

        The optimum of most cells has a leg at full stretch, where the CoM moves like the square root
        of the distance to the ball's surface: a pattern search stalls against it. Searching over the
        projection instead lets it slide along the surface (and along the circle where both legs
        are straight). See ``balance_kernel.into_reach``. The balls' radius is REACH_MARGIN_M short
        of thigh + shank: a leg exactly straight is singular (PlaCo's IK cannot place its CoM to
        better than ~1e-4 rad of edge angle there), and 0.1 mm leaves the knee bent about 2.6°.
        """
        radius = self.geom.thigh_m + self.geom.shank_m - REACH_MARGIN_M
        return into_reach(np.ascontiguousarray(P, dtype=float), np.ascontiguousarray(idx, dtype=np.int64),
                          c.centre_w, c.centre_s, radius)

    def reach_possible(self, c: _Cells) -> np.ndarray:
        """Exact test that some P_body reaches both ankles: two spheres of radius thigh + shank
        around the ankles, shifted by the hip offsets at the cell's yaw, must intersect."""
        g = self.geom
        return np.linalg.norm(c.centre_w - c.centre_s, axis=1) <= 2 * (g.thigh_m + g.shank_m)

    def __call__(self, c: _Cells, idx: np.ndarray, P: np.ndarray):
        """Objective, thrust [N] and reason code of candidates P (M, 3) [m] for cells ``idx`` (M,).

        The objective is F* plus an exact penalty for (A-10) (continuous, so the search can slide
        along the cone's edge), and graded penalties above 2000 for postures that do not reach, leave
        the joint limits or cannot be balanced (see ``balance_kernel.balance_objective``).
        """
        self.evaluations += len(P)
        P = np.ascontiguousarray(P, dtype=float)
        idx = np.ascontiguousarray(idx, dtype=np.int64)
        return balance_objective(P, idx, c.swing, c.yaw, c.fan, *self.params)


def _generic_seeds(ev: _Evaluator, c: _Cells, idx: np.ndarray) -> np.ndarray:
    """Pelvis positions per cell: over the support foot, a quarter and half way to the swing foot,
    each from a deep crouch to nearly straight legs: (len(idx), 12, 3)."""
    g = ev.geom
    sup = ev.support
    sw = c.swing[idx]
    leg = g.thigh_m + g.shank_m + g.ankle_height_m
    seeds = []
    for t in (0.0, 0.25, 0.5):
        base = sup + t * (sw - sup)
        for hz in (0.42, 0.57, 0.72, 0.87):
            p = base.copy()
            p[:, 2] = np.minimum(sup[2], sw[:, 2]) + hz * leg
            seeds.append(p)
    return np.stack(seeds, axis=1)


def _lens_seeds(ev: _Evaluator, c: _Cells, idx: np.ndarray) -> np.ndarray:
    """Pelvis positions spread over the lens where both legs reach (the two reach balls of radius
    thigh + shank): three cuts across the line of centres, two radii, five directions from straight
    up to level on either side: (len(idx), 30, 3) [m]."""
    L = ev.geom.thigh_m + ev.geom.shank_m
    a, b = c.centre_w[idx], c.centre_s[idx]
    axis = b - a
    h = np.linalg.norm(axis, axis=1)
    e = axis / np.maximum(h, 1e-12)[:, None]
    up = np.array([0.0, 0.0, 1.0]) - e[:, 2:3] * e
    up /= np.maximum(np.linalg.norm(up, axis=1), 1e-12)[:, None]
    side = np.cross(e, up)
    half = np.maximum(L - h / 2, 0.0)  # the lens's half thickness along the line of centres
    seeds = []
    for t in (-0.5, 0.0, 0.5):
        rt = np.sqrt(np.maximum(L ** 2 - (h / 2 + abs(t) * half) ** 2, 0.0))
        centre = (a + b) / 2 + (t * half)[:, None] * e
        for frac in (0.45, 0.9):
            for phi in (0.0, np.pi / 4, -np.pi / 4, np.pi / 2, -np.pi / 2):
                seeds.append(centre + (frac * rt)[:, None] * (np.cos(phi) * up + np.sin(phi) * side))
    return np.stack(seeds, axis=1)


def _from_neighbour(ev: _Evaluator, c: _Cells, idx: np.ndarray, P0: np.ndarray, spec: SweepSpec):
    """A short compass search (from 4 mm) started at a neighbour's optimum."""
    P0 = ev.into_reach(c, idx, P0)
    f0, _, _ = ev(c, idx, P0)
    return compass_search(ev, c, idx, P0, f0, np.full(len(idx), 0.004), spec.min_step_m)


def compass_search(ev: _Evaluator, c: _Cells, idx: np.ndarray, P: np.ndarray, f: np.ndarray, step0: np.ndarray,
                   min_step: float, max_iter: int = 60, give_up_after: int = 10, coarse_until: float = 0.002):
    """Vectorised compass search from P (B, 3) with objective f (B,), one cell per row.

    Polls the 6 axis directions while the step is at least ``coarse_until``, then the 6 axes and
    8 cube corners (so the search can slide along a constraint's edge). Every poll point is moved
    onto the reach balls first. A cell stops when its step falls below ``min_step``, when it
    reaches zero thrust, or, after ``give_up_after`` iterations, when it has still found no
    kinematically valid posture. A cell that ends on an invalid posture (a
    penalty a hair above zero) gets the best valid posture it met, if any.
    """
    P, f, step = P.copy(), f.copy(), step0.copy()
    P_ok, f_ok = np.full_like(P, np.nan), np.full(len(P), np.inf)
    for stage, dirs in ((0, AXIS_DIRECTIONS), (1, FINE_DIRECTIONS)):
        floor = coarse_until if stage == 0 else min_step
        P, f, step = _poll(ev, c, idx, P, f, step, floor, dirs, max_iter, give_up_after, P_ok, f_ok)
    # the penalties are exact, but a search that ends a hair outside a constraint falls back on the
    # best valid posture it met
    _, _, reason = ev(c, idx, P)
    back = ~feasible(reason) & np.isfinite(f_ok)
    P[back], f[back] = P_ok[back], f_ok[back]
    return P, f


def _poll(ev, c, idx, P, f, step, min_step, dirs, max_iter, give_up_after, P_ok, f_ok):
    """Compass polls until every row's step falls below ``min_step``; P_ok, f_ok keep (in place) the
    best valid posture met per row (a member, or only above the thrust limit)."""
    active = (step >= min_step) & (f > 0)
    for it in range(max_iter):
        if it == give_up_after:
            active &= f < 2000
        a = np.flatnonzero(active)
        if not len(a):
            break
        k = len(dirs)
        rows = np.repeat(idx[a], k)
        cand = ev.into_reach(c, rows, (P[a, None, :] + step[a, None, None] * dirs[None]).reshape(-1, 3))
        obj, _, reason = ev(c, rows, cand)
        obj, cand = obj.reshape(len(a), k), cand.reshape(len(a), k, 3)
        valid = np.where(feasible(reason).reshape(len(a), k), obj, np.inf)
        jv = np.argmin(valid, axis=1)
        best_valid = valid[np.arange(len(a)), jv]
        up = best_valid < f_ok[a]
        P_ok[a[up]], f_ok[a[up]] = cand[np.flatnonzero(up), jv[up]], best_valid[up]
        j = np.argmin(obj, axis=1)
        best = obj[np.arange(len(a)), j]
        better = best < f[a] - 1e-12
        moved = a[better]
        P[moved] = cand[np.flatnonzero(better), j[better]]
        f[moved] = best[better]
        step[a[~better]] *= 0.5
        active = (step >= min_step) & (f > 0)
    return P, f, step


def _relax_slice(ev: _Evaluator, c: _Cells, spec: SweepSpec, todo: np.ndarray, P_all: np.ndarray, f_all: np.ndarray,
                 src: np.ndarray, dst: np.ndarray) -> int:
    """Cells ``dst`` try their neighbours' (``src``, one cell away) optima; P_all, f_all updated in
    place. Returns how many cells improved.

    A neighbour's optimum is carried over (shifted by half the cell offset) and searched from only
    where it already scores within RELAX_SLACK_N of the cell's own, where it is a member and the
    cell is not, or where it only breaks the edge angle (whose penalty, 50 N per degree, says
    little about how close a valid posture is): thrust varies by up to ~1 N between neighbouring
    cells, so comparing the two cells' optima would retry nearly every cell.
    """
    ok = todo[dst] & np.isfinite(f_all[src]) & (f_all[src] < 2000)
    if not ok.any():
        return 0
    s_idx, d_idx = src[ok], dst[ok]
    P0 = ev.into_reach(c, d_idx, P_all[s_idx] + (c.swing[d_idx] - c.swing[s_idx]) / 2)
    f0, _, r0 = ev(c, d_idx, P0)
    fmax = spec.thrust_max_n
    go = ((f0 < f_all[d_idx] + RELAX_SLACK_N) | ((f_all[d_idx] > fmax) & (f_all[s_idx] <= fmax))
          | ((r0 == EDGE) & (f_all[d_idx] > 0)))
    if not go.any():
        return 0
    d_idx, P0, f0 = d_idx[go], P0[go], f0[go]
    P2, f2 = compass_search(ev, c, d_idx, P0, f0, np.full(len(d_idx), 0.004), spec.min_step_m)
    better = f2 < f_all[d_idx] - 1e-9
    P_all[d_idx[better]], f_all[d_idx[better]] = P2[better], f2[better]
    return int(better.sum())


def sweep_layers(spec: SweepSpec, zs: tuple[float, ...]) -> LayerResult:
    """Every cell of the layers at swing heights ``zs`` [m] (``continuation`` or ``exhaustive``).

    Layers are independent; sweeping a few together only makes the numpy batches larger.
    """
    robot = load_robot(spec.robot)
    ev = _Evaluator(robot, spec)
    xs, ys, _ = spec.axes()
    X, Y, Z = np.meshgrid(xs, ys, np.asarray(zs, dtype=float), indexing="ij")
    swing = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    n = len(swing)
    c = ev.cells(swing)
    reason = np.full(n, OUT_OF_REACH, dtype=np.int8)
    thrust = np.full(n, np.inf)
    best_p = np.full((n, 3), np.nan)
    sup = ev.support
    overlap = (np.abs(swing[:, 0] - sup[0]) < robot.sole_length_m) & (np.abs(swing[:, 1] - sup[1]) < robot.sole_width_m)
    reason[overlap] = OVERLAP
    todo = ~overlap & ev.reach_possible(c)
    if spec.method == "exhaustive":
        for i in np.flatnonzero(todo):
            best_p[i], thrust[i], reason[i] = _exhaustive_cell(ev, c, i)
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
            seeds = np.concatenate([_generic_seeds(ev, c, idx), _lens_seeds(ev, c, idx)], axis=1)
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
        # relaxation: Gauss-Seidel sweeps along -x, +y, -y, +x, slice by slice, so a better optimum
        # found anywhere can travel across the whole grid in one sweep; until no cell improves or
        # RELAX_PASSES rounds are done
        grid = np.arange(n).reshape(len(xs), len(ys), len(zs))
        for _ in range(RELAX_PASSES):
            improved = 0
            for axis, d in ((0, -1), (1, 1), (1, -1), (0, 1)):
                order = range(grid.shape[axis]) if d > 0 else range(grid.shape[axis] - 1, -1, -1)
                for k in list(order)[1:]:
                    improved += _relax_slice(ev, c, spec, todo, P_all, f_all, np.take(grid, k - d, axis=axis).ravel(),
                                             np.take(grid, k, axis=axis).ravel())
            if not improved:
                break
        idx = np.flatnonzero(todo)
        if len(idx):
            _, t, r = ev(c, idx, P_all[idx])
            thrust[idx], reason[idx] = t, r
            valid = has_posture(r)
            best_p[idx[valid]] = P_all[idx[valid]]
    member = reason == MEMBER
    return LayerResult(swing=swing, thrust=np.where(member | (reason == ABOVE_MAX), thrust, np.inf),
                       p_body=np.where(has_posture(reason)[:, None], best_p, np.nan), yaw=c.yaw, reason=reason,
                       evaluations=ev.evaluations)


def pelvis_box(ev: _Evaluator, c: _Cells, i: int, res: float) -> np.ndarray:
    """Grid points [m] of every P_body from which both ankles may be reached (bounding box of the
    intersection of the two reach spheres) at spacing ``res``."""
    g = ev.geom
    L = g.thigh_m + g.shank_m
    cs = reach_centre(g, ev.spec.support_side, ev.support, c.yaw[i])
    cw = reach_centre(g, ev.spec.swing_side, c.swing[i], c.yaw[i])
    lo = np.maximum(cs - L, cw - L)
    hi = np.minimum(cs + L, cw + L)
    lo[2] = max(lo[2], max(cs[2], cw[2]))  # the pelvis stays above the ankles
    axes = [np.arange(lo[k], hi[k] + 1e-12, res) for k in range(3)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def _exhaustive_cell(ev: _Evaluator, c: _Cells, i: int, basins: int = REFINE_BASINS):
    """The paper's exhaustive inner search: a P_body grid, then a 1 mm grid (±2 coarse steps) around
    each of the ``basins`` best coarse points that lie at least 2.5 coarse steps apart (a thin
    feasible sliver can hold the optimum in a basin whose best coarse point is not the best).

    Grid points beyond a leg's reach are moved onto its reach ball (:meth:`_Evaluator.into_reach`):
    the optimum usually has a leg at full stretch, on the ball's surface, which a plain grid only
    approaches to within its spacing while the thrust changes like the square root of the distance
    there (without it, up to 0.8 N and whole members were missed on 300 sampled cells).

    The answer is the best valid posture met (the penalties are exact, but a grid point a hair
    outside a constraint can score below every valid one); the best score where none is valid."""
    grid = pelvis_box(ev, c, i, ev.spec.pbody_resolution_m)
    if not len(grid):
        return np.full(3, np.nan), np.inf, OUT_OF_REACH
    grid = ev.into_reach(c, np.full(len(grid), i), grid)
    scored = [ev(c, np.full(len(chunk), i), chunk) for chunk in (grid[s:s + 20000] for s in range(0, len(grid), 20000))]
    obj = np.concatenate([o for o, _, _ in scored])
    valid = np.where(feasible(np.concatenate([rr for _, _, rr in scored])), obj, np.inf)
    r = ev.spec.pbody_resolution_m
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
    offsets = np.stack(np.meshgrid(fine, fine, fine, indexing="ij"), axis=-1).reshape(-1, 3)
    for q in centres:
        local = ev.into_reach(c, np.full(len(offsets), i), q + offsets)
        o, _, rr = ev(c, np.full(len(local), i), local)
        j = int(np.argmin(o))
        if o[j] < best_f:
            best_f, best_p = float(o[j]), local[j]
        v = np.where(feasible(rr), o, np.inf)
        j = int(np.argmin(v))
        if v[j] < best_valid_f:
            best_valid_f, best_valid_p = float(v[j]), local[j]
    if np.isfinite(best_valid_f):
        best_p = best_valid_p
    _, t, rr = ev(c, np.array([i]), best_p[None])
    return best_p, float(t[0]), int(rr[0])


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
        return self.reason == MEMBER

    @property
    def without_thrust(self) -> np.ndarray:
        return (self.reason == MEMBER) & (self.thrust == 0.0)


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
        from distributed import Client

        with Client(scheduler) if scheduler else Client(processes=True, n_workers=jobs, threads_per_worker=1) as _c, \
                parallel_config(backend="dask"):
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
    return SweepResult(spec, *(cat[f][order] for f in ("swing", "thrust", "p_body", "yaw", "reason")),
                       evaluations=sum(layer.evaluations for layer in layers), wall_s=time.perf_counter() - t0)


def verify_members(result: SweepResult) -> int:
    """Re-check every member cell's best posture by PlaCo forward kinematics; return the count checked.

    Raises:
        AssertionError: a posture whose soles are not where the sweep says (a bug).
    """
    robot = load_robot(result.spec.robot)
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
        err_s = np.linalg.norm(wrapper.get_T_world_frame(f"{spec.support_side}_foot")[:3, 3] - support)
        err_w = np.linalg.norm(wrapper.get_T_world_frame(f"{spec.swing_side}_foot")[:3, 3] - result.swing[i])
        if status[0] != OK or max(err_s, err_w) > 1e-9 or np.linalg.norm(wrapper.com_world() - com[0]) > 1e-9:
            raise AssertionError(f"balance-space cell {result.swing[i]} fails its PlaCo re-check")
    return len(idx)


def summary(result: SweepResult) -> dict:
    """summary.json of a sweep."""
    spec = result.spec
    res = spec.resolution_m
    sup = np.asarray(spec.support_xyz)
    out = {
        "support": {"side": spec.support_side, "position_m": list(spec.support_xyz)},
        "swing": spec.swing_side,
        "robot": spec.robot,
        "sole": {"length_m": load_robot(spec.robot).sole_length_m, "width_m": load_robot(spec.robot).sole_width_m},
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
    out["reasons"] = {REASONS[k] or "member": int(np.sum(result.reason == k)) for k in REASONS}
    out["spec"] = {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(spec).items()}
    return out
