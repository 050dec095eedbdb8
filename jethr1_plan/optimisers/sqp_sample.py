"""One swing sample as a smooth program for SLSQP (:class:`AnalyticSample`), and the local searches
on it (:func:`compass`, :func:`grid_starts`); :mod:`.sqp` runs them along a path.

For one swing sample the problem is 3-variable, bounded and smooth almost everywhere: minimise the
exact minimal thrust H(P_body) (A-5) subject to (A-8) joint limits, the legs' reach, (A-9)
0 ≤ F ≤ F_max and (A-10) the edge angle. Written with the thrust as a variable, the balance
condition is smooth; gradients are forward differences of the closed-form kinematics, compiled with
the constraints in one loop (``physics.compiled.sample_terms``), exact to rounding, three postures
per gradient. Constraints keep small margins, so that postures interpolated between samples (the
50 Hz rows) and PlaCo's check of the chosen postures pass too: ZMP 0.1 mm inside the sole, 0.002 rad
inside the (A-10) cone, 0.002 rad inside the joint limits, the knees bent by at least about 0.05 rad.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np

from jethr1_plan.geometry import GRAVITY, SIDES, halfplanes
from jethr1_plan.kinematics.closed_form import check_structure, closed_form_arrays, solve_postures
from jethr1_plan.optimisers.problem import SampleProblem
from jethr1_plan.optimisers.search import DIRECTIONS
from jethr1_plan.optimisers.slsqp import minimize_slsqp
from jethr1_plan.physics.balance import edge_angle_error, least_thrust, thrust_window
from jethr1_plan.physics.compiled.sample import sample_terms
from jethr1_plan.reasons import Reason
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.robot.schema import LEG_ROLES

__all__ = ["ACCEPT_N", "BOX_MOVES", "FD_STEP", "GRID", "MARGIN", "TRUST_M", "AnalyticSample", "Found", "compass",
           "follow_box", "grid_starts", "limit_mask", "solve_from_grid", "solve_from_neighbour"]

TRUST_M = 0.02  # half-width of the box around the neighbour's P_body [m]
MARGIN = 1e-5  # SLSQP may end this far outside a constraint (rad or m²); the margins below cover it
EDGE_MARGIN_RAD = 0.002  # margin [rad]
JOINT_MARGIN_RAD = 0.002  # joint-limit margin [rad]
ZMP_MARGIN_M = 1e-4  # ZMP margin inside the support polygon [m]
REACH_MARGIN_M2 = 1e-4  # L² − ‖hip − ankle‖² ≥ this: the knee stays bent by about 0.05 rad
FD_STEP = 1e-7  # forward-difference step [m]
MAX_ITER = 25  # SLSQP iterations per solve
RESTORE_START_ITER = 3  # Gauss-Newton steps that bring an SLSQP start inside the constraints
GRID = (7, 7, 5)  # coarse grid of starting points (x, y, z) where no neighbour helps
ACCEPT_N = 1e-3  # the backward pass keeps its answer unless it needs more thrust than this [N]
BOX_MOVES = 6  # where the trust box holds the forward pass's answer back, it moves up to this many times
_FD_MOVES = FD_STEP * np.eye(3)  # the three forward-difference steps of P_body [m], one per row


@functools.lru_cache(maxsize=8)  # bounded: a design sweep's worker meets hundreds of robots
def limit_mask(robot: RobotModel) -> np.ndarray:
    """(24,) which of the rows q − lower, upper − q (the legs' joints by role) are joint-limit
    constraints: all but a knee's straight-leg limit, which is the legs' reach; the reach constraint
    (with its margin) keeps it, and the two together would be degenerate at full stretch."""
    legs = robot.leg_index
    knee = np.isin(np.arange(12), (LEG_ROLES.index("knee"), 6 + LEG_ROLES.index("knee")))
    knee_straight = knee & (robot.lower_rad[legs] <= 1e-9)
    return np.concatenate([~knee_straight, np.ones(len(knee_straight), dtype=bool)])


class AnalyticSample:
    """One sample as a smooth program in x = (P_body [m], u = F / (M·g)), on the closed-form legs.

    With the thrust as a variable, the balance condition ZMP ∈ S becomes, for each edge n·z ≤ b of
    the support polygon, u·a − d ≥ 0 with a = n·P_T − b and d = n·CoM − b (the moment balance
    divided by M·g): smooth in x, where the closed-form H(P_body) has kinks. Under the robust
    policy (``balance.thrust_window``) the row is u·(a − X|a|) ≥ d' + Y|d'| with d' = d + ε, and
    the maximum splits into two smooth rows, u·(a − X|a|) − (1 ± Y)·d' ≥ 0 (a is fixed by the
    sample's fan, so |a| is a constant). Objective u plus the tie-break
    ε_s/(M·g)·‖P_body − anchor‖² (ε_s: ``smoothness_n_per_m2``); constraints: the polygon, (A-10),
    the legs' reach and the joint limits; bounds 0 ≤ u ≤ F_max / (M·g).
    """

    def __init__(self, robot: RobotModel, problem: SampleProblem, anchor: np.ndarray | None,
                 smoothness_n_per_m2: float = 10.0, margin_scale: float = 1.0):
        self.robot, self.problem, self.anchor = robot, problem, anchor
        self.eps = smoothness_n_per_m2
        self.margins = margin_scale * np.array([EDGE_MARGIN_RAD, REACH_MARGIN_M2, JOINT_MARGIN_RAD, ZMP_MARGIN_M])
        st = problem.stance
        self.feet = {s: (st.foot_pose(s)[:3, 3], st.support_yaw if s == st.support_side else st.swing_yaw)
                     for s in SIDES}
        g = check_structure(robot)
        self.reach = g.thigh_m + g.shank_m
        self.hip = g.hip_offset_m
        self.up = np.array([0.0, 0.0, g.ankle_height_m])
        self.weight = problem.mass_kg * GRAVITY
        self.normals, polygon_offsets = halfplanes(problem.support_polygon)
        self.offsets = polygon_offsets - self.margins[3]
        tol = problem.tolerance
        self.mass_factors = np.array([1.0 + tol.mass, 1.0 - tol.mass]) if tol.mass > 0 else np.ones(1)
        self._normals_t, self._mass_column, self._com_m = self.normals.T, self.mass_factors[:, None], tol.com_m
        self._dg_du: np.ndarray | None = None  # dg/du of every constraint (one fan), once its count is known
        self.one = problem.one_fixed_fan  # Paper A's case: one variable u, constant coefficients
        self.nf = len(problem.fan_xy)
        if self.one:
            a = self.normals @ problem.fan_xy[0] - self.offsets
            self.coef = a - tol.thrust * np.abs(a)  # dg/du of every balance row
            self.coef_rows = np.tile(self.coef, len(self.mass_factors))
            self.u_max = problem.thrust_max_n / self.weight
        else:  # u per fan; a trunk fan's coefficients move with P_body
            self.fixed_rows = self._fan_rows(np.zeros(3)) if not problem.fan_on_trunk.any() else None
            self.u_maxes = np.minimum(problem.fan_max_n, problem.thrust_max_n) / self.weight
        self.evaluations = 0
        self._cache: dict[bytes, np.ndarray] = {}
        self._limit_mask = limit_mask(robot)
        if self.one:  # the compiled kernel's arguments (physics.compiled.sample_terms)
            self._kernel_args = (
                float(st.body_yaw), np.array([self.feet[s][0] for s in SIDES], dtype=float),
                np.array([self.feet[s][1] for s in SIDES], dtype=float), *closed_form_arrays(robot),
                self._limit_mask, self.margins, np.asarray(problem.edge_origin_xy, dtype=float),
                np.asarray(problem.ankle_xy, dtype=float), float(problem.rho_rad),
                np.asarray(problem.fan_xy[0], dtype=float), np.ascontiguousarray(self.normals, dtype=float),
                np.ascontiguousarray(polygon_offsets, dtype=float), self.weight, tol.thrust, tol.mass, tol.com_m)

    def posture_terms(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """CoM (M, 3) [m], the P-only constraints (M, K) (≥ 0 when held) and the exact minimal
        thrust (M,) [N] for P_body (M, 3) [m]."""
        pr = self.problem
        self.evaluations += len(P)
        if self.one:
            return sample_terms(np.ascontiguousarray(P, dtype=float), *self._kernel_args)
        q, com, status = solve_postures(self.robot, P, pr.stance.body_yaw, self.feet)
        legs = self.robot.leg_index
        q = q[:, legs]
        edge = edge_angle_error(pr.edge_origin_xy, com[:, :2], pr.ankle_xy)
        c, s = np.cos(pr.stance.body_yaw), np.sin(pr.stance.body_yaw)
        reach = []
        for side, sgn in (("left", 1.0), ("right", -1.0)):  # hip − ankle, as in the closed form's leg IK
            d = P + sgn * self.hip * np.array([-s, c, 0.0]) - (self.feet[side][0] + self.up)
            reach.append(self.reach ** 2 - np.einsum("ij,ij->i", d, d) - self.margins[1])
        lo, hi = self.robot.lower_rad[legs], self.robot.upper_rad[legs]
        # out of reach the closed form returns a stretched leg whose knee sits on its limit with no
        # gradient; there the reach constraints alone (which have one) lead back
        unreachable = (status == Reason.UNREACHABLE)[:, None]
        limits = np.where(unreachable, 1.0, np.column_stack([q - lo, hi - q]) - self.margins[2])
        cons = np.column_stack([pr.rho_rad - edge - self.margins[0], *reach, limits[:, self._limit_mask]])
        if self.one:
            thrust, _ = thrust_window(com[:, :2], pr.fan_xy[0], pr.support_polygon, pr.mass_kg, pr.tolerance)
        else:
            caps = np.minimum(pr.fan_max_n, pr.thrust_max_n)
            thrust, _ = least_thrust(com[:, :2], pr.fans_at(P), pr.support_polygon, pr.mass_kg, caps, pr.tolerance)
        return com, cons, thrust

    def _fan_rows(self, P: np.ndarray) -> np.ndarray:
        """(rows, F): dg/du_i of every balance row (one block per mass factor), the fans at P_body ``P``."""
        tol = self.problem.tolerance
        a = self.problem.fans_at(P)[0] @ self.normals.T - self.offsets  # (F, K)
        return np.tile((a - tol.thrust * np.abs(a)).T, (len(self.mass_factors), 1))

    def _constraints(self, x: np.ndarray, com_xy: np.ndarray, cons: np.ndarray) -> np.ndarray:
        """All constraint values (≥ 0 when held) at x, from the CoM and the P-only constraints."""
        d = com_xy @ self._normals_t - self.offsets + self._com_m
        if self.one:
            poly = x[3] * self.coef_rows - (self._mass_column * d).ravel()  # (the outer product, as np.outer)
        else:
            rows = self.fixed_rows if self.fixed_rows is not None else self._fan_rows(x[:3])
            poly = rows @ x[3:] - (self._mass_column * d).ravel()
        return np.concatenate([poly, cons])

    def _values(self, x: np.ndarray) -> np.ndarray:
        key = x.tobytes()
        if key not in self._cache:
            com, cons, _ = self.posture_terms(x[None, :3])
            self._cache[key] = self._constraints(x, com[0, :2], cons[0])
        return self._cache[key]

    def _jacobian(self, x: np.ndarray) -> np.ndarray:
        """(C, 4): forward differences in P_body (three postures in one batch), exact in u."""
        g0 = self._values(x)
        com, cons, _ = self.posture_terms(x[:3] + _FD_MOVES)
        if self.one:
            g = np.stack([self._constraints(x, com[k, :2], cons[k]) for k in range(3)])
            if self._dg_du is None or len(self._dg_du) != len(g0):
                self._dg_du = np.concatenate([self.coef_rows, np.zeros(len(g0) - len(self.coef_rows))])
            return np.column_stack([((g - g0) / FD_STEP).T, self._dg_du])
        moved = x + np.concatenate([_FD_MOVES, np.zeros((3, self.nf))], axis=1)
        g = np.stack([self._constraints(moved[k], com[k, :2], cons[k]) for k in range(3)])
        rows = self.fixed_rows if self.fixed_rows is not None else self._fan_rows(x[:3])
        dg_du = np.vstack([rows, np.zeros((len(g0) - len(rows), self.nf))])
        return np.column_stack([((g - g0) / FD_STEP).T, dg_du])

    def _objective(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        """u (the total) plus the tie-break, and its gradient: no posture needed."""
        if self.one:
            obj, grad = float(x[3]), np.array([0.0, 0.0, 0.0, 1.0])
        else:
            obj, grad = float(np.sum(x[3:])), np.concatenate([np.zeros(3), np.ones(self.nf)])
        if self.anchor is not None:
            d = x[:3] - self.anchor
            k = self.eps / self.weight
            obj += k * float(d @ d)
            grad[:3] += 2 * k * d
        return obj, grad

    def feasible(self, P: np.ndarray, strict_edge: bool = False) -> tuple[bool, float]:
        """Whether P_body (3,) holds every constraint (within MARGIN; with ``strict_edge`` the (A-10) cone without
        it, as the output rows are held to it), and its exact thrust [N]."""
        _, cons, thrust = self.posture_terms(P[None])
        t = float(thrust[0])
        within = t <= self.problem.thrust_max_n if self.one else True  # several fans: the LP held each maximum
        ok = bool((cons[0] >= -MARGIN).all()) and math.isfinite(t) and within
        if strict_edge:
            ok = ok and bool(cons[0][0] >= 0.0)
        return ok, t

    def restore(self, P: np.ndarray, iterations: int = 3, target: float = 2e-6, max_step: float = 0.005
                ) -> np.ndarray:
        """Least-norm Gauss-Newton steps that bring slightly violated P-only constraints back to
        ``target`` (the constraints' own units); four postures per step."""
        P = P.copy()
        for _ in range(iterations):
            _, c0, _ = self.posture_terms(P[None])
            bad = c0[0] < target
            if not bad.any():
                break
            _, c1, _ = self.posture_terms(P + _FD_MOVES)
            J = ((c1 - c0) / FD_STEP).T[bad]  # (V, 3)
            step, *_ = np.linalg.lstsq(J, target - c0[0][bad], rcond=None)
            if not np.all(np.isfinite(step)) or np.linalg.norm(step) > max_step:
                break
            P = P + step
        return P

    def solve(self, p0: np.ndarray, bounds: list[tuple[float, float]] | None = None
              ) -> tuple[np.ndarray, float, bool]:
        """SLSQP from P_body ``p0`` [m] (first brought inside the P-only constraints by ``restore``
        where it is outside them); returns (P_body, exact minimal thrust [N], feasible)."""
        p0 = self.restore(p0, iterations=RESTORE_START_ITER, max_step=TRUST_M)
        if bounds is not None:
            p0 = np.clip(p0, [b[0] for b in bounds], [b[1] for b in bounds])
        _, _, thrust0 = self.posture_terms(p0[None])
        free: list[tuple[float | None, float | None]] = [(None, None)] * 3
        box: list[tuple[float | None, float | None]] = list(bounds or free)
        if self.one:
            u0 = min(float(thrust0[0]) / self.weight, self.u_max) if np.isfinite(thrust0[0]) else self.u_max
            box += [(0.0, self.u_max)]
            x0 = np.append(p0, u0)
        else:
            caps = np.minimum(self.problem.fan_max_n, self.problem.thrust_max_n)
            _, split = least_thrust(self.posture_terms(p0[None])[0][:, :2], self.problem.fans_at(p0[None]),
                                    self.problem.support_polygon, self.problem.mass_kg, caps, self.problem.tolerance)
            shares = np.where(np.isfinite(split[0]), split[0] / self.weight, self.u_maxes)
            box += [(0.0, float(u)) for u in self.u_maxes]
            x0 = np.concatenate([p0, np.minimum(shares, self.u_maxes)])
        res = minimize_slsqp(self._objective, x0, box, self._values, self._jacobian, MAX_ITER, 1e-7)
        P = np.asarray(res.x[:3], dtype=float)
        ok, t = self.feasible(P)
        if not ok:  # SLSQP often ends a hair outside (at a leg's full stretch it zig-zags): step back in
            P = self.restore(P)
            ok, t = self.feasible(P)
        return P, t, ok


def _penalised(sample: AnalyticSample, P: np.ndarray) -> np.ndarray:
    """Thrust [N] plus exact penalties for violated constraints, plus the tie-break (M,)."""
    _, cons, thrust = sample.posture_terms(P)
    viol = np.maximum(-cons, 0.0)
    obj = np.where(np.isfinite(thrust), thrust, 1e3) + 5e3 * viol[:, 0] + 1e3 * viol[:, 1:].sum(axis=1)
    if sample.anchor is not None:
        obj = obj + sample.eps * np.sum((P - sample.anchor) ** 2, axis=1)
    return obj


def compass(sample: AnalyticSample, p0: np.ndarray, step: float = 0.004, min_step: float = 0.0005,
            max_iter: int = 40) -> np.ndarray:
    """A 26-neighbour pattern search on the penalised thrust: the fallback where SLSQP stalls."""
    p = np.asarray(p0, dtype=float)
    f = float(_penalised(sample, p[None])[0])
    for _ in range(max_iter):
        if step < min_step:
            break
        cand = p + step * DIRECTIONS
        obj = _penalised(sample, cand)
        j = int(np.argmin(obj))
        if obj[j] < f - 1e-12:
            p, f = cand[j], float(obj[j])
        else:
            step *= 0.5
    return p


def grid_starts(sample: AnalyticSample, centre: np.ndarray, half: float, k: int = 3) -> list[np.ndarray]:
    """The ``k`` best points of a coarse grid (``GRID``) over the box ``centre`` ± ``half`` [m]:
    least thrust among the feasible ones, then the least constraint violation."""
    axes = [np.linspace(-half, half, n) for n in GRID]
    grid = centre + np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    _, cons, thrust = sample.posture_terms(grid)
    violation = np.sum(np.minimum(cons, 0.0) ** 2, axis=1) + np.where(np.isfinite(thrust), 0.0, 1.0)
    order = np.lexsort((np.where(np.isfinite(thrust), thrust, np.inf), violation))
    return [grid[i] for i in order[:k]]


# while the first failing segment moves on along the path (a repair can push the failure to the next segment: the
# cone turns with the swing foot), at most one per sample


class Found(NamedTuple):
    """A sample's chosen P_body [m], its exact minimal thrust [N], and whether SLSQP settled inside
    its trust box (the box did not hold it back)."""

    p: np.ndarray
    thrust: float
    settled: bool


def _box(centre: np.ndarray, half: float) -> list[tuple[float, float]]:
    return [(float(c) - half, float(c) + half) for c in centre]


def solve_from_neighbour(sample: AnalyticSample, centre: np.ndarray, guess: np.ndarray | None = None
                         ) -> Found | None:
    """SLSQP inside the trust box around the neighbour's P_body ``centre``, from ``guess`` and then,
    if that fails, from the centre; the compass search from the centre where both end infeasible.

    Returns None where nothing feasible was found.
    """
    box = _box(centre, TRUST_M)
    starts = [centre.copy()]
    if guess is not None:
        starts.insert(0, np.clip(guess, centre - TRUST_M, centre + TRUST_M))
    for start in starts:
        x, f, ok = sample.solve(start, box)
        if ok:
            return Found(x, f, bool(np.all(np.abs(x - centre) < TRUST_M - 1e-4)))
    x = compass(sample, centre)
    ok, f = sample.feasible(x)
    return Found(x, f, False) if ok else None


def follow_box(sample: AnalyticSample, r: Found | None) -> Found | None:
    """Where the trust box held ``r`` back (not settled inside it), move the box there and solve again,
    up to ``BOX_MOVES`` times, while the thrust falls by more than ``ACCEPT_N``."""
    for _ in range(BOX_MOVES):
        if r is None or r.settled:
            break
        r2 = solve_from_neighbour(sample, r.p)
        if r2 is None or r2.thrust >= r.thrust - ACCEPT_N:
            break
        r = r2
    return r


def solve_from_grid(sample: AnalyticSample, centre: np.ndarray, half: float) -> Found | None:
    """SLSQP from the three best points of a coarse grid over ``centre`` ± ``half``; the best feasible."""
    best = None
    for x0 in grid_starts(sample, centre, half):
        x, f, ok = sample.solve(x0, _box(centre, half))
        if not ok:
            x = compass(sample, x0, step=0.016)
            ok, f = sample.feasible(x)
        if ok and (best is None or f < best.thrust - 1e-9):
            best = Found(x, f, False)
    return best
