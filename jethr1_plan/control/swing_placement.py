"""Swing-foot placement: the swing leg's servo commands corrected for the yaw the support sole has
slipped by, measured through the robot's own sensors, so that the swing sole lands where the plan
puts it in the world.

Why (docs/rehearsal.md, "Why the landing missed its carton", measures it on the twin): the support sole
pivots a little in yaw on its carton while the other leg swings, and the joint commands place the swing
sole relative to the support sole: a yaw ψ of the support sole moves a landing d ahead of it sideways by
d·ψ, which a carton only a little wider than the sole does not forgive.

What a robot of this kind measures, and what the law uses:

* the joint encoders (the servos' output angles): forward kinematics gives the swing sole's pose
  relative to the support sole, sag included;
* the IMU's orientation of the trunk (its yaw integrated from the gyro, whose drift over a plan's
  duration the robot YAML bounds: ``sensors.imu.yaw_drift_rad_s``): with the encoders, the
  support sole's orientation in the world, so its yaw slip;
* not the support sole's slip along the ground (no sensor sees it): the estimate assumes the support
  sole's centre stays where the plan put it.

A loop that drove the estimated swing sole pose (from the support sole through encoders and IMU)
to the planned one with an integrator oscillated in x on the twin and fell (the trunk pitches with
the leg it moves); the law corrects instead only what is measured
to have moved: the support sole's yaw. With ψ the measured yaw of the support sole, ψ_plan its
planned yaw and δψ = ψ − ψ_plan (low-passed over ``filter_s``), the plan's landing seen from the
pivoted support sole lies turned by δψ about the support sole's centre s, so the swing sole is
moved back by

    Δp = −δψ · ẑ × (w − s)     (horizontal),     Δψ_swing = −δψ
    Δq = J⁺ · (Δp_x, Δp_y, 0, 0, 0, Δψ_swing)

with w the swing sole's planned position at the row, J the swing sole's world position and
orientation rates per swing-leg joint (damped least squares: the sole keeps its height and tilt)
and Δq added to the swing leg's servo commands. The
offset is set every tick of single support (no integrator in a loop with the servos and the
trunk) and held, not reset, once the sole lands (the relative pose the legs then hold is the
corrected one). Each component is clipped to ``max_offset_rad``. Pure numpy; units SI.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["PlacementGains", "SwingPlacement", "placement_law", "wrap", "yaw_of"]


@dataclass(frozen=True)
class PlacementGains:
    """The placement law's settings (SI units)."""

    filter_s: float = 0.05  # time constant of the low-pass on the measured yaw slip [s]
    damping: float = 0.01  # damped least squares: λ² added to J·Jᵀ [m² or rad²]
    max_offset_rad: float = 0.15  # each joint's offset is clipped to ± this [rad]
    release_s: float = 0.2  # a support leg lets go of its offset (from its own swing) with this time constant [s]


def placement_law(gains: PlacementGains) -> dict:
    """The placement law as ``summary.json`` states it (its ``controller.swing_placement``): signals, correction,
    settings with units."""
    return {
        "kind": "support_yaw_slip",
        "signal": "the support sole's yaw in the world [rad]: the trunk's IMU orientation through the support "
                  "leg's joint encoders",
        "correction": "the swing leg's <joint>_cmd_rad moved by J⁺·(Δp_x, Δp_y, 0, 0, 0, −δψ), Δp = −δψ·ẑ×(w − s): "
                      "the planned landing turned back about the support sole's centre by its measured yaw slip δψ",
        "settings": asdict(gains),
        "active": "single support; the last offset held after the landing",
        "description": " ".join(__doc__.split("\n\n")[0].split()),
    }


def yaw_of(R: np.ndarray) -> float:
    """Yaw [rad] of a 3×3 rotation matrix (or its 9 entries, row-major): the heading of its x axis."""
    r = np.asarray(R, dtype=float).reshape(3, 3)
    return math.atan2(float(r[1, 0]), float(r[0, 0]))


def wrap(angle_rad: float) -> float:
    """An angle wrapped to [−π, π) [rad]."""
    return (angle_rad + math.pi) % (2 * math.pi) - math.pi


class SwingPlacement:
    """The law with its state (the filtered yaw slip and one offset per joint of the robot), as a
    robot's loop runs it: :meth:`step` every tick of single support."""

    def __init__(self, gains: PlacementGains, n_joints: int) -> None:
        self.gains = gains
        self.offset = np.zeros(n_joints)  # added to the servo commands [rad]
        self.slip_rad: float | None = None  # the filtered yaw slip of the support sole [rad]

    def step(self, support_yaw_rad: float, support_yaw_plan_rad: float, lever_m: np.ndarray,
             jacobian: np.ndarray, joints: np.ndarray, dt_s: float) -> np.ndarray:
        """One tick: the support sole's measured and planned yaw [rad], ``lever_m`` the swing sole's
        planned position minus the support sole's planned centre (x, y) [m], ``jacobian`` (6,
        len(joints)) of the swing sole's world position [m] and orientation [rad] per swing-leg joint
        (``joints``: indices into the offset). Returns the offset [rad]."""
        slip = wrap(support_yaw_rad - support_yaw_plan_rad)
        if self.slip_rad is None:
            self.slip_rad = slip
        else:
            self.slip_rad += (slip - self.slip_rad) * min(1.0, dt_s / self.gains.filter_s)
        d = self.slip_rad
        top = self.gains.max_offset_rad
        target = np.array([d * float(lever_m[1]), -d * float(lever_m[0]), 0.0, 0.0, 0.0, -d])
        J = np.asarray(jacobian, dtype=float)
        lam = self.gains.damping
        dq = J.T @ np.linalg.solve(J @ J.T + lam * lam * np.eye(len(J)), target)
        self.offset[joints] = np.clip(dq, -top, top)
        return self.offset

    def release(self, joints: np.ndarray, dt_s: float) -> None:
        """One tick of letting go of the offset of ``joints`` (the support leg's: the offset it was given
        when it last swung, held through its landing), with the time constant ``release_s``: a support
        leg that keeps it turns the trunk, and the swing sole with it, about the sole it stands on."""
        self.offset[joints] *= max(0.0, 1.0 - dt_s / self.gains.release_s)
