"""Candidate evaluation and GAS's fitness, Paper A eqs. (A-5)..(A-22).

``evaluate_candidates`` turns P_body candidates into postures (PlaCo IK), the exact minimal thrust
H(P_body) of (A-5) with its ZMP, and the edge-angle error of (A-10). ``fitness`` adds the
penalties f1..f4 of (A-15)..(A-22).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from jethr1_plan.geometry import GRAVITY
from jethr1_plan.kinematics import PostureSolver, Stance
from jethr1_plan.physics.balance import (
    NOMINAL,
    Tolerance,
    edge_angle_excess,
    least_thrust,
    window_bounds,
    zmp_with_thrust,
    zmp_with_thrusts,
)
from jethr1_plan.reasons import Reason, ik_failed

__all__ = ["Candidates", "FitnessConstants", "SampleProblem", "evaluate_candidates", "fitness"]


@dataclass(frozen=True)
class SampleProblem:
    """Everything that one swing sample fixes (SI units).

    The fans that may thrust at a swing sample are the swing sole's and the trunk's (``fan_index``
    into ``robot.fans``). A fan on the sole has a fixed ground point; a fan on the trunk moves with
    P_body: its ``fan_xy`` row is its offset from P_body, turned by the body yaw.
    """

    stance: Stance
    fan_xy: np.ndarray  # (F, 2) per fan the thrust point on the ground, or its offset from P_body [m]
    ankle_xy: np.ndarray  # (2,) swing ankle projected on the ground [m]
    edge_origin_xy: np.ndarray  # (2,) Z of: the support sole centre [m]
    support_polygon: np.ndarray  # (K, 2) support sole, shrunk by the margin [m]
    mass_kg: float
    thrust_max_n: float  # the scenario's limit on every fan [N]
    rho_rad: float
    tolerance: Tolerance = NOMINAL  # model errors the thrust must survive (balance.thrust_window)
    fan_on_trunk: np.ndarray = field(default_factory=lambda: np.zeros(1, dtype=bool))  # (F,)
    fan_max_n: np.ndarray = field(default_factory=lambda: np.full(1, np.inf))  # (F,) each fan's maximum [N]
    fan_index: np.ndarray = field(default_factory=lambda: np.zeros(1, dtype=np.int64))  # (F,) into robot.fans

    @property
    def one_fixed_fan(self) -> bool:
        """One fan, fixed to the swing sole: Paper A's case, where the window is in closed form."""
        return len(self.fan_xy) == 1 and not bool(self.fan_on_trunk[0])

    def fans_at(self, p_body: np.ndarray) -> np.ndarray:
        """(N, F, 2) the fans' ground points [m] with the trunk at ``p_body`` (N, 3)."""
        p = np.atleast_2d(np.asarray(p_body, dtype=float))
        return self.fan_xy[None] + self.fan_on_trunk[None, :, None] * p[:, None, :2]


@dataclass
class Candidates:
    """Evaluated candidates: arrays with a leading dimension N."""

    p_body: np.ndarray  # (N, 3) [m]
    q: np.ndarray  # (N, 12) [rad]
    com: np.ndarray  # (N, 3) [m]
    thrust_n: np.ndarray  # (N,) least total thrust balancing within the tolerance; inf where none does or IK failed [N]
    zmp_xy: np.ndarray  # (N, 2) [m]
    edge_excess_rad: np.ndarray  # (N,) max(|θ_ZC − θ_CA| − ρ, 0) [rad]
    violation: np.ndarray  # (N,) the first violated constraint (a Reason): the IK's, then balance, F_max, (A-10)
    window_gap_n: np.ndarray  # (N,) where no thrust balances: how far the window is from opening [N] (inf: never)
    split_n: np.ndarray  # (N, F) the thrust of each of the problem's fans [N] (NaN where none balances)

    @property
    def feasible(self) -> np.ndarray:
        return self.violation == Reason.OK

    def take(self, i: int) -> Candidates:
        """The single candidate ``i`` (arrays of length 1)."""
        return Candidates(*(getattr(self, f)[i:i + 1] for f in self.__dataclass_fields__))


def evaluate_candidates(solver: PostureSolver, problem: SampleProblem, p_body: np.ndarray) -> Candidates:
    """Postures, thrust, ZMP and constraint status for candidates ``p_body`` (N, 3) [m]."""
    batch = solver.solve_batch(problem.stance, p_body)
    ik_ok = batch.status == Reason.OK
    com = batch.com[:, :2]
    if problem.one_fixed_fan:  # Paper A: the window of one fan, in closed form
        fan = problem.fan_xy[0]
        lo, hi, blocked = window_bounds(com, fan, problem.support_polygon, problem.mass_kg, problem.tolerance)
        empty = (lo > hi) | blocked
        thrust = np.where(ik_ok & ~empty, lo, np.inf)
        gap = np.where(empty, np.where(blocked | ~np.isfinite(lo - hi), np.inf, lo - hi), 0.0)
        over = thrust > problem.thrust_max_n
        with np.errstate(invalid="ignore"):
            zmp = zmp_with_thrust(com, fan, np.where(np.isfinite(thrust), thrust, np.nan), problem.mass_kg)
        split = np.where(np.isfinite(thrust), thrust, np.nan)[:, None]
    else:
        thrust, split, gap, over = _fan_thrusts(problem, np.asarray(p_body, dtype=float), com, ik_ok)
        with np.errstate(invalid="ignore"):
            zmp = zmp_with_thrusts(com, problem.fans_at(p_body), split, problem.mass_kg)
    excess = edge_angle_excess(problem.edge_origin_xy, com, problem.ankle_xy, problem.rho_rad)
    excess = np.where(ik_ok, excess, np.inf)
    violation = np.where(ik_ok, Reason.OK, batch.status.astype(np.int64))
    violation = np.where(ik_ok & ~np.isfinite(thrust), Reason.NO_BALANCE, violation)
    violation = np.where((violation == Reason.OK) & over, Reason.THRUST_MAX, violation)
    violation = np.where((violation == Reason.OK) & (excess > 0), Reason.EDGE_ANGLE, violation)
    return Candidates(np.asarray(p_body, dtype=float), batch.q, batch.com, thrust, zmp, excess, violation, gap, split)


