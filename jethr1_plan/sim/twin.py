"""The MuJoCo digital twin of a robot on its terrain, built from the robot's URDF and YAML.

What is modelled, and why:

* **The body**: the URDF as MuJoCo imports it, with ``fusestatic="false"`` and a free joint on the
  root link (otherwise MuJoCo welds the jointless root to the world and the robot weighs only its
  legs: 4.8 kg instead of 6.8 kg for Jet-HR1). :func:`build_twin` asserts the total mass.
* **Contacts**: only the soles touch anything. Each sole is a box of the robot YAML's sole size on
  its leg's sole frame (the URDF's collision shapes are switched off: the fan ducts' cylinders
  reach the sole plane and would prop the foot up); cartons are boxes, and a floor lies under the
  lowest carton (a robot that falls into the ditch lands on it). Elliptic friction cones, the
  YAML's ``twin.sole_friction``.
* **Servos**: a position actuator per joint, stiffness and damping from the YAML's servo table
  (``servos.stiffness_nm_per_rad`` × servos × gear², damping = stiffness × ``derivative_time_s``),
  torque limited to the URDF's effort limit, with a reflected rotor inertia (armature). They sag
  under load as real position servos do.
* **Fans**: a vertical force at each fan frame, applied by the rehearsal through a first-order lag.

Units: SI throughout.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from jethr1_plan.errors import RobotModelError
from jethr1_plan.geometry import SIDES
from jethr1_plan.robot.model import SOLE_FRICTION, RobotModel
from jethr1_plan.swing_path import Carton

__all__ = ["Twin", "TwinParams", "build_twin"]


@dataclass(frozen=True)
class TwinParams:
    """Settings of the twin (defaults: the robot YAML's ``twin:`` block, else these)."""

    timestep_s: float = 0.001
    sole_friction: float = SOLE_FRICTION
    sole_thickness_m: float = 0.01

    @classmethod
    def of(cls, robot: RobotModel) -> TwinParams:
        """The robot YAML's ``twin:`` settings over the defaults."""
        return cls(**robot.twin.given())


@dataclass
class Twin:
    """A compiled twin: the MuJoCo model and the ids the rehearsal needs."""

    model: Any  # mujoco.MjModel
    robot: RobotModel
    qpos_adr: np.ndarray  # (J,) qpos index of each joint, in the robot's joint order
    dof_adr: np.ndarray  # (J,) qvel index of each joint
    trunk: int  # body id of the root link (its free joint holds the pelvis pose)
    fan_bodies: dict[str, int]  # fan frame name -> body id (the force acts at the frame's origin)
    foot_bodies: dict[str, int]  # side -> body id of the leg's sole frame (the sole centre)
    sole_geoms: dict[str, int]  # side -> geom id of the sole's contact box
    total_mass_kg: float

    @functools.cached_property
    def sole_of_geom(self) -> dict[int, str]:
        """geom id of a sole's contact box -> its side (the inverse of ``sole_geoms``)."""
        return {g: s for s, g in self.sole_geoms.items()}


def _with_compiler_options(urdf_text: str) -> str:
    """The URDF with a ``<mujoco><compiler/></mujoco>`` block that keeps the root link a body."""
    head = urdf_text.index("<robot")
    end = urdf_text.index(">", head) + 1
    return (urdf_text[:end] + '<mujoco><compiler fusestatic="false" discardvisual="true"/></mujoco>'
            + urdf_text[end:])


def build_twin(robot: RobotModel, cartons: tuple[Carton, ...], params: TwinParams | None = None) -> Twin:
    """Compile the twin of ``robot`` standing on ``cartons`` (none: the ground plane z = 0).

    Raises:
        RobotModelError: MuJoCo cannot load the URDF, or the twin's mass differs from the model's.
    """
    import mujoco

    params = params or TwinParams.of(robot)
    try:
        spec = mujoco.MjSpec.from_string(_with_compiler_options(robot.urdf_path.read_text()))
    except Exception as exc:  # MuJoCo raises ValueError with the parser's message
        raise RobotModelError(str(robot.urdf_path), "", f"MuJoCo cannot load it: {exc}".splitlines()[0]) from None
    spec.option.timestep = params.timestep_s
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    root = spec.bodies[1]  # bodies[0] is the world
    root.add_freejoint()
    for geom in spec.geoms:  # the URDF's collision shapes: off (see the module docstring)
        geom.contype = 0
        geom.conaffinity = 0
    friction = [params.sole_friction, 0.005, 0.0001]
    h = params.sole_thickness_m
    for side in SIDES:
        sole = spec.body(robot.legs[side].sole).add_geom()
        sole.name = f"{side}_sole"
        sole.type = mujoco.mjtGeom.mjGEOM_BOX
        sole.size = [robot.sole_length_m / 2, robot.sole_width_m / 2, h / 2]
        sole.pos = [0.0, 0.0, h / 2]  # its bottom face is the sole plane
        sole.contype, sole.conaffinity = 1, 0
        sole.friction = friction
        sole.density = 0.0  # the URDF's inertials hold the mass
    for k, carton in enumerate(cartons):
        box = spec.worldbody.add_geom()
        box.name = f"carton{k}"
        box.type = mujoco.mjtGeom.mjGEOM_BOX
        x, y, top = carton.top_centre_m
        box.size = [carton.size_m[0] / 2, carton.size_m[1] / 2, carton.size_m[2] / 2]
        box.pos = [x, y, top - carton.size_m[2] / 2]
        box.contype, box.conaffinity = 0, 1
        box.friction = friction
    floor = spec.worldbody.add_geom()
    floor.name = "floor"
    floor.type = mujoco.mjtGeom.mjGEOM_PLANE
    floor.size = [10.0, 10.0, 0.1]
    floor.pos = [0.0, 0.0, min((c.top_z - c.size_m[2] for c in cartons), default=0.0)]
    floor.contype, floor.conaffinity = 0, 1
    floor.friction = friction
    for i, name in enumerate(robot.joint_names):
        spec.joint(name).armature = robot.armature_kgm2
        act = spec.add_actuator()
        act.name = name
        act.target = name
        act.trntype = mujoco.mjtTrn.mjTRN_JOINT
        act.set_to_position(kp=float(robot.servo_stiffness_nm_per_rad[i]),
                            kv=float(robot.servo_damping_nms_per_rad[i]))
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = [-float(robot.effort_nm[i]), float(robot.effort_nm[i])]
    model = spec.compile()
    total = float(model.body_mass.sum())
    if abs(total - robot.mass_kg) > 1e-6 * max(1.0, robot.mass_kg):
        raise RobotModelError(str(robot.urdf_path), "", f"the twin weighs {total:.4f} kg, the model "
                              f"{robot.mass_kg:.4f} kg (a link fused into the world?)")
    joints = [model.joint(name).id for name in robot.joint_names]
    return Twin(
        model=model, robot=robot,
        qpos_adr=np.array([model.jnt_qposadr[j] for j in joints]),
        dof_adr=np.array([model.jnt_dofadr[j] for j in joints]),
        trunk=int(model.body(root.name).id),
        fan_bodies={f.frame: int(model.body(f.frame).id) for f in robot.fans},
        foot_bodies={s: int(model.body(robot.legs[s].sole).id) for s in SIDES},
        sole_geoms={s: int(model.geom(f"{s}_sole").id) for s in SIDES},
        total_mass_kg=total,
    )
