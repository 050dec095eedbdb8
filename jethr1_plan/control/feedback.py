"""The robot's loop: the plan's commands, corrected by the thrust feedback law its sensors allow and by
the swing-foot placement, from one :class:`~.measurement.Measurement` a tick.

:class:`Controller` is what a robot runs at ``rate_hz``: :meth:`Controller.step` takes the tick's
measurement (the robot's declared sensors, nothing else) and the plan's reference at that tick, and
returns the servo and fan commands. Its parts:

* the thrust law of the robot (``RobotModel.feedback_law``): ``imu_tilt_pid`` (:mod:`.imu_thrust`: the
  trunk's tilt from the IMU; Jet-HR1 as published) or ``cop_edge_pi`` (:mod:`.thrust_feedback`: the
  support sole's centre of pressure from its force sensors, the fan's position from the encoders'
  kinematics, both in the sole's frame), in single support; the planned thrust in double support;
* the swing-foot placement (:mod:`.swing_placement`): the support sole's yaw from the IMU's attitude
  through the encoders' kinematics, at ``PLACEMENT_HZ``;
* the sag of the servos that carry the extra thrust: the swing leg's commands move by J_fanᵀ·ΔF/k
  (ΔF the law's addition as the fans deliver it through their nominal lag, J_fan from the robot's own
  kinematics at the measured joints, k the servos' nominal stiffness).

Single support is the plan's (its row's ``support``), and where the soles are sensed, as the robot
feels it: the support sole carrying more than a fifth of the weight and the swing sole next to nothing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from jethr1_plan.control import thrust_feedback as cop
from jethr1_plan.control.imu_thrust import ImuGains, ImuThrust, imu_law, tilt_error
from jethr1_plan.control.measurement import Command, Kinematics, Measurement, Reference
from jethr1_plan.control.swing_placement import PlacementGains, SwingPlacement, placement_law, yaw_of
from jethr1_plan.geometry import GRAVITY, SIDES, other_side, sole_polygon
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.robot.sensors import LAW_SENSORS

__all__ = ["UNLOADED", "Controller", "Diagnostics", "controller_summary"]

UNLOADED = 0.01  # a sole carrying less than this fraction of the weight is off the ground
PLACEMENT_HZ = 100.0  # the swing-foot placement's rate (its yaw filter's time constant is 50 ms) [Hz]


def controller_summary(robot: RobotModel, thrust_error: float, mass_error: float, thrust_max_n: float) -> dict:
    """The robot's loop as ``summary.json`` states it (``controller``): the law (``law``: its name, None where
    the robot's sensors allow none), the sensors it reads and the robot declares, its signals, gains and
    saturation, and the swing-foot placement where the robot has an IMU."""
    name = robot.feedback_law
    out: dict = {"law": name, "sensors": robot.sensors.describe()}
    if name == "imu_tilt_pid":
        out.update(imu_law(ImuGains.of(robot)))
    elif name == "cop_edge_pi":
        out.update(cop.law(cop.Gains.of(robot), thrust_error, mass_error, thrust_max_n))
        out["sensors_read"] = list(LAW_SENSORS[name])
    else:
        out["description"] = "feed-forward only: the robot declares no sensors a thrust law reads"
    if name is not None and robot.sensors.imu is not None:
        out["swing_placement"] = placement_law(PlacementGains())
    return out


@dataclass
class Diagnostics:
    """What the loop did at its last tick (for the rehearsal's record)."""

    single: bool = False
    error: float = 0.0  # the thrust law's error (CoP law [m], IMU law [rad])
    extra_n: float = 0.0  # the thrust the law added to the plan's [N]


class Controller:
    """The robot's loop (the module docstring). ``law``: ``None`` (the plan's commands alone), or the thrust
    law to run (it must be one the robot's sensors allow). ``compensate``: the plan's commands carry the
    sag and lag compensation (then the law's extra thrust unloads the servos as above)."""

    def __init__(self, robot: RobotModel, kinematics: Kinematics | None, law: str | None, thrust_max_n: float,
                 cop_gains: cop.Gains | None = None, imu_gains: ImuGains | None = None,
                 placement: PlacementGains | None = None, compensate: bool = True) -> None:
        if law is not None:
            missing = [s for s in LAW_SENSORS[law] if s not in robot.sensors.names]
            if missing:
                raise ValueError(f"{law} needs the robot's {' and '.join(missing)}")
            if kinematics is None:
                raise ValueError("a feedback law needs the robot's kinematics")
        self.robot, self.kin, self.law_name, self.compensate = robot, kinematics, law, compensate
        self.cop_gains = cop_gains or cop.Gains.of(robot)
        self.imu_gains = imu_gains or ImuGains.of(robot)
        self.rate_hz = self.imu_gains.rate_hz if law == "imu_tilt_pid" else self.cop_gains.rate_hz
        self.cop_law = cop.ThrustFeedback(self.cop_gains)
        self.imu_law = ImuThrust(self.imu_gains)
        self.placing = law is not None and robot.sensors.imu is not None
        self.place = SwingPlacement(placement or PlacementGains(), len(robot.joint_names))
        self.caps = np.array([min(f.thrust_max_n, thrust_max_n) for f in robot.fans])
        self.lag = np.array([f.lag_s for f in robot.fans])
        self.lag_step = np.minimum(1.0, 1.0 / (self.rate_hz * self.lag))  # a tick's share of each fan's lag
        self.stiffness = robot.servo_stiffness_nm_per_rad
        self.legs = {s: np.array(robot.legs[s].index) for s in SIDES}
        self.weight_n = GRAVITY * robot.mass_kg
        self.extra = np.zeros(len(robot.fans))  # the law's addition as the fans deliver it (nominal lag) [N]
        self.place_every = max(1, round(self.rate_hz / PLACEMENT_HZ))  # the placement's ticks
        self.tick = 0
        self.polygon = sole_polygon(np.zeros(2), 0.0, robot.sole_length_m, robot.sole_width_m)
        self.last = Diagnostics()
        self._pose_at: tuple[np.ndarray, np.ndarray] | None = None  # the tick's pose, not yet given to ``kin``

    def _single(self, m: Measurement, support: str) -> bool:
        if support == "both":
            return False
        if m.soles is None:
            return True
        return (m.soles[support].force_n > 0.2 * self.weight_n
                and m.soles[other_side(support)].force_n < UNLOADED * self.weight_n)

    def _posed(self) -> Kinematics:
        """The robot's kinematics posed at this tick's encoders and IMU attitude (posed once a tick, on first use:
        a tick that needs no pose, as most of double support, poses nothing)."""
        assert self.kin is not None
        if self._pose_at is not None:
            self.kin.update(*self._pose_at)
            self._pose_at = None
        return self.kin

    def step(self, m: Measurement, ref: Reference) -> Command:
        """The commands of one tick from its measurement and the plan's reference."""
        q = np.array(ref.q_cmd, dtype=float)
        ff = np.array(ref.thrust_cmd, dtype=float)
        if self.law_name is None or not ref.active:
            self.last = Diagnostics()
            return Command(q, ff)
        assert self.kin is not None and m.joints_rad is not None
        # the robot's own kinematics, posed at this measurement when first asked this tick (:meth:`_posed`)
        self._pose_at = (
            m.joints_rad, m.trunk_rotation if m.trunk_rotation is not None else np.eye(3))
        sup = ref.support
        single = self._single(m, sup)
        thrust = ff.copy()
        error = 0.0
        if single:
            # the law acts on the total thrust of the fans that carry it, in their planned shares; without
            # planned thrust, on the swing sole's first fan. Its saturation: the whole thrust the fans are given
            total_ff = float(ff.sum())
            carry = ((ff > 0).nonzero()[0] if total_ff > 0
                     else np.array(self.robot.swing_fans(other_side(sup))[:1], dtype=int))
            share = ff[carry] / total_ff if total_ff > 0 else np.ones(len(carry))
            if len(carry):
                top = float((self.caps[carry] / share).min())
                if self.law_name == "cop_edge_pi":
                    assert m.soles is not None
                    kin = self._posed()
                    p_s, r_s = kin.sole(sup)
                    fan = sum(share[n] * kin.fan(int(f)) for n, f in enumerate(carry))
                    fan_xy = (r_s.T @ (fan - p_s))[:2]  # in the support sole's frame
                    total = self.cop_law.step(m.soles[sup].cop_m, fan_xy, self.polygon, float(ff[carry].sum()), top)
                    error = self.cop_law.last_error_m
                else:
                    assert m.trunk_rotation is not None and m.trunk_rate_rad_s is not None
                    fan_xy = sum(share[n] * ref.fans_m[int(f), :2] for n, f in enumerate(carry))
                    toward = fan_xy - ref.feet_m[SIDES.index(sup), :2]
                    e, de = tilt_error(m.trunk_rotation, m.trunk_rate_rad_s, ref.trunk_rotation, toward)
                    total = self.imu_law.step(e, de, float(ff[carry].sum()), top)
                    error = e
                thrust[carry] = share * total
        else:
            self.cop_law.idle()
            self.imu_law.idle()
        if self.placing:
            self.tick += 1
            if single and self.tick % self.place_every == 0:
                # the support sole's yaw: the IMU's attitude through the encoders' kinematics
                sw = other_side(sup)
                si, wi = SIDES.index(sup), SIDES.index(sw)
                kin = self._posed()
                _, r_sup = kin.sole(sup)
                lever = ref.feet_m[wi, :2] - ref.feet_m[si, :2]
                dt = self.place_every / self.rate_hz
                self.place.step(yaw_of(r_sup), float(ref.feet_yaw_rad[si]), lever,
                                kin.sole_jacobian(sw, self.legs[sw]), self.legs[sw], dt)
                self.place.release(self.legs[sup], dt)
            q += self.place.offset
        # the thrust the law adds, as the robot estimates the fans deliver it (their nominal lag): the servos
        # that carry it unload, so their sag compensation follows (q_cmd − J_fanᵀ·ΔF/k)
        self.extra += (thrust - ff - self.extra) * self.lag_step
        if self.compensate:
            for f in (np.abs(self.extra) > 1e-6).nonzero()[0].tolist():
                q -= self._posed().fan_lift_jacobian(int(f)) * self.extra[f] / self.stiffness
        self.last = Diagnostics(single, error, float((thrust - ff).sum()))
        return Command(q, thrust)
