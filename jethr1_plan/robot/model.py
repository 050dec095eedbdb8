"""The robot model: URDF (through PlaCo) plus the robot YAML beside it.

Everything reported about a robot (mass, height, leg length, joints, fans) is computed from the
loaded model, never copied from the YAML. Frames and joint names follow CONTRACT.md.
"""

from __future__ import annotations

import functools
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from jethr1_plan.errors import InputError, RobotModelError
from jethr1_plan.geometry import GRAVITY, SIDES
from jethr1_plan.io.yaml_input import read_document

__all__ = [
    "LEG_ROLES",
    "ROBOTS_DIR",
    "Fan",
    "Leg",
    "RobotModel",
    "UrdfJoint",
    "WalkingStructure",
    "build_with_robot",
    "fan_ground_xy",
    "load_robot",
    "reach_centre",
    "robot_summary",
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
#: a leg's six joints by role, hip to ankle: the closed-form IK's structure (kinematics.closed_form)
LEG_ROLES = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")


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
    controller: dict  # the thrust feedback law's settings (sim.controller.Gains); {} for the defaults
    twin: dict  # contact settings of the twin (sim.twin.TwinParams); {} for the defaults
    walking: WalkingStructure = WalkingStructure()

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
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") and p.is_file():
        return p
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


def _require(doc: dict, key: str, src: str, kind: type) -> Any:
    """The value at the dotted ``key``, of type ``kind`` (a finite float for float).

    Raises:
        RobotModelError: missing or of another type.
    """
    cur: Any = doc
    for part in key.split("."):
        if not isinstance(cur, dict) or part not in cur:
            raise RobotModelError(src, key, "missing")
        cur = cur[part]
    if kind is float and isinstance(cur, int) and not isinstance(cur, bool):
        cur = float(cur)
    if not isinstance(cur, kind) or (isinstance(cur, float) and not math.isfinite(cur)):
        raise RobotModelError(src, key, f"expected {kind.__name__}, got {cur!r}")
    return cur


def _optional(doc: dict, key: str, src: str, default: float) -> float:
    """A non-negative finite number at the dotted ``key``, or ``default`` where it is absent."""
    cur = doc
    for part in key.split("."):
        if not isinstance(cur, dict) or part not in cur:
            return default
        cur = cur[part]
    if isinstance(cur, bool) or not isinstance(cur, int | float) or not math.isfinite(cur) or cur < 0:
        raise RobotModelError(src, key, f"expected a non-negative number, got {cur!r}")
    return float(cur)


def _numbers(doc: dict, key: str, src: str) -> dict:
    """The mapping at ``key`` (absent: empty), every value a non-negative finite number."""
    block = doc.get(key, {})
    if not isinstance(block, dict):
        raise RobotModelError(src, key, "expected a mapping")
    return {str(k): _optional(doc, f"{key}.{k}", src, 0.0) for k in block}


def _geometry_height(urdf: Path, robot, soles: list[str]) -> float:
    """Top of the URDF's visual boxes and cylinders over the lowest sole, at the zero posture [m]."""
    robot.state.q[7:] = 0.0
    robot.update_kinematics()
    z_sole = min(robot.get_T_world_frame(s)[2, 3] for s in soles)
    top = -math.inf
    for link in ET.parse(urdf).getroot().iter("link"):
        T_link = robot.get_T_world_frame(_attr(link, "name", urdf))
        for vis in link.iter("visual"):
            xyz = np.array(_numbers_of(vis.find("origin"), "xyz", "0 0 0"))
            geom = vis.find("geometry")
            box = geom.find("box") if geom is not None else None
            cyl = geom.find("cylinder") if geom is not None else None
            if box is not None:
                half = np.array(_numbers_of(box, "size", "0 0 0")) / 2
            elif cyl is not None:
                r, ln = float(_attr(cyl, "radius", urdf)), float(_attr(cyl, "length", urdf))
                half = np.array([r, r, ln / 2])
            else:
                continue
            corners = xyz + half * np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)])
            world = (T_link[:3, :3] @ corners.T).T + T_link[:3, 3]
            top = max(top, float(world[:, 2].max()))
    return top - z_sole


def load_robot(name_or_path: str | Path | RobotModel = "jethr1") -> RobotModel:
    """Load a robot by name (a folder of ``robots/``), directory or YAML path; a model is returned as is.

    Models are cached: loading the same name twice gives the same object.

    Raises:
        RobotModelError: missing or inconsistent files (exit 2).
    """
    if isinstance(name_or_path, RobotModel):
        return name_or_path
    return _load(name_or_path)


