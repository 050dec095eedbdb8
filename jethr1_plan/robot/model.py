"""The robot model: the typed dataclasses a loaded robot is (:class:`RobotModel`, its legs, fans and settings),
and the leg and fan geometry every planner shares. :mod:`.load` reads the URDF (checked by :mod:`.urdf`,
loaded by PlaCo) and the robot YAML beside it (checked by :mod:`.schema`) into them.

Everything reported about a robot (mass, height, leg length, joints, fans) is computed from the
loaded model, never copied from the YAML. Frames and joint names follow docs/robots.md.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from jethr1_plan.robot.sensors import LAW_SENSORS, Sensors

__all__ = [
    "SOLE_FRICTION",
    "ControllerSettings",
    "Fan",
    "ImuLawSettings",
    "Leg",
    "RobotModel",
    "TwinSettings",
    "WalkingStructure",
    "fan_ground_xy",
    "reach_centre",
]


def reach_centre(legs, side: str, foot_xyz: np.ndarray, trunk_yaw) -> np.ndarray:
    """Centre [m] of the ball of trunk positions from which the ``side`` leg reaches its ankle.

    The hip sits at trunk + s·w·(−sin γ, cos γ, 0) (s = +1 left, −1 right, w the hip offset, γ the
    trunk yaw) and reaches a flat foot's ankle (sole + ankle height) when ‖hip − ankle‖ ≤ thigh +
    shank: the trunk must lie within that distance of ankle − s·w·(−sin γ, cos γ, 0).

    Args:
        legs: anything with ``hip_offset_m`` and ``ankle_height_m`` (a RobotModel, a LegGeometry).
        foot_xyz: (3,) or (N, 3) sole centre(s) [m]; trunk_yaw: scalar or (N,) [rad].
    Returns:
        (3,) or (N, 3) [m], broadcast over the inputs.
    """
    sgn = 1.0 if side == "left" else -1.0
    yaw = np.asarray(trunk_yaw, dtype=float)
    offset = np.stack([-np.sin(yaw), np.cos(yaw), np.zeros_like(yaw)], axis=-1) * (sgn * legs.hip_offset_m)
    return np.asarray(foot_xyz, dtype=float) + np.array([0.0, 0.0, legs.ankle_height_m]) - offset


def fan_ground_xy(fan: Fan, soles: dict[str, np.ndarray], p_body: np.ndarray, yaw_rad: np.ndarray | float
                  ) -> np.ndarray:
    """Where a fan's vertical thrust meets the ground [m] (..., 2): its sole's centre plus its offset
    (the soles are flat and face +x), or for a trunk fan P_body plus its offset turned by the trunk yaw.

    Args:
        soles: the sole centres by side [m] ((3,) or (..., 3)); p_body: (..., 3) [m]; yaw_rad: (...,) [rad].
    """
    off = np.asarray(fan.offset_m[:2], dtype=float)
    if fan.leg is not None:
        return np.asarray(soles[fan.leg], dtype=float)[..., :2] + off
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    turned = np.stack([c * off[0] - s * off[1], s * off[0] + c * off[1]], axis=-1)
    return np.asarray(p_body, dtype=float)[..., :2] + turned


SOLE_FRICTION = 0.8  # μ of a sole on the ground unless the robot YAML's twin.sole_friction says otherwise


@dataclass(frozen=True)
class Leg:
    """One leg as the robot YAML names it: its sole frame and its six joints by role (:data:`LEG_ROLES`)."""

    side: str  # 'left' or 'right'
    sole: str  # frame at the sole centre on the ground plane, x forward, z up
    joints: tuple[str, ...]  # the six joint names, hip yaw to ankle roll
    index: tuple[int, ...]  # their positions in RobotModel.joint_names (and in every q vector)


@dataclass(frozen=True)
class Fan:
    """A ducted fan: ``frame`` is the thrust point, fixed to ``mount`` (a sole frame or the trunk).

    A fan on a sole thrusts while that foot swings (and ramps in the double support around the
    swing), never while its foot alone carries the robot; a fan on the trunk may thrust at any
    time. Thrust is vertical (Paper A, III-A).
    """

    name: str  # the fan's name in the CSV columns (thrust_<name>_n) and messages
    frame: str
    mount: str  # the frame it is fixed to: a leg's sole frame or the trunk frame
    leg: str | None  # the side whose sole carries it, or None on the trunk
    thrust_max_n: float
    offset_m: tuple[float, float, float]  # thrust point in the mount frame [m]
    lag_s: float = 0.05  # time constant of the thrust's first-order response to a command [s]

    @property
    def on_trunk(self) -> bool:
        return self.leg is None


@dataclass(frozen=True)
class WalkingStructure:
    """What Paper B's walking uses beyond the legs (the robot YAML's ``walking:``; all optional).

    Without a waist the pelvic rotation is the trunk's own yaw (both hip yaws turning together);
    without arm-swing joints the yaw momentum is not compensated.
    """

    waist_yaw: str | None = None  # the joint between the pelvis (the trunk) and the torso (B-6's q_WY)
    torso: str | None = None  # the frame that keeps facing the walk while the pelvis turns
    arm_swing: tuple[str, ...] = ()  # the joints of the arm-swing QP (B-43's q_up)
    arm_home_rad: tuple[tuple[str, float], ...] = ()  # the arms' initial pose (B-43's q_up^init) [rad]
    com_height_m: float | None = None  # the LIPM's z_c a walk uses unless it states its own [m]


@dataclass(frozen=True)
class ImuLawSettings:
    """The robot YAML's ``controller.imu_tilt_pid``: the IMU thrust law's gains (SI units); None where the
    YAML leaves the law's default (``control.imu_thrust.ImuGains``)."""

    kp_n_per_rad: float | None = None  # proportional gain on the trunk's tilt towards the fan [N/rad]
    ki_n_per_rad_s: float | None = None  # integral gain [N/(rad·s)]
    kd_n_s_per_rad: float | None = None  # derivative gain, on the gyro's rate [N·s/rad]
    leak_time_s: float | None = None  # the integral's decay time in double support [s]

    def given(self) -> dict[str, float]:
        """The settings the YAML gives."""
        return {k: v for k, v in asdict(self).items() if v is not None}


