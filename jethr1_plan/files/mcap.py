"""``trajectory.mcap``: JSON messages with jsonschema schemas, Foxglove schema names where one exists.

Topics (CONTRACT.md): ``/robot_description`` (the URDF as a ``std_msgs/String``-shaped message, the
form Foxglove's URDF layer reads from a topic: the file alone shows the robot), ``/tf``
(foxglove.FrameTransforms: world→trunk and every URDF joint's parent→child link, so the URDF layer
plays the motion), ``/joint_states``, ``/thrust``, ``/p_body``, ``/com``, ``/zmp``
(foxglove.PoseInFrame), ``/terrain`` and ``/swing_path`` (foxglove.SceneUpdate), ``/analysis``.

Times: every message is logged at ``EPOCH_NS`` + its time from the scenario's start, the epoch being
2000-01-01T00:00:00Z (a fixed date, so that the same plan gives the same bytes; Foxglove's timeline
shows the plan starting at midnight on 1 January 2000). Message timestamps carry the same time.
"""

from __future__ import annotations

import io
import json
from collections.abc import Iterable

import numpy as np

from jethr1_plan.geometry import quat_rpy
from jethr1_plan.robot.model import RobotModel, urdf_joints
from jethr1_plan.swing_path import Carton

__all__ = [
    "COLOR",
    "CUBE",
    "DURATION",
    "ENTITY",
    "EPOCH_NS",
    "LINE",
    "NUMBER",
    "POSE",
    "QUATERNION",
    "ROBOT_DESCRIPTION_SCHEMA",
    "SCHEMAS",
    "SPHERE",
    "TIME",
    "TOPICS",
    "VECTOR3",
    "JsonMcap",
    "frame_transforms",
    "joint_rotations",
    "log_time",
    "mcap_schemas",
    "pose_message",
    "quaternion_message",
    "read_mcap",
    "scene_entity",
    "stamp",
    "swing_path_update",
    "terrain_update",
    "thrust_schema",
    "vector3",
]

EPOCH_NS = 946_684_800 * 1_000_000_000  # 2000-01-01T00:00:00Z [ns since 1970]
ROBOT_DESCRIPTION_SCHEMA = "std_msgs/String"  # a name Foxglove's URDF layer accepts for a topic source

# --- JSON schemas (every field required, as in Foxglove's current schemas) ------------------


def _object(props: dict) -> dict:
    return {"type": "object", "properties": props, "required": list(props)}


NUMBER = {"type": "number"}
TIME = {"type": "object", "title": "time", "properties": {"sec": {"type": "integer", "minimum": 0},
                                                           "nsec": {"type": "integer", "minimum": 0,
                                                                    "maximum": 999999999}},
        "required": ["sec", "nsec"]}
VECTOR3 = {"title": "foxglove.Vector3", **_object({"x": NUMBER, "y": NUMBER, "z": NUMBER})}
QUATERNION = {"title": "foxglove.Quaternion", **_object({"x": NUMBER, "y": NUMBER, "z": NUMBER, "w": NUMBER})}
POSE = {"title": "foxglove.Pose", **_object({"position": VECTOR3, "orientation": QUATERNION})}
COLOR = {"title": "foxglove.Color", **_object({"r": NUMBER, "g": NUMBER, "b": NUMBER, "a": NUMBER})}
DURATION = {"type": "object", "title": "duration", "properties": {"sec": {"type": "integer"},
                                                                  "nsec": {"type": "integer", "minimum": 0}},
            "required": ["sec", "nsec"]}
LINE = {"title": "foxglove.LinePrimitive", **_object({
    "type": {"type": "integer", "enum": [0, 1, 2]}, "pose": POSE, "thickness": NUMBER,
    "scale_invariant": {"type": "boolean"}, "points": {"type": "array", "items": VECTOR3}, "color": COLOR,
    "colors": {"type": "array", "items": COLOR}, "indices": {"type": "array", "items": {"type": "integer"}}})}
CUBE = {"title": "foxglove.CubePrimitive", **_object({"pose": POSE, "size": VECTOR3, "color": COLOR})}
SPHERE = {"title": "foxglove.SpherePrimitive", **_object({"pose": POSE, "size": VECTOR3, "color": COLOR})}
ENTITY = {"title": "foxglove.SceneEntity", **_object({
    "timestamp": TIME, "frame_id": {"type": "string"}, "id": {"type": "string"}, "lifetime": DURATION,
    "frame_locked": {"type": "boolean"}, "metadata": {"type": "array"}, "arrows": {"type": "array"},
    "cubes": {"type": "array", "items": CUBE}, "spheres": {"type": "array", "items": SPHERE},
    "cylinders": {"type": "array"}, "lines": {"type": "array", "items": LINE}, "triangles": {"type": "array"},
    "texts": {"type": "array"}, "models": {"type": "array"}})}

