"""The robot model: the URDF (checked by :mod:`.urdf`, loaded by PlaCo) and the robot YAML beside it
(checked by :mod:`.schema`), as typed dataclasses.

Everything reported about a robot (mass, height, leg length, joints, fans) is computed from the
loaded model, never copied from the YAML. Frames and joint names follow docs/robots.md.
"""

from __future__ import annotations

import functools
import math
import os
import re
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from jethr1_plan.errors import InputError, RobotModelError
from jethr1_plan.geometry import SIDES
from jethr1_plan.io.yaml_input import read_document
from jethr1_plan.robot.schema import LEG_ROLES, read_robot_yaml
from jethr1_plan.robot.urdf import UrdfJoint, check_urdf, geometry_boxes, quiet_stderr, urdf_joints

__all__ = [
    "LAW_SENSORS",
    "LEG_ROLES",
    "ROBOTS_DIR",
    "SOLE_FRICTION",
    "ControllerSettings",
    "EncoderSpec",
    "Fan",
    "ImuLawSettings",
    "ImuSpec",
    "Leg",
    "RobotModel",
    "Sensors",
    "SoleSensorSpec",
    "TwinSettings",
    "UrdfJoint",
    "WalkingStructure",
    "build_with_robot",
    "fan_ground_xy",
    "forget_robots",
    "load_robot",
    "reach_centre",
    "urdf_joints",
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


def _robots_dir() -> Path:
    """The shipped robot models: the installed package data ``jethr1_plan.robots`` (a wheel, an
    editable install), else the checkout's ``robots/``."""
    try:
        from importlib.resources import files

        found = Path(str(files("jethr1_plan.robots")))
        if found.is_dir():
            return found
    except (ModuleNotFoundError, TypeError, ValueError):
        pass
    return Path(__file__).resolve().parents[1] / "robots"


ROBOTS_DIR = _robots_dir()
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
    max_thrust_n: float
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
class ImuSpec:
    """An IMU on the trunk (the robot YAML's ``sensors.imu``): what it measures is the trunk's attitude
    (roll, pitch from gravity; yaw integrated from the gyro) and angular rate; SI units. Noise is white
    (1 σ per sample); a bias is constant over a run, drawn within ± the bound by randomised trials."""

    frame: str  # the frame it is fixed to (the trunk)
    attitude_noise_rad: float = 0.0  # [rad] 1 σ on roll and pitch (and yaw)
    attitude_bias_rad: float = 0.0  # [rad] bound of the roll and pitch bias
    rate_noise_rad_s: float = 0.0  # [rad/s] 1 σ per axis
    rate_bias_rad_s: float = 0.0  # [rad/s] bound of the gyro's bias per axis
    yaw_drift_rad_s: float = 0.0  # [rad/s] bound of the heading's drift (the gyro's z bias, integrated)
    delay_s: float = 0.0  # [s] from the motion to the reading


@dataclass(frozen=True)
class EncoderSpec:
    """The joints' encoders (``sensors.encoders``): each servo's output angle; SI units."""

    noise_rad: float = 0.0  # [rad] 1 σ per sample
    resolution_rad: float = 0.0  # [rad] the reading is a multiple of this (0: continuous)
    offset_rad: float = 0.0  # [rad] bound of each joint's zero offset (calibration), drawn by randomised trials
    delay_s: float = 0.0  # [s]


@dataclass(frozen=True)
class SoleSensorSpec:
    """Force sensors under each sole (``sensors.soles``): the normal force and its centre of pressure in the
    sole's frame; SI units."""

    force_noise_n: float = 0.0  # [N] 1 σ
    cop_noise_m: float = 0.0  # [m] 1 σ per axis
    delay_s: float = 0.0  # [s]


@dataclass(frozen=True)
class Sensors:
    """What the robot measures (the robot YAML's ``sensors:``): the twin's controllers see the robot only
    through these (``sim.sensors``). ``perception_error_m``: how well the robot knows where the next
    foothold lies relative to its support sole when it plans a step from where it stands (a person or a
    camera measuring the cartons) [m], a bound."""

    imu: ImuSpec | None = None
    encoders: EncoderSpec | None = None
    soles: SoleSensorSpec | None = None
    perception_error_m: float = 0.0

    @property
    def names(self) -> tuple[str, ...]:
        """The sensors present, by name: ``imu``, ``encoders``, ``soles``."""
        return tuple(n for n in ("imu", "encoders", "soles") if getattr(self, n) is not None)

    def describe(self) -> dict:
        """The declaration as ``summary.json`` and ``simulation.json`` state it (SI units)."""
        return {"imu": None if self.imu is None else asdict(self.imu),
                "encoders": None if self.encoders is None else asdict(self.encoders),
                "soles": None if self.soles is None else asdict(self.soles),
                "perception": {"landing_error_m": self.perception_error_m}}


#: what each thrust law reads (``controller.law``): the sensors it needs
LAW_SENSORS = {"imu_tilt_pid": ("imu", "encoders"), "cop_edge_pi": ("soles", "encoders")}


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
    sensors: Sensors = Sensors()  # what the robot measures (none declared: only feed-forward runs)
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
        """A new PlaCo RobotWrapper for this model (PlaCo objects cannot be shared or pickled)."""
        import placo

        return placo.RobotWrapper(str(self.urdf_path), placo.Flags.ignore_collisions)


def _resolve(name_or_path: str | Path) -> Path:
    if not str(name_or_path).strip():
        raise RobotModelError(str(name_or_path), "robot", "empty: expected a robot's name (a folder of robots/), "
                              "a folder or a robot YAML")
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") and os.path.lexists(p):
        return p  # (read as a regular file, or refused as what it is: io.input_file)
    if p.is_dir():
        cands = sorted(p.glob("*.yaml"))
        if len(cands) == 1:
            return cands[0]
        raise RobotModelError(str(p), "", "expected exactly one robot YAML in the directory")
    d = ROBOTS_DIR / str(name_or_path)
    if d.is_dir() and (d / f"{name_or_path}.yaml").is_file():
        return d / f"{name_or_path}.yaml"
    known = ", ".join(sorted(x.name for x in ROBOTS_DIR.iterdir() if x.is_dir())) if ROBOTS_DIR.is_dir() else ""
    raise RobotModelError(str(name_or_path), "robot", f"unknown robot (known: {known or 'none'})")


def _geometry_height(urdf: Path, robot, soles: list[str]) -> float:
    """Top of the URDF's visual boxes and cylinders over the lowest sole, at the zero posture [m]."""
    robot.state.q[7:] = 0.0
    robot.update_kinematics()
    z_sole = min(robot.get_T_world_frame(s)[2, 3] for s in soles)
    top = -math.inf
    corners = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=float)
    for link, xyz, half in geometry_boxes(urdf):
        T_link = robot.get_T_world_frame(link)
        world = (T_link[:3, :3] @ (xyz + half * corners).T).T + T_link[:3, 3]
        top = max(top, float(world[:, 2].max()))
    return top - z_sole


