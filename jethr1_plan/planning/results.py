"""What planning produces: the optimised samples of each step and the plan as a whole."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jethr1_plan.optimisers import SampleResult
from jethr1_plan.records.infeasible import Infeasible
from jethr1_plan.records.plan_rows import Rows
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.scenario import Scenario

__all__ = ["PlanResult", "StepResult"]


@dataclass
class StepResult:
    """The optimised samples of one step."""

    index: int
    swing: str
    support: str
    path_m: np.ndarray  # (N, 3) the swing sole's samples [m]
    samples: list[SampleResult]
    fan_index: tuple[int, ...] = ()  # the robot's fans this swing may use (the samples' split_n columns)

    @property
    def p_body(self) -> np.ndarray:
        """(N, 3) the chosen P_body per sample [m]."""
        return np.array([s.p_body for s in self.samples])

    @property
    def shares(self) -> np.ndarray:
        """(N,) the share of the tolerance each sample holds (1: all of it)."""
        return np.array([s.share for s in self.samples])

    @property
    def thrust_n(self) -> np.ndarray:
        """(N,) the total thrust per sample [N] (inf where none balances)."""
        return np.array([float(s.best.thrust_n[0]) for s in self.samples])

    def fan_thrust(self, i: int, fans: int) -> np.ndarray:
        """(fans,) the thrust of each of the robot's ``fans`` fans at sample ``i`` [N] (NaN where none balances)."""
        out = np.zeros(fans)
        out[list(self.fan_index)] = self.samples[i].best.split_n[0]
        return out


@dataclass
class PlanResult:
    """A plan: the optimised steps, the output-rate rows, and the first infeasible sample or row."""

    scenario: Scenario
    robot: RobotModel
    method: str
    seed: int
    steps: list[StepResult]
    rows: Rows | None
    first_infeasible: Infeasible | None
    evaluations: int
    wall_s: float
    optimise_s: float = 0.0  # the optimisation alone (no output-rate sequence) [s]

    @property
    def feasible(self) -> bool:
        return self.first_infeasible is None
