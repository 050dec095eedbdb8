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

import numpy as np
import yaml

from jethr1_plan.errors import RobotModelError

__all__ = [
    "GRAVITY",
    "JOINT_NAMES",
    "JOINT_TYPES",
    "ROBOTS_DIR",
    "SIDES",
    "Fan",
    "RobotModel",
    "UrdfJoint",
    "load_robot",
    "reach_centre",
    "robot_summary",
    "urdf_joints",
]

SIDES = ("left", "right")


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
JOINT_TYPES = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")
#: the 12 joints in URDF order (left leg then right leg)
JOINT_NAMES = tuple(f"{side}_{j}" for side in SIDES for j in JOINT_TYPES)
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
GRAVITY = 9.81  # [m/s^2]


@dataclass(frozen=True)
class Fan:
    """A ducted fan: ``frame`` is the thrust point, fixed to the sole frame ``foot``."""

    frame: str
    foot: str
    axis: tuple[float, float, float]
    max_thrust_n: float
    offset_in_foot_m: tuple[float, float, float]  # thrust point in the foot frame [m]
    lag_s: float = 0.05  # time constant of the thrust's first-order response to a command [s]


@dataclass(frozen=True, eq=False)  # identity hash: models are cached by load_robot
class RobotModel:
    """A loaded robot: the URDF path and what the YAML adds, with figures read from PlaCo."""

    name: str
    urdf_path: Path
    yaml_path: Path
    mass_kg: float
    joint_names: tuple[str, ...]
    lower_rad: np.ndarray  # (12,)
    upper_rad: np.ndarray  # (12,)
    effort_nm: np.ndarray  # (12,) URDF effort limits
    servo_limit_nm: np.ndarray  # (12,) from the YAML's servo table
    fans: tuple[Fan, ...]
    sole_length_m: float
    sole_width_m: float
    hip_offset_m: float  # trunk origin -> each hip joint centre, along the trunk y axis
    thigh_m: float  # hip joint centre -> knee axis
    shank_m: float  # knee axis -> ankle joint centre
    ankle_height_m: float  # ankle joint centre -> sole
    leg_length_m: float  # hip joint centre -> sole, legs straight
    height_m: float  # sole -> top of the highest geometry, standing straight
    servo_stiffness_nm_per_rad: np.ndarray  # (12,) the twin's position servos: servos × stiffness × gear²
    servo_damping_nms_per_rad: np.ndarray  # (12,) stiffness × derivative time
    armature_kgm2: float  # rotor inertia reflected through each joint's gearbox
    controller: dict  # the thrust feedback law's settings (sim.controller.Gains); {} for the defaults
    twin: dict  # contact settings of the twin (sim.twin.TwinParams); {} for the defaults

    def fan_for(self, side: str) -> Fan:
        """The fan on the ``side`` ('left'/'right') foot."""
        for fan in self.fans:
            if fan.foot == f"{side}_foot":
                return fan
        raise RobotModelError(str(self.yaml_path), "fans", f"no fan on the {side} foot")

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


def _require(doc: dict, key: str, src: str, kind: type):
    cur = doc
    for part in key.split("."):
        if not isinstance(cur, dict) or part not in cur:
            raise RobotModelError(src, key, "missing")
        cur = cur[part]
    if kind is float and isinstance(cur, int) and not isinstance(cur, bool):
        cur = float(cur)
    if not isinstance(cur, kind) or (kind is float and not math.isfinite(cur)):
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


def _geometry_height(urdf: Path, robot) -> float:
    """Top of the URDF's visual boxes and cylinders over the lowest sole, at the zero posture [m]."""
    robot.state.q[7:] = 0.0
    robot.update_kinematics()
    z_sole = min(robot.get_T_world_frame(f"{s}_foot")[2, 3] for s in SIDES)
    top = -math.inf
    for link in ET.parse(urdf).getroot().iter("link"):
        T_link = robot.get_T_world_frame(link.get("name"))
        for vis in link.iter("visual"):
            org = vis.find("origin")
            xyz = np.array([float(v) for v in (org.get("xyz", "0 0 0") if org is not None else "0 0 0").split()])
            geom = vis.find("geometry")
            box, cyl = geom.find("box"), geom.find("cylinder")
            if box is not None:
                half = np.array([float(v) for v in box.get("size").split()]) / 2
            elif cyl is not None:
                r, ln = float(cyl.get("radius")), float(cyl.get("length"))
                half = np.array([r, r, ln / 2])
            else:
                continue
            corners = xyz + half * np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)])
            world = (T_link[:3, :3] @ corners.T).T + T_link[:3, 3]
            top = max(top, float(world[:, 2].max()))
    return top - z_sole