def load_robot(name_or_path: str | Path | RobotModel = "jethr1") -> RobotModel:
    """Load a robot by name (a folder of ``robots/``), directory or YAML path; a model is returned as is.

    Models are cached by their YAML file: loading a robot by name and then by its YAML's path (as a plan
    folder's summary names it) gives the same object, loaded once.

    Raises:
        RobotModelError: missing, malformed or inconsistent files (exit 2): the YAML against its
            schema (:mod:`.schema`), the URDF against its checks (:mod:`.urdf`), then the two together.
    """
    if isinstance(name_or_path, RobotModel):
        return name_or_path
    return _load(_resolve(name_or_path))


def forget_robots() -> None:
    """Forget every robot loaded so far (the caches of :func:`load_robot`, of PlaCo's models and of the URDF
    checks, all keyed by file path): for a process that loads robots from folders it then removes, so that a
    later folder at the same path is read afresh."""
    _load.cache_clear()
    _placo_robot.cache_clear()
    check_urdf.cache_clear()


@functools.lru_cache(maxsize=16)
def _load(yaml_path: Path) -> RobotModel:
    src = str(yaml_path)
    doc = read_robot_yaml(yaml_path)
    urdf = yaml_path.parent / doc["urdf"]
    if not os.path.lexists(urdf):
        raise RobotModelError(src, "urdf", f"no such file {urdf}")
    checked = check_urdf(urdf.resolve())
    robot = _placo_robot(str(urdf))
    model = robot.model
    names = tuple(model.names[2:])
    frames = set(_frame_names(robot))
    if abs(float(robot.total_mass()) - checked.total_mass_kg) > 1e-9 * max(1.0, checked.total_mass_kg):
        raise RobotModelError(str(urdf), "", f"PlaCo reads {float(robot.total_mass()):.6g} kg, the links' masses add "
                              f"up to {checked.total_mass_kg:.6g} kg: a link's inertial was not read")
    trunk = doc["trunk"]
    if checked.root != trunk:
        raise RobotModelError(src, "trunk", f"{trunk!r} is not the URDF's root link (the root is {checked.root!r})")
    legs = {side: _leg(doc, side, names, frames, src) for side in SIDES}
    if len({j for leg in legs.values() for j in leg.joints}) != 12:
        raise RobotModelError(src, "legs", "the two legs share a joint")
    lower = np.array(model.lowerPositionLimit[7:], dtype=float)
    upper = np.array(model.upperPositionLimit[7:], dtype=float)
    effort = np.array(model.effortLimit[6:], dtype=float)
    for k in (k for leg in legs.values() for k in leg.index):  # the URDF's checks hold; the planner needs these
        if not (np.isfinite(lower[k]) and np.isfinite(upper[k]) and lower[k] < upper[k] and effort[k] > 0):
            raise RobotModelError(str(urdf), f"joint {names[k]} limit", "a leg joint needs finite, ordered limits "
                                  "and a positive effort")

    servos = doc["servos"]
    stall = float(servos["stall_torque_nm"])
    stiffness = float(servos.get("stiffness_nm_per_rad", 78.0))
    derivative = float(servos.get("derivative_time_s", 0.03))
    role = {j: r for leg in legs.values() for r, j in zip(LEG_ROLES, leg.joints, strict=True)}
    servo_limit, servo_k = np.empty(len(names)), np.empty(len(names))
    table = servos["joints"]
    known = set(LEG_ROLES) | set(names)
    unknown = sorted(k for k in table if k not in known)
    if unknown:
        raise RobotModelError(src, f"servos.joints.{unknown[0]}", "neither a leg role nor a joint of the URDF")
    for i, jn in enumerate(names):
        key = role.get(jn, jn)  # leg joints by role, any other joint by its name
        if key not in table:
            raise RobotModelError(src, f"servos.joints.{key}", "missing (servos and gear ratio of the joint"
                                  + (f" {jn})" if key != jn else ")"))
        n, ratio = int(table[key]["servos"]), float(table[key]["gear_ratio"])
        servo_limit[i] = stall * n * ratio
        servo_k[i] = stiffness * n * ratio * ratio

    robot.state.q[7:] = 0.0
    robot.set_T_world_fbase(np.eye(4))
    robot.update_kinematics()
    soles = {leg.sole: side for side, leg in legs.items()}
    fans = []
    for k, fd in enumerate(doc.get("fans", [])):
        key = f"fans[{k}]"
        frame = fd["frame"]
        mount = fd.get("mount", fd.get("foot"))
        if not isinstance(mount, str) or (mount not in soles and mount != trunk):
            raise RobotModelError(src, f"{key}.mount", f"expected a sole frame ({', '.join(soles)}) or the trunk "
                                  f"({trunk}), got {mount!r}")
        if frame not in frames:
            raise RobotModelError(src, f"{key}.frame", f"frame {frame!r} not in the URDF")
        T_fan, T_mount = robot.get_T_world_frame(frame), robot.get_T_world_frame(mount)
        off = np.linalg.solve(T_mount, T_fan)[:3, 3]
        axis = tuple(float(a) for a in fd.get("axis", [0, 0, 1]))
        if axis != (0.0, 0.0, 1.0):
            raise RobotModelError(src, f"{key}.axis", "only vertical thrust [0, 0, 1] is modelled")
        fans.append(Fan(fd.get("name", frame), frame, mount, soles.get(mount), float(fd["max_thrust_n"]),
                        (float(off[0]), float(off[1]), float(off[2])), float(fd.get("lag_s", 0.05))))
    for k, fan in enumerate(fans):
        if not fan.name.replace("_", "").isalnum():
            raise RobotModelError(src, f"fans[{k}].name", f"expected letters, digits and _, got {fan.name!r}")
    if len({f.name for f in fans}) != len(fans):
        raise RobotModelError(src, "fans", "two fans share a name")

    def at(frame: str) -> np.ndarray:
        return robot.get_T_world_frame(frame)[:3, 3]

    hips = {s: at(legs[s].joints[0]) for s in SIDES}
    left = legs["left"]
    hip_l, knee_l, ankle_l, foot_l = hips["left"], at(left.joints[3]), at(left.joints[4]), at(left.sole)
    if np.linalg.norm((hips["left"] + hips["right"]) / 2) > 1e-9:
        raise RobotModelError(str(urdf), trunk, "trunk origin is not the midpoint of the hip joints")
    stance = float(doc.get("stance_width_m", abs(at(legs["left"].sole)[1] - at(legs["right"].sole)[1])))
    sole_l, sole_w = float(doc["sole"]["length_m"]), float(doc["sole"]["width_m"])
    if stance < sole_w:
        raise RobotModelError(src, "stance_width_m", f"{stance:g} m: the soles ({sole_w:g} m wide) would overlap")
    return RobotModel(
        name=yaml_path.parent.name,
        urdf_path=urdf.resolve(),
        yaml_path=yaml_path.resolve(),
        mass_kg=float(robot.total_mass()),
        trunk=trunk,
        legs=legs,
        joint_names=names,
        lower_rad=lower,
        upper_rad=upper,
        effort_nm=effort,
        servo_limit_nm=servo_limit,
        fans=tuple(fans),
        sole_length_m=sole_l,
        sole_width_m=sole_w,
        stance_width_m=stance,
        hip_offset_m=float(np.linalg.norm(hips["left"] - hips["right"]) / 2),
        thigh_m=float(np.linalg.norm(knee_l - hip_l)),
        shank_m=float(np.linalg.norm(ankle_l - knee_l)),
        ankle_height_m=float(np.linalg.norm(foot_l - ankle_l)),
        leg_length_m=float(np.linalg.norm(hip_l - foot_l)),
        height_m=_geometry_height(urdf, robot, [legs[s].sole for s in SIDES]),
        servo_stiffness_nm_per_rad=servo_k,
        servo_damping_nms_per_rad=servo_k * derivative,
        armature_kgm2=float(servos.get("armature_kgm2", 0.003)),
        controller=_controller(doc, src),
        twin=TwinSettings(**{k: float(v) for k, v in doc.get("twin", {}).items()}),
        walking=_walking(doc, names, frames, legs, src),
        sensors=_sensors(doc, trunk, frames, src),
        landing_error_m=(None if "landing_error_m" not in doc.get("execution", {})
                         else float(doc["execution"]["landing_error_m"])),
    )