@functools.lru_cache(maxsize=16)
def _load(name_or_path: str | Path) -> RobotModel:
    yaml_path = _resolve(name_or_path)
    src = str(yaml_path)
    try:
        doc = yaml.safe_load(yaml_path.read_text())
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise RobotModelError(src, "", f"cannot read: {exc}".splitlines()[0]) from None
    if not isinstance(doc, dict):
        raise RobotModelError(src, "", "expected a mapping")
    urdf = yaml_path.parent / _require(doc, "urdf", src, str)
    if not urdf.is_file():
        raise RobotModelError(src, "urdf", f"no such file {urdf}")
    try:
        robot = _placo_robot(str(urdf))
    except Exception as exc:  # PlaCo/pinocchio raise RuntimeError on a bad URDF
        raise RobotModelError(str(urdf), "", f"PlaCo cannot load it: {exc}") from None
    model = robot.model
    names = tuple(model.names[2:])
    frames = set(_frame_names(robot))
    trunk = _require(doc, "trunk", src, str)
    root = ET.parse(urdf).getroot()
    children = {_attr(j.find("child"), "link", urdf) for j in root.iter("joint")}
    roots = [link.get("name") for link in root.iter("link") if link.get("name") not in children]
    if roots != [trunk]:
        raise RobotModelError(src, "trunk", f"{trunk!r} is not the URDF's root link (the root is {roots})")
    legs = {side: _leg(doc, side, names, frames, src) for side in SIDES}
    if len({j for leg in legs.values() for j in leg.joints}) != 12:
        raise RobotModelError(src, "legs", "the two legs share a joint")
    lower = np.array(model.lowerPositionLimit[7:], dtype=float)
    upper = np.array(model.upperPositionLimit[7:], dtype=float)
    effort = np.array(model.effortLimit[6:], dtype=float)

    stall = _require(doc, "servos.stall_torque_nm", src, float)
    stiffness = _optional(doc, "servos.stiffness_nm_per_rad", src, 78.0)
    derivative = _optional(doc, "servos.derivative_time_s", src, 0.03)
    role = {j: r for leg in legs.values() for r, j in zip(LEG_ROLES, leg.joints, strict=True)}
    servo_limit, servo_k = np.empty(len(names)), np.empty(len(names))
    table = doc.get("servos", {}).get("joints") if isinstance(doc.get("servos"), dict) else None
    for i, jn in enumerate(names):
        key = role.get(jn, jn)  # leg joints by role, any other joint by its name
        if not isinstance(table, dict) or key not in table:
            raise RobotModelError(src, f"servos.joints.{key}", "missing (servos and gear ratio of the joint"
                                  + (f" {jn})" if key != jn else ")"))
        n = _require(doc, f"servos.joints.{key}.servos", src, int)
        ratio = _require(doc, f"servos.joints.{key}.gear_ratio", src, float)
        servo_limit[i] = stall * n * ratio
        servo_k[i] = stiffness * n * ratio * ratio

    robot.state.q[7:] = 0.0
    robot.set_T_world_fbase(np.eye(4))
    robot.update_kinematics()
    soles = {leg.sole: side for side, leg in legs.items()}
    fans = []
    fan_docs = doc.get("fans", [])
    if not isinstance(fan_docs, list):
        raise RobotModelError(src, "fans", "expected a list (empty for a robot without fans)")
    for k, fd in enumerate(fan_docs):
        key = f"fans[{k}]"
        if not isinstance(fd, dict):
            raise RobotModelError(src, key, "expected a mapping")
        frame = _require(fd, "frame", src, str)
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
        fmax = _require(fd, "max_thrust_n", src, float)
        if fmax < 0:
            raise RobotModelError(src, f"{key}.max_thrust_n", "must be >= 0")
        name = fd.get("name", frame)
        if not isinstance(name, str) or not name.replace("_", "").isalnum():
            raise RobotModelError(src, f"{key}.name", f"expected letters, digits and _, got {name!r}")
        fans.append(Fan(name, frame, mount, soles.get(mount), fmax, (float(off[0]), float(off[1]), float(off[2])),
                        _optional(fd, "lag_s", src, 0.05)))
    if len({f.name for f in fans}) != len(fans):
        raise RobotModelError(src, "fans", "two fans share a name")

    def at(frame: str) -> np.ndarray:
        return robot.get_T_world_frame(frame)[:3, 3]

    hips = {s: at(legs[s].joints[0]) for s in SIDES}
    left = legs["left"]
    hip_l, knee_l, ankle_l, foot_l = hips["left"], at(left.joints[3]), at(left.joints[4]), at(left.sole)
    if np.linalg.norm((hips["left"] + hips["right"]) / 2) > 1e-9:
        raise RobotModelError(str(urdf), trunk, "trunk origin is not the midpoint of the hip joints")
    stance = _optional(doc, "stance_width_m", src, float(abs(at(legs["left"].sole)[1] - at(legs["right"].sole)[1])))
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
        sole_length_m=_require(doc, "sole.length_m", src, float),
        sole_width_m=_require(doc, "sole.width_m", src, float),
        stance_width_m=stance,
        hip_offset_m=float(np.linalg.norm(hips["left"] - hips["right"]) / 2),
        thigh_m=float(np.linalg.norm(knee_l - hip_l)),
        shank_m=float(np.linalg.norm(ankle_l - knee_l)),
        ankle_height_m=float(np.linalg.norm(foot_l - ankle_l)),
        leg_length_m=float(np.linalg.norm(hip_l - foot_l)),
        height_m=_geometry_height(urdf, robot, [legs[s].sole for s in SIDES]),
        servo_stiffness_nm_per_rad=servo_k,
        servo_damping_nms_per_rad=servo_k * derivative,
        armature_kgm2=_optional(doc, "servos.armature_kgm2", src, 0.003),
        controller=_numbers(doc, "controller", src),
        twin=_numbers(doc, "twin", src),
        walking=_walking(doc, names, frames, legs, src),
    )