SCHEMAS: dict[str, dict] = {
    "foxglove.FrameTransforms": _object({"transforms": {"type": "array", "items": {
        "title": "foxglove.FrameTransform", **_object({
            "timestamp": TIME, "parent_frame_id": {"type": "string"}, "child_frame_id": {"type": "string"},
            "translation": VECTOR3, "rotation": QUATERNION})}}}),
    "foxglove.PoseInFrame": _object({"timestamp": TIME, "frame_id": {"type": "string"}, "pose": POSE}),
    "foxglove.SceneUpdate": _object({"deletions": {"type": "array"}, "entities": {"type": "array", "items": ENTITY}}),
    "jethr1.JointState": _object({"timestamp": TIME, "name": {"type": "array", "items": {"type": "string"}},
                                  "position_rad": {"type": "array", "items": NUMBER},
                                  "command_rad": {"type": "array", "items": NUMBER},
                                  "effort_nm": {"type": "array", "items": NUMBER}}),
    ROBOT_DESCRIPTION_SCHEMA: _object({"data": {"type": "string"}}),
    "jethr1.LegAnalysis": _object({"timestamp": TIME, "kappa_left": NUMBER, "kappa_right": NUMBER,
                                   "yaw_momentum_nms": NUMBER}),
}


def thrust_schema(fans: list[str]) -> dict:
    """``jethr1.Thrust`` for a robot whose fans are named ``fans``: ``<fan>_n`` and ``<fan>_cmd_n`` per fan [N]."""
    schema = _object({"timestamp": TIME, **{f"{f}_n": NUMBER for f in fans}, "phase": {"type": "string"},
                      "support": {"enum": ["left", "right", "both"]}, "step": {"type": "integer"},
                      "sample": {"type": "integer"}, "feasible": {"type": "boolean"},
                      "reason": {"type": "string"}, **{f"{f}_cmd_n": NUMBER for f in fans},
                      "window_lo_n": {"type": ["number", "null"]}, "window_hi_n": {"type": ["number", "null"]},
                      "zmp_margin_m": NUMBER})
    schema["title"] = "jethr1.Thrust"
    return schema


SCHEMAS["jethr1.Thrust"] = thrust_schema(["left", "right"])  # Jet-HR1's; a plan's MCAP holds its robot's
for _name, _schema in SCHEMAS.items():
    _schema.setdefault("title", _name)

TOPICS = {"/robot_description": ROBOT_DESCRIPTION_SCHEMA, "/tf": "foxglove.FrameTransforms",
          "/joint_states": "jethr1.JointState", "/thrust": "jethr1.Thrust",
          "/p_body": "foxglove.PoseInFrame", "/com": "foxglove.PoseInFrame", "/zmp": "foxglove.PoseInFrame",
          "/terrain": "foxglove.SceneUpdate", "/swing_path": "foxglove.SceneUpdate", "/analysis": "jethr1.LegAnalysis"}

# --- helpers ------------------------------------------------------------------------------


def log_time(t_s: float) -> int:
    """Log time [ns] of a message at ``t_s`` [s] from the scenario's start."""
    return EPOCH_NS + round(t_s * 1e9)


def stamp(t_s: float) -> dict:
    ns = log_time(t_s)
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def vector3(v) -> dict:
    return {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}


def quaternion_message(q) -> dict:
    return {"x": float(q[0]), "y": float(q[1]), "z": float(q[2]), "w": float(q[3])}


def pose_message(pos, quat=(0.0, 0.0, 0.0, 1.0)) -> dict:
    return {"position": vector3(pos), "orientation": quaternion_message(quat)}


def scene_entity(t: float, ident: str, cubes=(), lines=(), spheres=()) -> dict:
    return {"timestamp": stamp(t), "frame_id": "world", "id": ident, "lifetime": {"sec": 0, "nsec": 0},
            "frame_locked": False, "metadata": [], "arrows": [], "cubes": list(cubes), "spheres": list(spheres),
            "cylinders": [], "lines": list(lines), "triangles": [], "texts": [], "models": []}


def terrain_update(cartons: Iterable[Carton], t: float = 0.0) -> dict:
    """/terrain: one cube per carton (brown)."""
    cubes = []
    for c in cartons:
        x, y, ztop = c.top_centre_m
        cubes.append({"pose": pose_message((x, y, ztop - c.size_m[2] / 2)), "size": vector3(c.size_m),
                      "color": {"r": 0.72, "g": 0.53, "b": 0.32, "a": 0.9}})
    return {"deletions": [], "entities": [scene_entity(t, "cartons", cubes=cubes)]}


