"""How far a leg is from its straight-leg singularity, by forward kinematics: the knee's bend (the
angle between the thigh, hip pitch axis → knee axis, and the shank, knee axis → ankle pitch axis;
0 when straight) and the reach left (thigh + shank − hip–ankle distance [m]).

At the singularity the sole's Jacobian w.r.t. the leg loses a rank: the bend is what a walk keeps
away from it (``success.knee_margin_rad``, also the IK's floor on the knee). The bend grows like
the square root of the reach left, so a leg running out of reach shows it first in the bend.
"""

from __future__ import annotations

import math

import numpy as np

from jethr1_plan.robot.model import RobotModel

__all__ = ["knee_bend_rad", "knee_limits_for_bend", "leg_points", "straight_knee_rad"]


def leg_points(wrapper, robot: RobotModel, side: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(hip, knee, ankle) [m], the hip pitch, knee and ankle pitch joints' origins in the world, of
    ``wrapper``'s current posture (kinematics updated)."""
    leg = robot.legs[side]
    hip, knee, ankle = (wrapper.get_T_world_frame(leg.joints[k])[:3, 3] for k in (2, 3, 4))
    return hip, knee, ankle


def knee_bend_rad(hip: np.ndarray, knee: np.ndarray, ankle: np.ndarray) -> np.ndarray:
    """(...,) the angle [rad] between the thigh (hip → knee) and the shank (knee → ankle): 0 straight."""
    a = np.asarray(knee, dtype=float) - hip
    b = np.asarray(ankle, dtype=float) - knee
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    return np.arctan2(cross, np.einsum("...i,...i->...", a, b))


def straight_knee_rad(robot: RobotModel, side: str) -> tuple[float, int]:
    """The knee angle [rad] at which the ``side`` leg is straight, and the sign (+1, −1) of the knee
    angle's change that bends it (found from the bend at the knee's two limits, the other joints at 0)."""
    w = robot.wrapper()
    k = robot.legs[side].index[3]
    lo = robot.lower_rad[k] if math.isfinite(robot.lower_rad[k]) else -1.0
    hi = robot.upper_rad[k] if math.isfinite(robot.upper_rad[k]) else 1.0

    def bend(x: float) -> float:
        w.state.q[7:] = 0.0
        w.state.q[7 + k] = x
        w.update_kinematics()
        return float(knee_bend_rad(*leg_points(w, robot, side)))

    b_lo, b_hi = bend(lo), bend(hi)
    if b_hi >= b_lo:
        return float(hi - b_hi), 1
    return float(lo + b_lo), -1


def knee_limits_for_bend(robot: RobotModel, side: str, bend_rad: float) -> tuple[float, float]:
    """The ``side`` knee's angle limits [rad] narrowed so that the leg stays bent by at least
    ``bend_rad`` [rad]."""
    k = robot.legs[side].index[3]
    straight, sign = straight_knee_rad(robot, side)
    lo, hi = float(robot.lower_rad[k]), float(robot.upper_rad[k])
    if sign > 0:
        return max(lo, straight + bend_rad), hi
    return lo, min(hi, straight - bend_rad)