def _controller(doc: dict, src: str) -> ControllerSettings:
    """``controller:``: the law's name, the rate, the CoP law's flat settings and ``imu_tilt_pid``."""
    block = dict(doc.get("controller", {}))
    law = block.pop("law", None)
    imu = ImuLawSettings(**{k: float(v) for k, v in block.pop("imu_tilt_pid", {}).items()})
    out = ControllerSettings(**{k: float(v) for k, v in block.items()}, law=law, imu_tilt_pid=imu)
    if law is not None:
        have = set(_sensor_names(doc))
        missing = [n for n in LAW_SENSORS[law] if n not in have]
        if missing:
            raise RobotModelError(src, "controller.law", f"{law} reads the {' and '.join(missing)}; sensors: declares "
                                  f"{', '.join(sorted(have)) or 'none'}")
    return out


def _sensor_names(doc: dict) -> list[str]:
    block = doc.get("sensors", {})
    return [n for n in ("imu", "encoders", "soles") if block.get(n) is not None]


def _sensors(doc: dict, trunk: str, frames: set[str], src: str) -> Sensors:
    """``sensors:``: the IMU (on the trunk), the encoders, the soles' force sensors, the perception error."""
    block = doc.get("sensors", {})
    imu = block.get("imu")
    if imu is not None:
        imu = dict(imu)
        frame = imu.pop("frame", trunk)
        if frame != trunk:
            raise RobotModelError(src, "sensors.imu.frame", f"{frame!r}: the IMU is modelled on the trunk ({trunk!r})"
                                  if frame in frames else f"frame {frame!r} not in the URDF")
        imu = ImuSpec(frame, **{k: float(v) for k, v in imu.items()})
    enc = block.get("encoders")
    soles = block.get("soles")
    return Sensors(imu=imu,
                   encoders=None if enc is None else EncoderSpec(**{k: float(v) for k, v in enc.items()}),
                   soles=None if soles is None else SoleSensorSpec(**{k: float(v) for k, v in soles.items()}),
                   perception_error_m=float(block.get("perception", {}).get("landing_error_m", 0.0)))


