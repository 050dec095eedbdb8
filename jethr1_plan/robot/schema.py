"""The robot YAML's schema: every key known, every number finite and in a range that means something.

The file is read as scenarios are (:func:`jethr1_plan.io.yaml_input.read_document`: bounded size, no
duplicate keys, aliases bounded, NaN and infinities refused), then checked against :data:`SCHEMA`;
each problem is one :class:`~jethr1_plan.errors.RobotModelError` with the key's full path
(``fans[0].thrust_max_n``). What the schema cannot say (frames and joints that exist in the URDF,
the trunk being its root) is checked by :func:`jethr1_plan.robot.load.load_robot`.
"""

from __future__ import annotations

from pathlib import Path

from jethr1_plan.errors import InputError, RobotModelError
from jethr1_plan.io.yaml_input import read_document, read_text

__all__ = ["LAWS", "LEG_ROLES", "MAX_ROBOT_BYTES", "MIN_CONTROL_HZ", "MIN_TWIN_STEP_S", "SCHEMA", "read_robot_yaml"]

#: a leg's six joints by role, hip to ankle: the closed-form IK's structure (kinematics.closed_form)
LEG_ROLES = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")
#: the thrust feedback laws a robot YAML may name (``controller.law``): on the trunk's IMU, on the soles' CoP
LAWS = ("imu_tilt_pid", "cop_edge_pi")
MAX_ROBOT_BYTES = 1_000_000  # a robot YAML is a few kilobytes
MAX_VALUES = 20_000  # values in the document, aliases expanded (Jet-HR1's has about 150)
#: the slowest thrust loop [Hz]: the twin steps 1 / (rate · timestep) times between two of its ticks in one call
#: that Ctrl-C cannot stop, and a slower loop acts a few times at most in a swing of about 1 s
MIN_CONTROL_HZ = 10.0
#: the twin's finest step [s] (ten times finer than its default, 1 ms): a run costs 1 / timestep steps a second
MIN_TWIN_STEP_S = 1e-4

_name = {"type": "string", "minLength": 1, "maxLength": 200}
_ident = {"type": "string", "pattern": "^[A-Za-z0-9_]+$", "maxLength": 100}


def _num(lo: float, hi: float, lo_open: bool = False) -> dict:
    return {"type": "number", ("exclusiveMinimum" if lo_open else "minimum"): lo, "maximum": hi}


def _obj(props: dict, required: tuple = ()) -> dict:
    return {"type": "object", "properties": props, "required": list(required), "additionalProperties": False}


_leg = _obj({"sole": _name, "joints": _obj({role: _name for role in LEG_ROLES}, LEG_ROLES)}, ("sole", "joints"))

SCHEMA = _obj({
    "urdf": {"type": "string", "minLength": 1, "maxLength": 4096},
    "description": {"type": "string", "maxLength": 5000},
    "trunk": _name,
    "legs": _obj({"left": _leg, "right": _leg}, ("left", "right")),
    "stance_width_m": _num(0, 10, lo_open=True),
    "fans": {"type": "array", "maxItems": 16, "items": _obj({
        "name": _ident,
        "frame": _name,
        "mount": _name,
        "foot": _name,  # the mount's former name
        "axis": {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3},
        "thrust_max_n": _num(0, 1e4),
        "lag_s": _num(0, 10),  # the thrust's first-order time constant [s]
    }, ("frame", "thrust_max_n"))},
    "sole": _obj({"length_m": _num(0, 2, lo_open=True), "width_m": _num(0, 2, lo_open=True)},
                 ("length_m", "width_m")),
    "walking": _obj({
        "waist_yaw": _name,
        "torso": _name,
        "arm_swing": {"type": "array", "maxItems": 64, "items": _name},
        "arm_home_rad": {"type": "object", "maxProperties": 64, "additionalProperties": _num(-7, 7)},
        "com_height_m": _num(0, 10, lo_open=True),
    }),
    "servos": _obj({
        "model": {"type": "string", "maxLength": 500},
        "stall_torque_nm": _num(0, 1e5, lo_open=True),
        "stiffness_nm_per_rad": _num(0, 1e7, lo_open=True),
        "derivative_time_s": _num(0, 10),
        "armature_kgm2": _num(0, 100),
        "joints": {"type": "object", "maxProperties": 256, "additionalProperties": _obj({
            "servos": {"type": "integer", "minimum": 1, "maximum": 100},
            "gear_ratio": _num(0, 1e4, lo_open=True)}, ("servos", "gear_ratio"))},
    }, ("stall_torque_nm", "joints")),
    "controller": _obj({
        "law": {"enum": list(LAWS)},
        "rate_hz": _num(MIN_CONTROL_HZ, 1e4),
        "band_margin_m": _num(0, 0.5),
        "kp_n_per_m": _num(0, 1e7),
        "ki_n_per_m_s": _num(0, 1e8),
        "leak_time_s": _num(0, 1e3, lo_open=True),
        "imu_tilt_pid": _obj({
            "kp_n_per_rad": _num(0, 1e6),
            "ki_n_per_rad_s": _num(0, 1e7),
            "kd_n_s_per_rad": _num(0, 1e5),
            "leak_time_s": _num(0, 1e3, lo_open=True),
        }),
    }),
    "sensors": _obj({
        "imu": {"type": ["object", "null"], "properties": {
            "frame": _name,
            "attitude_noise_rad": _num(0, 0.5),
            "attitude_bias_rad": _num(0, 0.5),
            "rate_noise_rad_s": _num(0, 10),
            "rate_bias_rad_s": _num(0, 10),
            "yaw_drift_rad_s": _num(0, 1),
            "delay_s": _num(0, 1),
        }, "additionalProperties": False},
        "encoders": {"type": ["object", "null"], "properties": {
            "noise_rad": _num(0, 0.5),
            "resolution_rad": _num(0, 0.5),
            "offset_rad": _num(0, 0.5),
            "delay_s": _num(0, 1),
        }, "additionalProperties": False},
        "soles": {"type": ["object", "null"], "properties": {
            "force_noise_n": _num(0, 1e4),
            "cop_noise_m": _num(0, 0.5),
            "delay_s": _num(0, 1),
        }, "additionalProperties": False},
        "perception": _obj({"landing_error_m": _num(0, 0.5)}),
    }),
    "execution": _obj({"landing_error_m": _num(0, 0.5)}),
    "twin": _obj({
        "timestep_s": _num(MIN_TWIN_STEP_S, 0.01),
        "sole_friction": _num(0, 10, lo_open=True),
        "sole_thickness_m": _num(0, 0.1, lo_open=True),
    }),
}, ("urdf", "trunk", "legs", "sole", "servos"))


def read_robot_yaml(path: Path) -> dict:
    """The robot YAML at ``path``, read and checked against :data:`SCHEMA`.

    Raises:
        RobotModelError: the first problem, with the key's full path (exit 2).
    """
    src = str(path)
    try:
        return read_document(read_text(path, MAX_ROBOT_BYTES, "a robot YAML"), src, SCHEMA, MAX_VALUES,
                             "a robot YAML")
    except RobotModelError:
        raise
    except InputError as exc:
        raise RobotModelError(exc.source, exc.key, exc.problem) from None
