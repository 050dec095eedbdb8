"""The optimisers' interface: a swing path in (:class:`PathRequest`), a P_body per sample out (:class:`PathResult`).

Every optimiser is a function ``optimise_path(request) -> PathResult`` registered by name in
:data:`jethr1_plan.optimisers.OPTIMISERS`; the planner never asks which one runs. Settings of every
optimiser live in one :class:`OptimiserConfig` (a scenario's ``optimiser:``); the default method is
sqp (``compare --pareto`` shows why), the GAs' defaults are Paper A's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from jethr1_plan.kinematics import PostureSolver
from jethr1_plan.optimisers.problem import Candidates, FitnessConstants, SampleProblem
from jethr1_plan.robot.model import RobotModel

__all__ = ["GAPhase", "OptimiserConfig", "PathRequest", "PathResult", "SampleResult"]


@dataclass(frozen=True)
class GAPhase:
    """One phase of the binary GA (Tables 2 and 3)."""

    population: int
    generations: int
    half_range_m: float  # search box half-width around the phase's centre [m]
    crossover: float = 0.5  # probability that a pair of parents is crossed
    mutation: float = 0.01  # probability that a bit flips


@dataclass(frozen=True)
class OptimiserConfig:
    """Optimiser parameters: the method (sqp by default) and each method's settings (the GAs' are
    Paper A's Tables 2 and 3)."""

    method: str = "sqp"  # dominates GAS (Pareto: thrust and smoothness) with >10x fewer evaluations; gas: Paper A
    initial: GAPhase = GAPhase(200, 50, 0.150)
    intermediate: GAPhase = GAPhase(150, 8, 0.025)
    bits: int = 10
    constants: FitnessConstants = field(default_factory=FitnessConstants)
    gaex_half_m: float = 0.006
    gaex_step_m: float = 0.001
    tournament_size: int = 2
    elites: int = 1
    sqp_smoothness_n_per_m2: float = 7e4  # sqp: ε, the price of ε·‖ΔP_body‖² against thrust [N/m²]


@dataclass
class SampleResult:
    """The chosen P_body at one sample and how it was found."""

    best: Candidates  # a single evaluated candidate (arrays of length 1)
    fitness: float
    evaluations: int
    phase: str  # 'initial', 'intermediate', 'exhaustive', 'restart', 'sqp', 'sqp-grid', 'sqp-share' or 'share'
    share: float = 1.0  # the share of the problem's tolerance the sample holds (robust policy; 1: all of it)

    @property
    def p_body(self) -> np.ndarray:
        return self.best.p_body[0]

    @property
    def feasible(self) -> bool:
        return bool(self.best.feasible[0])


@dataclass
class PathRequest:
    """One step's swing path as every optimiser takes it.

    ``between(i, λ)`` is the problem at the fraction λ of the way from sample i to i + 1 (the swing
    sole interpolated as the output rows are); ``row_positions`` are the fractional sample indices
    at which the output rows fall (``planning.sequence.swing_row_positions``): an optimiser that
    checks between samples checks there.
    """

    robot: RobotModel
    solver: PostureSolver  # evaluates the chosen postures (PlaCo by default)
    problems: list[SampleProblem]  # one per swing sample, in path order
    nominals: np.ndarray  # (N, 3) per sample, the centre of the search box where no neighbour helps [m]
    config: OptimiserConfig
    rngs: list[np.random.Generator]  # one random stream per sample
    between: Callable[[int, float], SampleProblem]
    row_positions: np.ndarray
    stop_at_infeasible: bool = True  # an optimiser may stop at the first infeasible sample
    progress: Callable[[int], None] | None = None  # called with the number of samples done


@dataclass
class PathResult:
    """The chosen sample results in path order (fewer than the problems if stopped at an infeasible one)."""

    samples: list[SampleResult] = field(default_factory=list)

    @property
    def first_infeasible(self) -> int | None:
        """Index of the first infeasible sample, or None."""
        return next((i for i, s in enumerate(self.samples) if not s.feasible), None)