def _walking(doc: dict, joints: tuple[str, ...], frames: set[str], legs: dict[str, Leg], src: str
             ) -> WalkingStructure:
    """``walking:``: the waist yaw joint, the torso frame, the arm-swing joints and their home pose."""
    block = doc.get("walking", {})
    leg_joints = {j for leg in legs.values() for j in leg.joints}
    waist = block.get("waist_yaw")
    if waist is not None and (waist not in joints or waist in leg_joints):
        raise RobotModelError(src, "walking.waist_yaw", f"expected a joint of the URDF outside the legs, got {waist!r}")
    torso = block.get("torso")
    if torso is not None and torso not in frames:
        raise RobotModelError(src, "walking.torso", f"frame {torso!r} not in the URDF")
    if (waist is None) != (torso is None):
        raise RobotModelError(src, "walking", "waist_yaw and torso go together")
    arms = block.get("arm_swing", [])
    for k, a in enumerate(arms):
        if a not in joints or a in leg_joints or a == waist:
            raise RobotModelError(src, f"walking.arm_swing[{k}]", f"{a!r}: expected a joint of the URDF outside the "
                                  "legs and the waist")
    home = block.get("arm_home_rad", {})
    for k in home:
        if k not in joints:
            raise RobotModelError(src, f"walking.arm_home_rad.{k}", "not a joint of the URDF")
    height = block.get("com_height_m")
    return WalkingStructure(waist, torso, tuple(arms), tuple((str(k), float(v)) for k, v in home.items()),
                            None if height is None else float(height))