def _walking(doc: dict, joints: tuple[str, ...], frames: set[str], legs: dict[str, Leg], src: str
             ) -> WalkingStructure:
    """``walking:``: the waist yaw joint, the torso frame, the arm-swing joints and their home pose."""
    block = doc.get("walking", {})
    if not isinstance(block, dict):
        raise RobotModelError(src, "walking", "expected a mapping")
    unknown = set(block) - {"waist_yaw", "torso", "arm_swing", "arm_home_rad", "com_height_m"}
    if unknown:
        raise RobotModelError(src, f"walking.{sorted(unknown)[0]}", "unknown key")
    leg_joints = {j for leg in legs.values() for j in leg.joints}
    waist = block.get("waist_yaw")
    if waist is not None and (not isinstance(waist, str) or waist not in joints or waist in leg_joints):
        raise RobotModelError(src, "walking.waist_yaw", f"expected a joint of the URDF outside the legs, got {waist!r}")
    torso = block.get("torso")
    if torso is not None and (not isinstance(torso, str) or torso not in frames):
        raise RobotModelError(src, "walking.torso", f"frame {torso!r} not in the URDF")
    if (waist is None) != (torso is None):
        raise RobotModelError(src, "walking", "waist_yaw and torso go together")
    arms = block.get("arm_swing", [])
    if not isinstance(arms, list) or any(not isinstance(a, str) or a not in joints or a in leg_joints or a == waist
                                         for a in arms):
        raise RobotModelError(src, "walking.arm_swing", "expected a list of joints of the URDF outside the legs "
                              "and the waist")
    home = block.get("arm_home_rad", {})
    if not isinstance(home, dict) or any(k not in joints for k in home):
        raise RobotModelError(src, "walking.arm_home_rad", "expected joint names of the URDF")
    for k in home:
        _require(home, k, src, float)
    height = None
    if "com_height_m" in block:
        height = _require(doc, "walking.com_height_m", src, float)
        if not 0.0 < height < 10.0:
            raise RobotModelError(src, "walking.com_height_m", f"{height:g} m: expected a height in (0, 10) m")
    return WalkingStructure(waist, torso, tuple(arms), tuple((str(k), float(v)) for k, v in home.items()), height)


def _frame_names(robot) -> list[str]:
    return [f.name for f in robot.model.frames]