@dataclass(frozen=True)
class ControllerSettings:
    """The robot YAML's ``controller:``: which thrust feedback law the robot runs (``law``, None: the one
    its sensors allow, :meth:`RobotModel.feedback_law`), the loop rate, the centre-of-pressure law's
    settings (flat, as before the IMU law: ``control.thrust_feedback.Gains``) and the IMU law's
    (``imu_tilt_pid``); None where the YAML leaves a default. SI units."""

    rate_hz: float | None = None  # loop rate [Hz]
    band_margin_m: float | None = None  # how close to the sole's edge the CoP may come [m]
    kp_n_per_m: float | None = None  # proportional gain [N/m]
    ki_n_per_m_s: float | None = None  # integral gain [N/(m·s)]
    leak_time_s: float | None = None  # the integral's decay time inside the band [s]
    law: str | None = None  # imu_tilt_pid | cop_edge_pi
    imu_tilt_pid: ImuLawSettings = ImuLawSettings()

    def given(self) -> dict[str, float]:
        """The centre-of-pressure law's settings (and the rate) the YAML gives."""
        return {k: v for k, v in asdict(self).items() if v is not None and k not in ("law", "imu_tilt_pid")}


@dataclass(frozen=True)
class TwinSettings:
    """The robot YAML's ``twin:``: contact settings of the MuJoCo twin (SI units); None where the YAML
    leaves the twin's default (``sim.twin.TwinParams``)."""

    timestep_s: float | None = None  # [s]
    sole_friction: float | None = None  # Coulomb friction of the soles
    sole_thickness_m: float | None = None  # [m]

    def given(self) -> dict[str, float]:
        """The settings the YAML gives."""
        return {k: v for k, v in asdict(self).items() if v is not None}


