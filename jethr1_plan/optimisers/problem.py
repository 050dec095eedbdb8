"""Candidate evaluation and GAS's fitness, Paper A eqs. (A-5)..(A-22).

``evaluate_candidates`` turns P_body candidates into postures (PlaCo IK), the exact minimal thrust
H(P_body) of (A-5) with its ZMP, and the edge-angle error of (A-10). ``fitness`` adds the
penalties f1..f4 of (A-15)..(A-22).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jethr1_plan.kinematics import PostureSolver, Stance
from jethr1_plan.physics.balance import NOMINAL, Tolerance, edge_angle_excess, window_bounds, zmp_with_thrust
from jethr1_plan.reasons import Reason, ik_failed
from jethr1_plan.robot.model import GRAVITY

__all__ = ["Candidates", "FitnessConstants", "SampleProblem", "evaluate_candidates", "fitness"]


@dataclass(frozen=True)
class SampleProblem:
    """Everything that one swing sample fixes (SI units)."""

    stance: Stance
    fan_xy: np.ndarray  # (2,) thrust point on the ground [m]
    ankle_xy: np.ndarray  # (2,) swing ankle projected on the ground [m]
    edge_origin_xy: np.ndarray  # (2,) Z of: the support sole centre [m]
    support_polygon: np.ndarray  # (K, 2) support sole, shrunk by the margin [m]
    mass_kg: float
    thrust_max_n: float
    rho_rad: float
    tolerance: Tolerance = NOMINAL  # model errors the thrust must survive (balance.thrust_window)


@dataclass
class Candidates:
    """Evaluated candidates: arrays with a leading dimension N."""

    p_body: np.ndarray  # (N, 3) [m]
    q: np.ndarray  # (N, 12) [rad]
    com: np.ndarray  # (N, 3) [m]
    thrust_n: np.ndarray  # (N,) least thrust balancing within the tolerance; inf where none does or IK failed [N]
    zmp_xy: np.ndarray  # (N, 2) [m]
    edge_excess_rad: np.ndarray  # (N,) max(|θ_ZC − θ_CA| − ρ, 0) [rad]
    violation: np.ndarray  # (N,) the first violated constraint (a Reason): the IK's, then balance, F_max, (A-10)
    window_gap_n: np.ndarray  # (N,) where no thrust balances: how far the window is from opening [N] (inf: never)

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
    lo, hi, blocked = window_bounds(batch.com[:, :2], problem.fan_xy, problem.support_polygon, problem.mass_kg,
                                    problem.tolerance)
    empty = (lo > hi) | blocked
    thrust = np.where(ik_ok & ~empty, lo, np.inf)
    gap = np.where(empty, np.where(blocked | ~np.isfinite(lo - hi), np.inf, lo - hi), 0.0)
    with np.errstate(invalid="ignore"):
        zmp = zmp_with_thrust(batch.com[:, :2], problem.fan_xy, np.where(np.isfinite(thrust), thrust, np.nan),
                              problem.mass_kg)
    excess = edge_angle_excess(problem.edge_origin_xy, batch.com[:, :2], problem.ankle_xy, problem.rho_rad)
    excess = np.where(ik_ok, excess, np.inf)
    violation = np.where(ik_ok, Reason.OK, batch.status.astype(np.int64))
    violation = np.where(ik_ok & ~np.isfinite(thrust), Reason.NO_BALANCE, violation)
    violation = np.where((violation == Reason.OK) & (thrust > problem.thrust_max_n), Reason.THRUST_MAX, violation)
    violation = np.where((violation == Reason.OK) & (excess > 0), Reason.EDGE_ANGLE, violation)
    return Candidates(np.asarray(p_body, dtype=float), batch.q, batch.com, thrust, zmp, excess, violation, gap)


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


def fitness(c: Candidates, k: FitnessConstants, thrust_max_n: float,
            previous_p_body: np.ndarray | None = None) -> np.ndarray:
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
    thrust_ok = finite & (thrust <= thrust_max_n)
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