def swing_path_update(paths: Iterable[np.ndarray], t: float = 0.0) -> dict:
    """/swing_path: one line strip per step through its swing samples."""
    lines = [{"type": 0, "pose": pose_message((0, 0, 0)), "thickness": 0.005, "scale_invariant": False,
              "points": [vector3(p) for p in path], "color": {"r": 0.1, "g": 0.6, "b": 1.0, "a": 1.0}, "colors": [],
              "indices": []} for path in paths]
    return {"deletions": [], "entities": [scene_entity(t, "swing_paths", lines=lines)]}


def joint_rotations(robot: RobotModel, q: np.ndarray) -> list[np.ndarray]:
    """Per URDF joint, the parent→child rotation quaternions (N, 4) for joint angles ``q`` (N, 12)."""
    q = np.atleast_2d(q)
    index = {name: k for k, name in enumerate(robot.joint_names)}
    out = []
    for j in urdf_joints(robot.urdf_path):
        base = quat_rpy(j.rpy)
        if j.kind in ("revolute", "continuous"):
            axis = np.asarray(j.axis, dtype=float) / np.linalg.norm(j.axis)
            half = 0.5 * q[:, index[j.name]]
            rot = np.concatenate([np.sin(half)[:, None] * axis, np.cos(half)[:, None]], axis=1)
            bx, by, bz, bw = base
            x, y, z, w = rot.T
            out.append(np.stack([bw * x + bx * w + by * z - bz * y, bw * y - bx * z + by * w + bz * x,
                                 bw * z + bx * y - by * x + bz * w, bw * w - bx * x - by * y - bz * z], axis=1))
        else:
            out.append(np.repeat(base[None], len(q), axis=0))
    return out


def frame_transforms(robot: RobotModel, t: float, p_body, trunk_quat_xyzw, q: np.ndarray,
                     rotations: list[np.ndarray] | None = None, prefix: str = "") -> dict:
    """/tf at one instant: world→trunk and each joint's parent→child (``rotations``: precomputed rows).

    ``prefix`` goes before every frame of the robot (``sim/`` for a rehearsal), so two robots can
    play in one scene; Foxglove's URDF layer takes the same prefix.
    """
    ts = stamp(t)
    tfs = [{"timestamp": ts, "parent_frame_id": "world", "child_frame_id": prefix + robot.trunk,
            "translation": vector3(p_body), "rotation": quaternion_message(trunk_quat_xyzw)}]
    if rotations is None:
        rotations = [r[0] for r in joint_rotations(robot, q)]
    for j, rot in zip(urdf_joints(robot.urdf_path), rotations, strict=True):
        tfs.append({"timestamp": ts, "parent_frame_id": prefix + j.parent, "child_frame_id": prefix + j.child,
                    "translation": vector3(j.xyz), "rotation": quaternion_message(rot)})
    return {"transforms": tfs}


class JsonMcap:
    """An MCAP being written: JSON messages on channels whose JSON schemas are registered up front
    (zstd-compressed chunks, one sequence number per message, logged at :func:`log_time`)."""

    def __init__(self, schemas: dict[str, dict], topics: dict[str, str]):
        from mcap.writer import CompressionType, Writer

        self._buf = io.BytesIO()
        self._w = Writer(self._buf, compression=CompressionType.ZSTD)
        self._w.start(profile="", library="jethr1-plan")
        ids = {name: self._w.register_schema(name=name, encoding="jsonschema",
                                             data=json.dumps(schema, sort_keys=True).encode())
               for name, schema in schemas.items()}
        self._channels = {topic: self._w.register_channel(topic=topic, message_encoding="json", schema_id=ids[name])
                          for topic, name in topics.items()}
        self._seq = 0

    def put(self, topic: str, t: float, msg: dict) -> None:
        """Log ``msg`` on ``topic`` at ``t`` [s] from the start."""
        ns = log_time(t)
        self._w.add_message(channel_id=self._channels[topic], log_time=ns, publish_time=ns, sequence=self._seq,
                            data=json.dumps(msg, separators=(",", ":"), check_circular=False).encode())
        self._seq += 1

    def finish(self) -> bytes:
        """The file's bytes."""
        self._w.finish()
        return self._buf.getvalue()


def read_mcap(data: bytes) -> list[tuple[str, str, dict, int]]:
    """Every message of an MCAP file: (topic, schema name, decoded JSON, log_time [ns]), the chunks'
    CRCs checked."""
    from mcap.reader import make_reader

    out = []
    reader = make_reader(io.BytesIO(data), validate_crcs=True)
    for schema, channel, message in reader.iter_messages():
        out.append((channel.topic, schema.name if schema is not None else "", json.loads(message.data),
                    message.log_time))
    return out


def mcap_schemas(data: bytes) -> dict[str, dict]:
    """Schema name → the JSON schema stored in the file."""
    from mcap.reader import make_reader

    summary = make_reader(io.BytesIO(data)).get_summary()
    return {} if summary is None else {s.name: json.loads(s.data) for s in summary.schemas.values()}