def _leg(doc: dict, side: str, joints: tuple[str, ...], frames: set[str], src: str) -> Leg:
    """``legs.<side>``: the sole frame and the six joints by role."""
    key = f"legs.{side}"
    sole = _require(doc, f"{key}.sole", src, str)
    if sole not in frames:
        raise RobotModelError(src, f"{key}.sole", f"frame {sole!r} not in the URDF")
    by_role = _require(doc, f"{key}.joints", src, dict)
    names = []
    for role in LEG_ROLES:
        name = by_role.get(role)
        if not isinstance(name, str):
            raise RobotModelError(src, f"{key}.joints.{role}", "missing (the joint's name in the URDF)")
        if name not in joints:
            raise RobotModelError(src, f"{key}.joints.{role}", f"no joint {name!r} in the URDF")
        names.append(name)
    extra = set(by_role) - set(LEG_ROLES)
    if extra:
        raise RobotModelError(src, f"{key}.joints", f"unknown roles {sorted(extra)} (roles: {', '.join(LEG_ROLES)})")
    return Leg(side, sole, tuple(names), tuple(joints.index(n) for n in names))


@dataclass(frozen=True)
class UrdfJoint:
    """A URDF joint as written: origin (xyz [m], rpy [rad]) and axis, for /tf."""

    name: str
    kind: str
    parent: str
    child: str
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float]
    axis: tuple[float, float, float]


@functools.lru_cache(maxsize=16)
def urdf_joints(urdf: Path) -> tuple[UrdfJoint, ...]:
    """Every joint of the URDF file, in file order."""
    out = []
    for j in ET.parse(urdf).getroot().iter("joint"):
        org, ax = j.find("origin"), j.find("axis")
        out.append(UrdfJoint(_attr(j, "name", urdf), _attr(j, "type", urdf), _attr(j.find("parent"), "link", urdf),
                             _attr(j.find("child"), "link", urdf), _vec3(_numbers_of(org, "xyz", "0 0 0")),
                             _vec3(_numbers_of(org, "rpy", "0 0 0")), _vec3(_numbers_of(ax, "xyz", "1 0 0"))))
    return tuple(out)


def _attr(el: ET.Element | None, key: str, urdf: Path) -> str:
    """An attribute the URDF must have.

    Raises:
        RobotModelError: the element or the attribute is missing.
    """
    value = el.get(key) if el is not None else None
    if value is None:
        raise RobotModelError(str(urdf), key, "missing in the URDF (a joint without parent or child, a link without "
                              "a name?)")
    return value


def _numbers_of(el: ET.Element | None, key: str, default: str) -> list[float]:
    """The numbers of a URDF attribute (``default`` where the element or the attribute is absent)."""
    return [float(v) for v in (el.get(key, default) if el is not None else default).split()]


def _vec3(v: list[float]) -> tuple[float, float, float]:
    return (v[0], v[1], v[2])


@functools.lru_cache(maxsize=4)
def _placo_robot(urdf: str):
    import placo

    return placo.RobotWrapper(urdf, placo.Flags.ignore_collisions)


def robot_summary(model: RobotModel) -> dict:
    """The figures of ``jethr1 robot show --json`` (SI units)."""
    return {
        "name": model.name,
        "urdf": str(model.urdf_path),
        "mass_kg": model.mass_kg,
        "height_m": model.height_m,
        "leg_length_m": model.leg_length_m,
        "hip_width_m": 2 * model.hip_offset_m,
        "joints": [
            {
                "name": n,
                "lower_rad": float(lo),
                "upper_rad": float(hi),
                "effort_nm": float(e),
                "servo_limit_nm": float(s),
            }
            for n, lo, hi, e, s in zip(
                model.joint_names, model.lower_rad, model.upper_rad, model.effort_nm, model.servo_limit_nm, strict=True
            )
        ],
        "fans": [
            {"name": f.name, "frame": f.frame, "mount": f.mount, "max_thrust_n": f.max_thrust_n,
             "offset_m": list(f.offset_m), "lag_s": f.lag_s}
            for f in model.fans
        ],
        "trunk": model.trunk,
        "legs": {s: {"sole": leg.sole, "joints": dict(zip(LEG_ROLES, leg.joints, strict=True))}
                 for s, leg in model.legs.items()},
        "stance_width_m": model.stance_width_m,
        "sole": {"length_m": model.sole_length_m, "width_m": model.sole_width_m},
        "weight_n": model.mass_kg * GRAVITY,
    }


def build_with_robot(text: str, src: str, schema: dict, max_values: int, what: str, build):
    """Read a document that names its ``robot`` (default ``jethr1``), load that robot and return
    ``build(doc, src, robot)``.

    Raises:
        InputError: the document's first problem, or its robot's, under the key ``robot``.
    """
    doc = read_document(text, src, schema, max_values, what)
    try:
        robot = load_robot(doc.get("robot", "jethr1"))
    except InputError as exc:
        raise InputError(src, "robot", str(exc)) from None
    return build(doc, src, robot)
