"""A rehearsal's ``simulation.mcap``: the twin's robot (frames prefixed ``sim/``), its thrust, CoP and
CoM, and the cartons."""

from __future__ import annotations

import io
import json

import numpy as np

from jethr1_plan.files.mcap import (
    NUMBER,
    ROBOT_DESCRIPTION_SCHEMA,
    SCHEMAS,
    TIME,
    _object,
    frame_transforms,
    joint_rotations,
    log_time,
    pose_message,
    stamp,
    terrain_update,
)
from jethr1_plan.robot.model import RobotModel

__all__ = ["simulation_mcap"]


def simulation_mcap(robot: RobotModel, record: dict, cartons) -> bytes:
    """The MCAP bytes of a rehearsal: ``/tf`` with every robot frame prefixed ``sim/`` (the plan's
    ``trajectory.mcap`` uses the bare names, so both files play side by side in one scene),
    ``/sim/thrust`` (applied per fan [N]), ``/sim/cop`` and ``/sim/com`` (foxglove.PoseInFrame),
    ``/terrain``. Times as in ``trajectory.mcap``: seconds from the plan's start."""
    from mcap.writer import CompressionType, Writer

    schemas = {ROBOT_DESCRIPTION_SCHEMA: SCHEMAS[ROBOT_DESCRIPTION_SCHEMA],
               "foxglove.FrameTransforms": SCHEMAS["foxglove.FrameTransforms"],
               "foxglove.PoseInFrame": SCHEMAS["foxglove.PoseInFrame"],
               "foxglove.SceneUpdate": SCHEMAS["foxglove.SceneUpdate"],
               "jethr1.SimThrust": _object({"timestamp": TIME, "frame": {"type": "array", "items": {"type": "string"}},
                                            "thrust_n": {"type": "array", "items": NUMBER}})}
    schemas["jethr1.SimThrust"].setdefault("title", "jethr1.SimThrust")
    topics = {"/robot_description": ROBOT_DESCRIPTION_SCHEMA, "/tf": "foxglove.FrameTransforms",
              "/sim/thrust": "jethr1.SimThrust", "/sim/cop": "foxglove.PoseInFrame",
              "/sim/com": "foxglove.PoseInFrame", "/terrain": "foxglove.SceneUpdate"}
    buf = io.BytesIO()
    w = Writer(buf, compression=CompressionType.ZSTD)
    w.start(profile="", library="jethr1-plan")
    ids = {name: w.register_schema(name=name, encoding="jsonschema", data=json.dumps(s, sort_keys=True).encode())
           for name, s in schemas.items()}
    channels = {topic: w.register_channel(topic=topic, message_encoding="json", schema_id=ids[name])
                for topic, name in topics.items()}
    seq = 0

    def put(topic: str, t: float, msg: dict) -> None:
        nonlocal seq
        ns = log_time(max(t, 0.0))
        w.add_message(channel_id=channels[topic], log_time=ns, publish_time=ns, sequence=seq,
                      data=json.dumps(msg, separators=(",", ":")).encode())
        seq += 1

    put("/robot_description", 0.0, {"data": robot.urdf_path.read_text(encoding="utf-8")})
    put("/terrain", 0.0, terrain_update(cartons))
    qpos = np.asarray(record["qpos"], dtype=float).reshape(-1, 19)
    rotations = joint_rotations(robot, qpos[:, 7:]) if len(qpos) else []
    frames = [f.frame for f in robot.fans]
    for i, t in enumerate(record["t"]):
        w_, x, y, z = qpos[i, 3:7]
        put("/tf", t, frame_transforms(robot, t, qpos[i, :3], (x, y, z, w_), qpos[i, 7:], [r[i] for r in rotations],
                                       prefix="sim/"))
        put("/sim/thrust", t, {"timestamp": stamp(t), "frame": frames, "thrust_n": record["thrust"][i]})
        put("/sim/com", t, {"timestamp": stamp(t), "frame_id": "world", "pose": pose_message(record["com"][i])})
        cop = record["cop"][i]
        if cop is not None:
            put("/sim/cop", t, {"timestamp": stamp(t), "frame_id": "world", "pose": pose_message(cop)})
    w.finish()
    return buf.getvalue()