def _fan_thrusts(problem: SampleProblem, p_body: np.ndarray, com: np.ndarray, ik_ok: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Several fans (or one on the trunk): the least total thrust within each fan's maximum
    (``balance.least_thrust``); where only more than a maximum balances, the least total without
    the maxima (THRUST_MAX, graded by it). Returns total (N,), split (N, F), the window gap (N,) [N]
    where nothing balances (the smallest of the single fans' gaps) and where a maximum is exceeded."""
    fans = problem.fans_at(p_body)
    tol, poly, m = problem.tolerance, problem.support_polygon, problem.mass_kg
    caps = np.minimum(problem.fan_max_n, problem.thrust_max_n)
    total, split = least_thrust(com, fans, poly, m, caps, tol)
    free, free_split = least_thrust(com, fans, poly, m, None, tol)
    over = ~np.isfinite(total) & np.isfinite(free)
    total = np.where(ik_ok, np.where(over, free, total), np.inf)
    split = np.where((ik_ok & over)[:, None], free_split, split)
    split = np.where(ik_ok[:, None], split, np.nan)
    gap = np.full(len(com), np.inf)
    for i in range(fans.shape[1]):
        lo, hi, blocked = window_bounds(com, fans[:, i], poly, m, tol)
        gap = np.minimum(gap, np.where(blocked | ~np.isfinite(lo - hi), np.inf, np.maximum(lo - hi, 0.0)))
    gap = np.where(np.isfinite(free), 0.0, gap)
    return total, split, gap, over & ik_ok


@dataclass(frozen=True)
class FitnessConstants:
    """Constants of (A-16)..(A-22). ``f3_unit_m`` is the length unit f3 is computed in [m]."""

    c1: float = 11000.0
    c2: float = 9000.0
    c4_1: float = 5000.0
    c4_2: float = 10.0
    omega: float = 50.0
    f3_unit_m: float = 0.001  # the paper's mm
    graded: bool = True  # rank infeasible candidates by how far they are from feasibility
    weight_n: float = 6.8 * GRAVITY  # M·g, the grading of a ray that misses the sole [N]


def fitness(c: Candidates, k: FitnessConstants, previous_p_body: np.ndarray | None = None) -> np.ndarray:
    """f = f1 + f2 + f3 + f4 of (A-15); f3 only with ``previous_p_body`` (intermediate phase).

    f1 = C1 when the IK fails or a joint limit binds (A-16); f2 = C2 when (A-10) fails (A-17);
    f3 = ω·Σ(ΔP_body)² in units of ``f3_unit_m`` (A-18..A-21); f4 = C4-2·F when 0 ≤ F ≤ F_max,
    else C4-1 (A-22). A failed IK also counts as violating (A-9) and (A-10).

    With ``k.graded`` (the default) each violated term also grows with the size of the violation:
    f2 adds C4-2 per degree beyond ρ; f4 adds C4-2·F above F_max, or, where no thrust balances,
    C4-2 times how far the thrust window is from opening (``balance.window_bounds``: lo − hi [N]),
    at most M·g (M·g where it never opens). Every infeasible candidate still scores above every
    feasible one, as in the paper; the grading only ranks infeasible candidates among themselves,
    so the GA climbs towards feasibility instead of searching blindly where the feasible set is
    small.
    """
    failed = ik_failed(c.violation)
    finite = np.isfinite(c.thrust_n)
    thrust = np.where(finite, c.thrust_n, 0.0)
    thrust_ok = finite & (c.violation != Reason.THRUST_MAX)
    edge_ok = c.edge_excess_rad <= 0
    f1 = np.where(failed, k.c1, 0.0)
    f2 = np.where(edge_ok, 0.0, k.c2)
    f4 = np.where(thrust_ok, k.c4_2 * thrust, k.c4_1)
    if k.graded:
        f2 = f2 + np.where(~failed & ~edge_ok, k.c4_2 * np.degrees(np.where(failed, 0, c.edge_excess_rad)), 0.0)
        f4 = f4 + np.where(~failed & finite & ~thrust_ok, k.c4_2 * thrust, 0.0)
        f4 = f4 + np.where(~failed & ~finite, k.c4_2 * np.minimum(c.window_gap_n, k.weight_n), 0.0)
    f = f1 + f2 + f4
    if previous_p_body is not None:
        d = (c.p_body - previous_p_body) / k.f3_unit_m
        f = f + k.omega * np.sum(d * d, axis=1)
    return f
