"""What a robot's loop receives each tick and what it sends back: the records between the robot (or its
twin's sensor model, :mod:`jethr1_plan.sim.sensors`) and the controllers of :mod:`.feedback`.

A controller sees the robot only through a :class:`Measurement` (its declared sensors' readings, with
their noise, bias and delay) and the plan through a :class:`Reference` (the plan's row at this tick);
it answers with a :class:`Command`. The robot's own kinematic model (its URDF, nominal: not the twin's
physics) turns encoder angles and the IMU's attitude into sole and fan poses (:class:`Kinematics`).
Frames: the *IMU world*, z up (gravity), x along the heading the IMU integrates; positions relative to
the trunk's origin. SI units.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

__all__ = ["Command", "Kinematics", "Measurement", "Reference", "SoleReading"]


@dataclass(frozen=True)
class SoleReading:
    """A sole's force sensors: the normal force [N] and its centre of pressure in the sole's frame (x, y) [m]."""

    force_n: float
    cop_m: np.ndarray


@dataclass(frozen=True)
class Measurement:
    """One tick's readings of the robot's declared sensors (None: the robot has no such sensor)."""

    time_s: float
    trunk_rotation: np.ndarray | None  # (3, 3) the IMU's attitude of the trunk in the IMU world
    trunk_rate_rad_s: np.ndarray | None  # (3,) the gyro: the trunk's angular rate in its own frame [rad/s]
    joints_rad: np.ndarray | None  # (J,) the encoders, in the robot's joint order [rad]
    soles: dict[str, SoleReading] | None  # per side: the sole's force sensors


@dataclass(frozen=True)
class Reference:
    """The plan at this tick, as the controller follows it (interpolated between rows; world frame of the
    plan, which the IMU world is aligned with at the plan's start)."""

    time_s: float
    support: str  # 'left', 'right' or 'both'
    q_cmd: np.ndarray  # (J,) the plan's servo commands [rad]
    thrust_cmd: np.ndarray  # (F,) the plan's fan commands [N]
    trunk_rotation: np.ndarray  # (3, 3) the planned trunk orientation
    feet_m: np.ndarray  # (2, 3) the planned sole centres, left then right [m]
    feet_yaw_rad: np.ndarray  # (2,) their planned yaw [rad]
    fans_m: np.ndarray  # (F, 3) the planned fan positions [m]
    active: bool = True  # the plan's clock runs (False while the robot settles before it)


@dataclass(frozen=True)
class Command:
    """What the loop sends: servo targets [rad] and fan commands [N]."""

    q: np.ndarray
    thrust: np.ndarray


class Kinematics(Protocol):
    """The robot's own kinematic model, evaluated at a measurement (encoders and the IMU's attitude)."""

    def update(self, joints_rad: np.ndarray, trunk_rotation: np.ndarray) -> None:
        """Pose the model: the trunk at the origin with ``trunk_rotation``, the joints at ``joints_rad``."""

    def sole(self, side: str) -> tuple[np.ndarray, np.ndarray]:
        """The ``side`` sole's centre (3,) [m] and orientation (3, 3)."""

    def fan(self, index: int) -> np.ndarray:
        """Fan ``index``'s thrust point (3,) [m]."""

    def sole_jacobian(self, side: str, joints: np.ndarray) -> np.ndarray:
        """(6, len(joints)) the ``side`` sole's position [m] and orientation [rad] rates per joint of
        ``joints`` (indices in the robot's order), the trunk held."""

    def fan_lift_jacobian(self, index: int) -> np.ndarray:
        """(J,) fan ``index``'s height rate per joint [m/rad], the trunk held."""
