"""What a balance-space sweep covers (:class:`SweepSpec`) and how its continuation search runs
(:class:`SearchSettings`: the knobs the benchmark flips to measure each one's worth)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from jethr1_plan.geometry import other_side
from jethr1_plan.optimisers.compass import POLL_CHUNK
from jethr1_plan.optimisers.search import INTO_JOINT_LIMITS, INTO_ROLL_KNEE, SupportStance
from jethr1_plan.physics.balance import NOMINAL, Tolerance
from jethr1_plan.robot.load import load_robot
from jethr1_plan.robot.model import RobotModel

__all__ = ["SearchSettings", "SweepSpec"]


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
            object.__setattr__(self, "thrust_max_n", max((f.thrust_max_n for f in self.model.fans), default=0.0))

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


@dataclass(frozen=True)
class SearchSettings:
    """How the continuation search runs (defaults: the release's). The output depends on these (and on the
    spec) only: never on the number of workers, their order or the executor.

    The block partition: the whole x axis per block (the forward continuation along +x stays intact),
    ``block_y_cells`` cells of y and ``block_z_layers`` layers of z; a fixed size in cells, so the number of
    tasks grows with the grid (``balance_space.blocks``).
    """

    search_level: int = INTO_ROLL_KNEE  # the compass's projection (optimisers.search.Evaluator.into_reach)
    offer_level: int = INTO_JOINT_LIMITS  # a neighbour's shifted optimum, offered to a cell, moved into this
    polish_level: int = INTO_JOINT_LIMITS  # the final polish's projection
    poll_chunk: int = POLL_CHUNK  # compass directions evaluated together (optimisers.compass)
    offer_once: bool = True  # relaxation: offer each optimum once per direction (False: on every pass)
    forward_marks: bool = True  # relaxation: no +x offer the forward pass already made from the same start
    skip_zero: bool = True  # cells at zero thrust are not searched further (nothing is below zero)
    hip_yaw_gate: bool = True  # cells whose body yaw leaves a hip yaw beyond its limits: no search
    block_y_cells: int = 43  # the partition into tasks
    block_z_layers: int = 8
    max_rounds: int = 12  # boundary rounds between blocks at most (they stop when no cell changes)
