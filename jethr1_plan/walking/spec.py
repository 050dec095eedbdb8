"""A walk file (``WALK.yaml``, read by ``jethr1 walk`` and ``jethr1 walk-sweep``): the robot, the
footsteps, the timing, and the settings of Paper B's generator; every default stated once, in the
dataclasses it fills (``Footsteps``, ``WalkTiming`` here, ``SuccessCriteria`` in ``analysis``, ``CoMSettings``,
``PelvisRotation``, ``ArmSwing`` and ``IKSettings`` in their modules).

Every problem is one :class:`~jethr1_plan.errors.InputError` naming the file and the key.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.geometry import SIDES, other_side
from jethr1_plan.io.yaml_input import fill_dataclass, read_text
from jethr1_plan.robot.load import build_with_robot
from jethr1_plan.robot.model import RobotModel
from jethr1_plan.walking.analysis import SuccessCriteria
from jethr1_plan.walking.com_mpc import CoMSettings
from jethr1_plan.walking.generator import ArmSwing, PelvisRotation
from jethr1_plan.walking.ik import IKSettings
from jethr1_plan.walking.timeline import Timeline, repetitive_footsteps

__all__ = ["MAX_ROWS", "ROTATION_MODES", "SCHEMA", "Footsteps", "SuccessCriteria", "WalkSpec", "WalkTiming",
           "load_walk", "load_walk_text"]

ROTATION_MODES = ("none", "paper_b")
MAX_FILE_BYTES = 1_000_000  # a walk file is a few hundred bytes
MAX_VALUES = 100_000
MAX_ROWS = 200_000  # control periods of one walk (duration × control_hz)
MAX_STEPS = 200


@dataclass(frozen=True)
class Footsteps:
    """Where the feet land. ``repetitive``: a straight walk of ``count`` steps of ``step_length_m``
    (the distance between successive footholds, Paper B's step length), the last one closing the
    stance; ``explicit``: the landing sole centres in order."""

    kind: str = "repetitive"  # repetitive | explicit
    step_length_m: float = 0.3
    count: int = 6
    first: str = "left"  # the first swing foot
    step_width_m: float | None = None  # between the sole centres (default: the robot's stance width) [m]
    landings: tuple[tuple[str, tuple[float, float, float]], ...] = ()  # explicit: (side, sole centre [m])


@dataclass(frozen=True)
class WalkTiming:
    """The phases of a walk [s] and its control rate [Hz]."""

    start_s: float = 1.0  # standing, the ZMP moving onto the first support sole
    single_support_s: float = 0.8
    double_support_s: float = 0.4
    end_s: float = 1.0  # standing again after the last landing
    control_hz: float = 100.0  # the IK and the arm QP run at this rate; the rows of trajectory.csv
    swing_height_m: float = 0.05  # the swing sole's apex over its footholds [m]


@dataclass(frozen=True)
class WalkSpec:
    """A walk to generate (SI units)."""

    source: str
    name: str
    robot: RobotModel
    footsteps: Footsteps
    timing: WalkTiming
    com: CoMSettings
    rotation: PelvisRotation
    arms: ArmSwing
    success: SuccessCriteria
    ik: IKSettings = field(default_factory=IKSettings)
    text: str = ""

    def start(self) -> dict[str, np.ndarray]:
        """Both sole centres standing [m]: beside each other, ``step_width_m`` apart about y = 0."""
        width = self.footsteps.step_width_m
        if width is None:
            return self.robot.start_feet()
        return {"left": np.array([0.0, width / 2, 0.0]), "right": np.array([0.0, -width / 2, 0.0])}

    def timeline(self) -> Timeline:
        """The footsteps in time."""
        start = self.start()
        f = self.footsteps
        if f.kind == "repetitive":
            landings = repetitive_footsteps(start, f.step_length_m, f.count, f.first)
        else:
            landings = [(side, np.array(p, dtype=float)) for side, p in f.landings]
        t = self.timing
        return Timeline.build(start, landings, t.start_s, t.single_support_s, t.double_support_s, t.end_s,
                              t.swing_height_m, self.robot.sole_length_m, self.robot.sole_width_m)

    def varied(self, step_length_m: float | None = None, mode: str | None = None,
               arms: bool | None = None) -> WalkSpec:
        """The same walk with another step length (repetitive footsteps), rotation mode or arm swing."""
        out = self
        if step_length_m is not None:
            out = replace(out, footsteps=replace(out.footsteps, step_length_m=float(step_length_m)))
        if mode is not None:
            out = replace(out, rotation=replace(out.rotation, mode=mode))
        if arms is not None:
            out = replace(out, arms=replace(out.arms, enabled=arms))
        return out


def _obj(props: dict, required: tuple = ()) -> dict:
    return {"type": "object", "properties": props, "required": list(required), "additionalProperties": False}


_pos = {"type": "number", "exclusiveMinimum": 0, "maximum": 1e9}
_weight = {"type": "number", "minimum": 0, "maximum": 1e12}
_duration = {"type": "number", "minimum": 0, "maximum": 300}  # [s]
_coord = {"type": "number", "minimum": -1000, "maximum": 1000}  # [m]

SCHEMA = _obj({
    "name": {"type": "string", "maxLength": 200},
    "description": {"type": "string", "maxLength": 5000},
    "robot": {"type": "string", "minLength": 1, "maxLength": 1000},
    "footsteps": {"oneOf": [
        _obj({"kind": {"const": "repetitive"},
              "step_length_m": {"type": "number", "minimum": 0, "maximum": 5},
              "count": {"type": "integer", "minimum": 1, "maximum": MAX_STEPS},
              "first": {"enum": list(SIDES)},
              "step_width_m": {"type": "number", "exclusiveMinimum": 0, "maximum": 5}}, ("kind",)),
        _obj({"kind": {"const": "explicit"},
              "step_width_m": {"type": "number", "exclusiveMinimum": 0, "maximum": 5},
              "landings": {"type": "array", "minItems": 1, "maxItems": MAX_STEPS, "items": _obj({
                  "side": {"enum": list(SIDES)},
                  "position_m": {"type": "array", "items": _coord, "minItems": 3, "maxItems": 3}},
                  ("side", "position_m"))}}, ("kind", "landings")),
    ]},
    "timing": _obj({"start_s": _duration, "single_support_s": {**_duration, "exclusiveMinimum": 0},
                    "double_support_s": {**_duration, "exclusiveMinimum": 0}, "end_s": _duration,
                    "control_hz": {"type": "number", "minimum": 10, "maximum": 2000},
                    "swing_height_m": {"type": "number", "minimum": 0, "maximum": 1}}),
    "com": _obj({"height_m": {"type": "number", "exclusiveMinimum": 0, "maximum": 10},
                 "dt_s": {"type": "number", "minimum": 0.005, "maximum": 1},
                 "horizon_s": {"type": "number", "exclusiveMinimum": 0, "maximum": 10},
                 "zmp_weight": {"type": "number", "exclusiveMinimum": 0, "maximum": 1e12},
                 "velocity_weight": _weight, "jerk_weight": _weight,
                 "zmp_margin_m": {"type": "number", "minimum": 0, "maximum": 0.5}}),
    "pelvis_rotation": _obj({"mode": {"enum": list(ROTATION_MODES)},
                             "k_pel": {"type": "number", "minimum": 0, "maximum": 10},
                             "horizon_s": {"type": "number", "exclusiveMinimum": 0, "maximum": 10},
                             "alpha": {"type": "number", "exclusiveMinimum": 0, "maximum": 1e12},
                             "beta": _weight}),
    "arm_swing": _obj({"enabled": {"type": "boolean"}, "w1": _weight, "w2": _weight, "w3": _weight}),
    "ik": _obj({"max_joint_acceleration_rad_s2": {"type": "number", "exclusiveMinimum": 0, "maximum": 1e6}}),
    "success": _obj({"foot_tolerance_m": {"type": "number", "exclusiveMinimum": 0, "maximum": 1},
                     "foot_tolerance_rad": {"type": "number", "exclusiveMinimum": 0, "maximum": 3.2},
                     "knee_margin_rad": {"type": "number", "minimum": 0, "maximum": 3.2},
                     "com_tolerance_m": {"type": "number", "exclusiveMinimum": 0, "maximum": 1},
                     "zmp_margin_m": {"type": "number", "minimum": -1, "maximum": 1},
                     "rehearse": {"type": "boolean"},
                     "landing_tolerance_m": {"type": "number", "exclusiveMinimum": 0, "maximum": 10}}),
})


def load_walk(path: str | Path) -> WalkSpec:
    """Read and validate a walk file.

    Raises:
        InputError: the first problem found (exit 2).
    """
    return load_walk_text(read_text(path, MAX_FILE_BYTES, "a walk"), str(path))


def load_walk_text(text: str, src: str) -> WalkSpec:
    """A walk from its YAML ``text``; ``src`` names it in messages."""
    return replace(build_with_robot(text, src, SCHEMA, MAX_VALUES, "a walk", _build), text=text)


def _build(doc: dict, src: str, robot: RobotModel) -> WalkSpec:
    steps_doc = dict(doc.get("footsteps", {"kind": "repetitive"}))
    kind = steps_doc.pop("kind")
    if kind == "explicit":
        steps_doc["landings"] = tuple((d["side"], tuple(float(v) for v in d["position_m"]))
                                      for d in steps_doc["landings"])
    footsteps = fill_dataclass(Footsteps(), steps_doc, kind=kind)
    timing = fill_dataclass(WalkTiming(), doc.get("timing", {}))
    com_doc = dict(doc.get("com", {}))
    if "height_m" not in com_doc:
        if robot.walking.com_height_m is None:
            raise InputError(src, "com.height_m", f"missing, and robot {robot.name} states no walking.com_height_m")
        com_doc["height_m"] = robot.walking.com_height_m
    com = fill_dataclass(CoMSettings(height_m=com_doc["height_m"]), com_doc)
    spec = WalkSpec(src, doc.get("name", Path(src).stem), robot, footsteps, timing, com,
                    fill_dataclass(PelvisRotation(), doc.get("pelvis_rotation", {})),
                    fill_dataclass(ArmSwing(), doc.get("arm_swing", {})),
                    fill_dataclass(SuccessCriteria(), doc.get("success", {})),
                    fill_dataclass(IKSettings(), doc.get("ik", {})))
    check_walk(spec, src)
    return spec


def check_walk(spec: WalkSpec, src: str) -> None:
    """What the schema cannot say: the MPC's step and the control period agree, the soles do not
    overlap, the footholds are on the ground, the walk is not too long, the margins leave a polygon.

    Raises:
        InputError: naming ``src`` and the key.
    """
    t, com, robot = spec.timing, spec.com, spec.robot
    ratio = com.dt_s * t.control_hz
    if abs(ratio - round(ratio)) > 1e-6 or round(ratio) < 1:
        raise InputError(src, "com.dt_s", f"{com.dt_s:g} s is not a whole number of control periods "
                         f"(1/{t.control_hz:g} s)")
    for key, value in (("timing.single_support_s", t.single_support_s),
                       ("timing.double_support_s", t.double_support_s)):
        if value < com.dt_s - 1e-9:
            raise InputError(src, key, f"{value:g} s is shorter than the MPC's step com.dt_s = {com.dt_s:g} s")
    if com.zmp_margin_m >= min(robot.sole_length_m, robot.sole_width_m) / 2:
        raise InputError(src, "com.zmp_margin_m", f"leaves no support polygon (sole {robot.sole_length_m} x "
                         f"{robot.sole_width_m} m)")
    if spec.footsteps.step_width_m is not None and spec.footsteps.step_width_m < robot.sole_width_m:
        raise InputError(src, "footsteps.step_width_m", f"{spec.footsteps.step_width_m:g} m: the soles "
                         f"({robot.sole_width_m:g} m wide) would overlap")
    if spec.rotation.mode == "paper_b" and spec.rotation.horizon_s < com.dt_s:
        raise InputError(src, "pelvis_rotation.horizon_s", f"shorter than the MPC's step com.dt_s = {com.dt_s:g} s")
    timeline = spec.timeline()
    rows = timeline.duration_s * t.control_hz
    if rows > MAX_ROWS:
        raise InputError(src, "timing", f"the walk would have {rows:,.0f} rows; at most {MAX_ROWS:,} "
                         "(fewer steps, shorter phases or a lower control_hz)")
    feet = dict(timeline.start)
    span = 2 * (robot.leg_length_m + robot.hip_offset_m)  # both legs straight, hips side by side
    for k, st in enumerate(timeline.steps):
        key = f"footsteps.landings[{k}].position_m" if spec.footsteps.kind == "explicit" else "footsteps"
        reach = float(np.linalg.norm(np.asarray(st.position_m) - np.asarray(feet[other_side(st.side)])))
        if reach > span:
            raise InputError(src, key, f"out of reach: step {k} lands the {st.side} sole {reach:.3f} m from the "
                             f"other; {robot.name}'s legs span at most {span:.3f} m")
        if abs(st.position_m[2]) > 1e-9:
            raise InputError(src, key, f"z = {st.position_m[2]:g} m: the walk is on flat ground (z = 0)")
        other = feet[other_side(st.side)]
        if (abs(st.position_m[0] - other[0]) < robot.sole_length_m
                and abs(st.position_m[1] - other[1]) < robot.sole_width_m):
            raise InputError(src, key, f"step {k} lands the {st.side} sole on the other sole "
                             f"(at {np.round(other, 3).tolist()} m)")
        feet[st.side] = st.position_m