@functools.lru_cache(maxsize=16)
def load_robot(name_or_path: str = "jethr1") -> RobotModel:
    """Load a robot by name (a folder of ``robots/``), directory or YAML path.

    Raises:
        RobotModelError: missing or inconsistent files (exit 2).
    """
    yaml_path = _resolve(name_or_path)
    src = str(yaml_path)
    try:
        doc = yaml.safe_load(yaml_path.read_text())
    except (OSError, yaml.YAMLError) as exc:
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
    if names != JOINT_NAMES:
        raise RobotModelError(str(urdf), "joints", f"expected {list(JOINT_NAMES)}, got {list(names)}")
    lower = np.array(model.lowerPositionLimit[7:], dtype=float)
    upper = np.array(model.upperPositionLimit[7:], dtype=float)
    effort = np.array(model.effortLimit[6:], dtype=float)

    stall = _require(doc, "servos.stall_torque_nm", src, float)
    stiffness = _optional(doc, "servos.stiffness_nm_per_rad", src, 78.0)
    derivative = _optional(doc, "servos.derivative_time_s", src, 0.03)
    servo_limit, servo_k = np.empty(12), np.empty(12)
    for i, jn in enumerate(JOINT_NAMES):
        jt = jn.split("_", 1)[1]
        n = _require(doc, f"servos.joints.{jt}.servos", src, int)
        ratio = _require(doc, f"servos.joints.{jt}.gear_ratio", src, float)
        servo_limit[i] = stall * n * ratio
        servo_k[i] = stiffness * n * ratio * ratio

    robot.state.q[7:] = 0.0
    robot.set_T_world_fbase(np.eye(4))
    robot.update_kinematics()
    fans = []
    fan_docs = doc.get("fans")
    if not isinstance(fan_docs, list) or not fan_docs:
        raise RobotModelError(src, "fans", "expected a non-empty list")
    for k, fd in enumerate(fan_docs):
        frame = _require(fd, "frame", src, str)
        foot = _require(fd, "foot", src, str)
        try:
            T_fan, T_foot = robot.get_T_world_frame(frame), robot.get_T_world_frame(foot)
        except Exception:
            raise RobotModelError(src, f"fans[{k}]", f"frame {frame!r} or {foot!r} not in the URDF") from None
        off = np.linalg.solve(T_foot, T_fan)[:3, 3]
        axis = tuple(float(a) for a in fd.get("axis", [0, 0, 1]))
        if axis != (0.0, 0.0, 1.0):
            raise RobotModelError(src, f"fans[{k}].axis", "only vertical thrust [0, 0, 1] is modelled")
        fmax = _require(fd, "max_thrust_n", src, float)
        if fmax < 0:
            raise RobotModelError(src, f"fans[{k}].max_thrust_n", "must be >= 0")
        lag = _optional(fd, "lag_s", src, 0.05)
        fans.append(Fan(frame, foot, axis, fmax, tuple(float(v) for v in off), lag))

    hip_l = robot.get_T_world_frame("left_hip_yaw_link")[:3, 3]
    hip_r = robot.get_T_world_frame("right_hip_yaw_link")[:3, 3]
    foot_l = robot.get_T_world_frame("left_foot")[:3, 3]
    knee_l = robot.get_T_world_frame("left_shank")[:3, 3]
    ankle_l = robot.get_T_world_frame("left_ankle")[:3, 3]
    if np.linalg.norm((hip_l + hip_r) / 2) > 1e-9:
        raise RobotModelError(str(urdf), "trunk", "trunk origin is not the midpoint of the hip joints")
    return RobotModel(
        name=yaml_path.parent.name,
        urdf_path=urdf.resolve(),
        yaml_path=yaml_path.resolve(),
        mass_kg=float(robot.total_mass()),
        joint_names=names,
        lower_rad=lower,
        upper_rad=upper,
        effort_nm=effort,
        servo_limit_nm=servo_limit,
        fans=tuple(fans),
        sole_length_m=_require(doc, "sole.length_m", src, float),
        sole_width_m=_require(doc, "sole.width_m", src, float),
        hip_offset_m=float(np.linalg.norm(hip_l - hip_r) / 2),
        thigh_m=float(np.linalg.norm(knee_l - hip_l)),
        shank_m=float(np.linalg.norm(ankle_l - knee_l)),
        ankle_height_m=float(np.linalg.norm(foot_l - ankle_l)),
        leg_length_m=float(np.linalg.norm(hip_l - foot_l)),
        height_m=_geometry_height(urdf, robot),
        servo_stiffness_nm_per_rad=servo_k,
        servo_damping_nms_per_rad=servo_k * derivative,
        armature_kgm2=_optional(doc, "servos.armature_kgm2", src, 0.003),
        controller=_numbers(doc, "controller", src),
        twin=_numbers(doc, "twin", src),
    )


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
        org = j.find("origin")
        ax = j.find("axis")

        def vec(el, key, default="0 0 0"):
            return tuple(float(v) for v in ((el.get(key, default) if el is not None else default).split()))

        out.append(UrdfJoint(j.get("name"), j.get("type"), j.find("parent").get("link"), j.find("child").get("link"),
                             vec(org, "xyz"), vec(org, "rpy"), vec(ax, "xyz", "1 0 0")))
    return tuple(out)


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
            {"frame": f.frame, "foot": f.foot, "max_thrust_n": f.max_thrust_n,
             "offset_in_foot_m": list(f.offset_in_foot_m), "lag_s": f.lag_s}
            for f in model.fans
        ],
        "sole": {"length_m": model.sole_length_m, "width_m": model.sole_width_m},
        "weight_n": model.mass_kg * GRAVITY,
    }
