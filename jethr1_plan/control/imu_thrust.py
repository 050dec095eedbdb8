"""The IMU thrust law: the planned thrust corrected by a PID on the trunk's tilt towards the fan, as
Paper A's robot ran it ("the thrust was controlled by a proportional–integral–derivative controller
according to the feedback of the body's IMU", Sec. IV-C). It needs a trunk IMU and joint encoders
only: what Jet-HR1 carries.

Why the tilt: in single support the robot is a body on a sole, balanced by the swing fan's thrust F
about the support sole's edges (A-1, A-2). When it starts to tip towards the fan's side (too little
thrust, a heavier robot, servos that sag more than the plan's commands assume) the trunk leans that
way, and more thrust rights it; leaning away, less. With u the horizontal unit vector from the planned
support sole centre to the planned fan, z the trunk's measured up axis and z* the planned one,

    e     = (z − z*)·u                       the tilt towards the fan [rad] (small angles)
    ė     = ((R·ω) × z)·u                    its rate from the gyro ω (body frame) [rad/s]
    I     ← I + e·dt   (not while the command is saturated against e); I ← I·(1 − dt/τ_leak) in double support
    F_cmd = clip(F_plan + k_p·e + k_i·I + k_d·ė,  0,  F_top)

with F_plan the plan's fan command and F_top the thrust the fans are given. A tilt of the support
leg's servos (their sag beyond the plan's compensation) reads as a tilt too: the law then rights the
trunk with thrust, which holds the swing sole where the plan's kinematics put it (measured on the
twin: docs/rehearsal.md). The gains are the robot's (its YAML's ``controller.imu_tilt_pid``), tuned
on the twin (``bench/tune_controller.py``). Pure numpy; SI units.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["ImuGains", "ImuThrust", "imu_law", "tilt_error"]


@dataclass(frozen=True)
class ImuGains:
    """The IMU law's settings (SI units)."""

    rate_hz: float = 500.0  # loop rate [Hz]
    kp_n_per_rad: float = 300.0  # [N/rad]
    ki_n_per_rad_s: float = 300.0  # [N/(rad·s)]
    kd_n_s_per_rad: float = 30.0  # [N·s/rad]
    leak_time_s: float = 0.3  # the integral's decay time in double support [s]

    @classmethod
    def of(cls, robot) -> ImuGains:
        """The robot YAML's ``controller.rate_hz`` and ``controller.imu_tilt_pid`` over the defaults."""
        rate = robot.controller.rate_hz
        return cls(**({"rate_hz": rate} if rate is not None else {}), **robot.controller.imu_tilt_pid.given())


def imu_law(gains: ImuGains) -> dict:
    """The law as ``summary.json`` states it: its signals, gains and saturation, with units."""
    return {
        "kind": "imu_tilt_pid",
        "sensors_read": ["imu", "encoders"],
        "signal": "the trunk's tilt towards the swing fan from the IMU's attitude [rad], its rate from the gyro "
                  "[rad/s]",
        "reference": "the planned trunk attitude; the direction from the planned support sole to the planned fan",
        "gains": asdict(gains),
        "saturation": {"lower": "0",
                       "upper": "least of each carrying fan's thrust_max_n and the scenario's balance.thrust_max_n"},
        "active": "single support; in double support the planned thrust, the integral leaking away",
        "description": " ".join(__doc__.split("\n\n")[0].split()),
    }


def tilt_error(rotation: np.ndarray, rate_body: np.ndarray, planned: np.ndarray, toward_xy: np.ndarray
               ) -> tuple[float, float]:
    """(e [rad], ė [rad/s]): the trunk's tilt towards the horizontal direction ``toward_xy`` beyond the
    planned attitude, and its rate from the gyro ``rate_body`` (body frame)."""
    ux, uy = float(toward_xy[0]), float(toward_xy[1])
    norm = math.hypot(ux, uy)
    if norm < 1e-9:
        return 0.0, 0.0
    ux, uy = ux / norm, uy / norm
    R = np.asarray(rotation, dtype=float)
    z = R[:, 2]
    e = (float(z[0]) - float(planned[0][2])) * ux + (float(z[1]) - float(planned[1][2])) * uy
    wx, wy, wz = (R @ np.asarray(rate_body, dtype=float)).tolist()
    zx, zy, zz = z.tolist()
    # (w × z) in x and y, along u
    return e, (wy * zz - wz * zy) * ux + (wz * zx - wx * zz) * uy


class ImuThrust:
    """The law with its state (the integral), as a robot's loop runs it: :meth:`step` every tick of single
    support, :meth:`idle` every tick of double support."""

    def __init__(self, gains: ImuGains) -> None:
        self.gains = gains
        self.integral = 0.0  # ∫e dt [rad·s]
        self.last_error_rad = 0.0

    def idle(self) -> None:
        g = self.gains
        self.integral *= max(0.0, 1.0 - 1.0 / (g.rate_hz * g.leak_time_s))
        self.last_error_rad = 0.0

    def step(self, e: float, de: float, thrust_plan_n: float, upper_n: float, lower_n: float = 0.0) -> float:
        """The total thrust command [N] of the fans that carry it, from the tilt ``e`` [rad] and its rate
        ``de`` [rad/s]."""
        g = self.gains
        self.last_error_rad = e
        raw = thrust_plan_n + g.kp_n_per_rad * e + g.ki_n_per_rad_s * self.integral + g.kd_n_s_per_rad * de
        out = min(max(raw, lower_n), upper_n)
        if out == raw or (raw > upper_n and e < 0) or (raw < lower_n and e > 0):
            self.integral += e / g.rate_hz  # anti-windup: no integration against a saturated command
        return out