def _frame_names(robot) -> list[str]:
    return [f.name for f in robot.model.frames]


def _leg(doc: dict, side: str, joints: tuple[str, ...], frames: set[str], src: str) -> Leg:
    """``legs.<side>``: the sole frame and the six joints by role."""
    key = f"legs.{side}"
    sole = doc["legs"][side]["sole"]
    if sole not in frames:
        raise RobotModelError(src, f"{key}.sole", f"frame {sole!r} not in the URDF")
    by_role = doc["legs"][side]["joints"]
    names = []
    for role in LEG_ROLES:
        name = by_role[role]
        if name not in joints:
            raise RobotModelError(src, f"{key}.joints.{role}", f"no joint {name!r} in the URDF")
        names.append(name)
    return Leg(side, sole, tuple(names), tuple(joints.index(n) for n in names))


@functools.lru_cache(maxsize=4)
def _placo_robot(urdf: str):
    """PlaCo's model of the URDF (checked first by :func:`.urdf.check_urdf`); what pinocchio prints on
    the C stderr is kept off the terminal.

    Raises:
        RobotModelError: PlaCo cannot load it (its first line of complaint in the message).
    """
    import placo

    try:
        with quiet_stderr() as said:
            return placo.RobotWrapper(urdf, placo.Flags.ignore_collisions)
    except Exception as exc:  # PlaCo/pinocchio raise RuntimeError on a bad URDF
        first = (str(exc) or (said[0] if said else type(exc).__name__)).splitlines()[0][:160]
        if re.search(r"\.(cpp|hpp|cc|cxx|h)\b|From file", first):  # the C++ source file that threw: not the user's
            first = "a mesh or an element it names cannot be read (its parser failed)"
        raise RobotModelError(urdf, "", f"PlaCo cannot load it: {first}") from None


def build_with_robot(text: str, src: str, schema: dict, max_values: int, what: str, build):
    """Read a document that names its ``robot`` (default ``jethr1``), load that robot and return
    ``build(doc, src, robot)``.

    Raises:
        InputError: the document's first problem, or its robot's, under the key ``robot``.
    """
    doc = read_document(text, src, schema, max_values, what)
    ref = doc.get("robot", "jethr1")
    if os.path.isdir(ref) and os.path.isfile(src):
        yamls = sorted(Path(ref).glob("*.yaml"))
        if len(yamls) == 1 and os.path.samefile(yamls[0], src):
            raise InputError(src, "robot", f"{ref!r}: the folder of this very file, whose only YAML is this "
                             f"{what[2:] if what.startswith('a ') else what}: expected a robot's name, folder or YAML")
    try:
        robot = load_robot(ref)
    except InputError as exc:
        raise InputError(src, "robot", str(exc)) from None
    return build(doc, src, robot)
