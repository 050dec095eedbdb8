"""A rehearsal's ``simulation.mcap`` (ROS 2 profile, :mod:`.mcap`): the twin's robot with every frame
prefixed ``sim/`` (in ``/tf``, ``/tf_static`` and the URDF on ``/sim/robot_description``), so the
plan's ``trajectory.mcap`` (bare frame names) and its rehearsal play side by side in one scene; the
thrust each fan applied, the CoP and CoM, and the cartons. Times as in ``trajectory.mcap``: seconds
from the plan's start after the fixed epoch.

Topics: :data:`SIMULATION_TOPICS`.
"""

from __future__ import annotations

import numpy as np

from jethr1_plan.files.mcap import MARKERS, POSE, STRING, TF, Ros2Mcap, Topic
from jethr1_plan.files.messages import (
    carton_markers,
    header,
    pose_stamped,
    robot_transforms,
    step_markers,
    urdf_message,
)
from jethr1_plan.records import topics as tp
from jethr1_plan.robot.model import RobotModel

__all__ = ["PREFIX", "SIMULATION_TOPICS", "simulation_mcap"]

PREFIX = "sim/"  # before every robot frame of a rehearsal

#: the topics of a rehearsal's ``simulation.mcap``, in the order the file registers them
SIMULATION_TOPICS: dict[str, Topic] = {
    "/sim/robot_description": Topic(STRING, True, "the robot's URDF, every link prefixed `sim/`"),
    tp.TF_STATIC: Topic(TF, True, "every fixed joint's parent → child link (`sim/` frames)"),
    tp.TF_TOPIC: Topic(TF, False, "at 50 Hz: world → `sim/trunk` and every moving joint's link (`sim/` frames)"),
    tp.TERRAIN: Topic(MARKERS, True, "a CUBE per carton"),
    "/sim/thrust": Topic("jethr1_msgs/msg/FanThrust", False,
                         "at 50 Hz: the thrust each fan applied [N] and the frame it acts at (`sim/left_fan` …)"),
    "/sim/com": Topic(POSE, False, "at 50 Hz: the twin's centre of mass"),
    "/sim/cop": Topic(POSE, False, "at 50 Hz while a sole bears weight: the centre of pressure"),
    "/sim/steps": Topic(MARKERS, True, "per landing: the foothold (green sphere), where the sole landed (orange), a "
                                       "line between them and a label: the landing's error, the support sole's slip "
                                       "and turn over the swing"),
}


def simulation_mcap(robot: RobotModel, record: dict, cartons) -> bytes:
    """The MCAP bytes of a rehearsal's ``record`` (``t`` [s], ``qpos`` (N, 7 + J): position, w-x-y-z
    quaternion and joints, ``thrust`` (N, F) [N], ``com`` (N, 3) [m], ``cop`` per sample (3,) [m] or
    None; ``steps``: per landing the judge's record, ``sim.judge.StepJudge``, with ``foothold_m`` and
    ``foothold_error_m`` where the foothold is not the plan's landing)."""
    out = Ros2Mcap(SIMULATION_TOPICS)
    out.write("/sim/robot_description", 0.0, urdf_message(robot, PREFIX))
    out.write(tp.TERRAIN, 0.0, carton_markers(cartons))
    t = np.maximum(np.asarray(record["t"], dtype=float), 0.0)
    n = len(t)
    if n:
        qpos = np.asarray(record["qpos"], dtype=float).reshape(n, -1)
        tf, tf_static = robot_transforms(robot, t, qpos[:, :3], qpos[:, [4, 5, 6, 3]], qpos[:, 7:], prefix=PREFIX)
        out.write(tp.TF_STATIC, 0.0, tf_static)
        out.write_rows(tp.TF_TOPIC, t, tf)
        out.write_rows("/sim/thrust", t, {"header": header(t), "frame": [PREFIX + f.frame for f in robot.fans],
                                          "thrust_n": np.asarray(record["thrust"], dtype=float).reshape(n, -1)})
        out.write_rows("/sim/com", t, pose_stamped(t, "world", np.asarray(record["com"], dtype=float)))
        has = np.array([c is not None for c in record["cop"]], dtype=bool)
        if has.any():
            cop = np.array([c for c in record["cop"] if c is not None], dtype=float)
            out.write_rows("/sim/cop", t[has], pose_stamped(t[has], "world", cop))
    out.write("/sim/steps", 0.0, step_markers(
        {"step": st["step"], "foothold_m": st.get("foothold_m", st["target_m"]), "landed_m": st["landed_m"],
         "error_m": st.get("foothold_error_m", st["landing_error_m"]), "slip_m": st["support_slip_m"],
         "turn_rad": st["support_turn_rad"]} for st in record.get("steps", [])))
    return out.finish()