@dataclass(frozen=True, eq=False)  # identity hash: models are cached by load_robot
class RobotModel:
    """A loaded robot: the URDF path and what the YAML adds, with figures read from PlaCo.

    Arrays over joints follow ``joint_names`` (the URDF's actuated joints in PlaCo's order).
    """

    name: str
    urdf_path: Path
    yaml_path: Path
    mass_kg: float
    trunk: str  # the root link: its origin is P_body, the midpoint of the hip joint centres
    legs: dict[str, Leg]  # 'left' and 'right'
    joint_names: tuple[str, ...]
    lower_rad: np.ndarray  # (J,)
    upper_rad: np.ndarray  # (J,)
    effort_nm: np.ndarray  # (J,) URDF effort limits
    servo_limit_nm: np.ndarray  # (J,) from the YAML's servo table
    fans: tuple[Fan, ...]
    sole_length_m: float
    sole_width_m: float
    stance_width_m: float  # between the sole centres when standing (a scenario's default start)
    hip_offset_m: float  # trunk origin -> each hip joint centre, along the trunk y axis
    thigh_m: float  # hip joint centre -> knee axis
    shank_m: float  # knee axis -> ankle joint centre
    ankle_height_m: float  # ankle joint centre -> sole
    leg_length_m: float  # hip joint centre -> sole, legs straight
    height_m: float  # sole -> top of the highest geometry, standing straight
    servo_stiffness_nm_per_rad: np.ndarray  # (J,) the twin's position servos: servos × stiffness × gear²
    servo_damping_nms_per_rad: np.ndarray  # (J,) stiffness × derivative time
    armature_kgm2: float  # rotor inertia reflected through each joint's gearbox
    controller: ControllerSettings  # the thrust feedback law's settings (control.thrust_feedback.Gains)
    twin: TwinSettings  # contact settings of the twin (sim.twin.TwinParams)
    walking: WalkingStructure = WalkingStructure()
    sensors: Sensors = Sensors()  # noqa: RUF009 (frozen)  what the robot measures (none declared: feed-forward only)
    #: how far a landing executed step by step in the twin comes from its foothold (the YAML's
    #: ``execution.landing_error_m``: measured, the 99th percentile over randomised trials) [m]; None: not measured
    landing_error_m: float | None = None

    @property
    def feedback_law(self) -> str | None:
        """The thrust feedback law the robot runs: the YAML's ``controller.law``, else the IMU law where
        the robot has an IMU and encoders, else the CoP law where its soles are sensed, else None."""
        if self.controller.law is not None:
            return self.controller.law
        have = set(self.sensors.names)
        return next((law for law, need in LAW_SENSORS.items() if have >= set(need)), None)

    @property
    def leg_index(self) -> np.ndarray:
        """(12,) positions in ``joint_names`` of the left leg's six joints, then the right's, by role."""
        return np.array([*self.legs["left"].index, *self.legs["right"].index], dtype=np.int64)

    def fans_on(self, side: str) -> tuple[Fan, ...]:
        """The fans fixed to the ``side`` sole."""
        return tuple(f for f in self.fans if f.leg == side)

    @property
    def trunk_fans(self) -> tuple[Fan, ...]:
        return tuple(f for f in self.fans if f.on_trunk)

    def swing_fans(self, swing: str) -> tuple[int, ...]:
        """Positions in ``fans`` of the fans that may thrust while the ``swing`` foot swings: those on
        its sole, then those on the trunk."""
        return tuple(i for i, f in enumerate(self.fans) if f.leg == swing) + tuple(
            i for i, f in enumerate(self.fans) if f.on_trunk)

    @property
    def sole_friction(self) -> float:
        """μ of the soles on the ground: the YAML's ``twin.sole_friction`` (default :data:`SOLE_FRICTION`)."""
        return SOLE_FRICTION if self.twin.sole_friction is None else float(self.twin.sole_friction)

    def fan_for(self, side: str) -> Fan | None:
        """The (first) fan on the ``side`` sole, or None: the fan Paper A's body yaw (A-4) points at."""
        fans = self.fans_on(side)
        return fans[0] if fans else None

    def start_feet(self) -> dict[str, np.ndarray]:
        """Both sole centres [m] standing at the origin, ``stance_width_m`` apart, facing +x."""
        half = self.stance_width_m / 2
        return {"left": np.array([0.0, half, 0.0]), "right": np.array([0.0, -half, 0.0])}

    def wrapper(self):
        """A PlaCo RobotWrapper of this model that nobody else holds, in the state a new one has (kept for reuse
        within the process: :mod:`.wrappers`; PlaCo objects cannot be shared between processes or pickled)."""
        from jethr1_plan.robot.wrappers import hand_out

        return hand_out(self.urdf_path)
