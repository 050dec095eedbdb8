"""A robot loaded: the URDF (checked by :mod:`.urdf`, loaded by PlaCo) and the robot YAML beside it (checked by
:mod:`.schema`) put together into a :class:`~.model.RobotModel`, each figure read from the loaded model; robots
found by name among the shipped ones (:data:`ROBOTS_DIR`), cached by their YAML's path.
"""

from __future__ import annotations

import functools
import math
import os
import re
from pathlib import Path

import numpy as np

from jethr1_plan.errors import InputError, RobotModelError
from jethr1_plan.geometry import SIDES
from jethr1_plan.io.yaml_input import read_document
from jethr1_plan.robot.model import (
    ControllerSettings,
    Fan,
    ImuLawSettings,
    Leg,
    RobotModel,
    TwinSettings,
    WalkingStructure,
)
from jethr1_plan.robot.schema import LEG_ROLES, read_robot_yaml
from jethr1_plan.robot.sensors import LAW_SENSORS, declared_sensors, sensor_names
from jethr1_plan.robot.urdf import check_urdf, geometry_boxes, quiet_stderr
from jethr1_plan.robot.wrappers import hand_out

__all__ = ["ROBOTS_DIR", "build_with_robot", "forget_robots", "load_robot"]


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
    if os.path.lexists(p):
        raise RobotModelError(str(p), "", "not a robot: expected a folder holding one robot YAML, or a robot YAML "
                              "(.yaml)")
    if len(p.parts) > 1 or p.suffix in (".yaml", ".yml"):
        raise RobotModelError(str(p), "", "no such file or folder: expected a robot's folder or YAML (or the name of "
                              "one of robots/)")
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
    """Forget every robot loaded so far (the caches of :func:`load_robot` and of the URDF checks, keyed by file
    path): for a process that loads robots from folders it then removes, so that a later folder at the same
    path is read afresh (PlaCo's wrappers kept for reuse are keyed by the URDF's bytes too: :mod:`.wrappers`)."""
    _load.cache_clear()
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
    lower, upper, effort = _joint_limits(model, legs, names, urdf)
    servos = doc["servos"]
    servo_limit, servo_k = _servo_tables(servos, names, legs, src)
    derivative = float(servos.get("derivative_time_s", 0.03))
    fans = _fans(doc, robot, legs, trunk, frames, src)

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
        sensors=declared_sensors(doc, trunk, frames, src),
        landing_error_m=(None if "landing_error_m" not in doc.get("execution", {})
                         else float(doc["execution"]["landing_error_m"])),
    )


def _joint_limits(model, legs: dict[str, Leg], names: tuple[str, ...], urdf: Path
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The actuated joints' position limits [rad] and efforts [N·m] as PlaCo reads them; every leg joint's finite,
    ordered and with a positive effort (the URDF's checks hold; the planner needs these)."""
    lower = np.array(model.lowerPositionLimit[7:], dtype=float)
    upper = np.array(model.upperPositionLimit[7:], dtype=float)
    effort = np.array(model.effortLimit[6:], dtype=float)
    for k in (k for leg in legs.values() for k in leg.index):
        if not (np.isfinite(lower[k]) and np.isfinite(upper[k]) and lower[k] < upper[k] and effort[k] > 0):
            raise RobotModelError(str(urdf), f"joint {names[k]} limit", "a leg joint needs finite, ordered limits "
                                  "and a positive effort")
    return lower, upper, effort


def _servo_tables(servos: dict, names: tuple[str, ...], legs: dict[str, Leg], src: str
                  ) -> tuple[np.ndarray, np.ndarray]:
    """``servos:``: each joint's torque limit [N·m] (stall torque × servos × gear ratio) and stiffness
    [N·m/rad] (servo stiffness × servos × gear ratio²), over ``names``; leg joints by role, others by name."""
    stall = float(servos["stall_torque_nm"])
    stiffness = float(servos.get("stiffness_nm_per_rad", 78.0))
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

    return servo_limit, servo_k


def _fans(doc: dict, robot, legs: dict[str, Leg], trunk: str, frames: set[str], src: str) -> list[Fan]:
    """``fans:``: each fan's mount (a sole or the trunk), its thrust point's offset in the mount frame at the
    zero posture, its limit and lag; names checked unique."""
    robot.state.q[7:] = 0.0
    robot.set_T_world_fbase(np.eye(4))
    robot.update_kinematics()
    soles = {leg.sole: side for side, leg in legs.items()}
    fans: list[Fan] = []
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
        fans.append(Fan(fd.get("name", frame), frame, mount, soles.get(mount), float(fd["thrust_max_n"]),
                        (float(off[0]), float(off[1]), float(off[2])), float(fd.get("lag_s", 0.05))))
    for k, fan in enumerate(fans):
        if not fan.name.replace("_", "").isalnum():
            raise RobotModelError(src, f"fans[{k}].name", f"expected letters, digits and _, got {fan.name!r}")
    if len({f.name for f in fans}) != len(fans):
        raise RobotModelError(src, "fans", "two fans share a name")

    return fans


def _controller(doc: dict, src: str) -> ControllerSettings:
    """``controller:``: the law's name, the rate, the CoP law's flat settings and ``imu_tilt_pid``."""
    block = dict(doc.get("controller", {}))
    law = block.pop("law", None)
    imu = ImuLawSettings(**{k: float(v) for k, v in block.pop("imu_tilt_pid", {}).items()})
    out = ControllerSettings(**{k: float(v) for k, v in block.items()}, law=law, imu_tilt_pid=imu)
    if law is not None:
        have = set(sensor_names(doc))
        missing = [n for n in LAW_SENSORS[law] if n not in have]
        if missing:
            raise RobotModelError(src, "controller.law", f"{law} reads the {' and '.join(missing)}; sensors: declares "
                                  f"{', '.join(sorted(have)) or 'none'}")
    return out


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


def _placo_robot(urdf: str):
    """PlaCo's model of the URDF (checked first by :func:`.urdf.check_urdf`), from the wrappers kept for reuse
    (:mod:`.wrappers`: once dropped, it is the first the robot's plans are handed); what pinocchio prints on
    the C stderr is kept off the terminal.

    Raises:
        RobotModelError: PlaCo cannot load it (its first line of complaint in the message).
    """
    try:
        with quiet_stderr() as said:
            return hand_out(urdf)
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
