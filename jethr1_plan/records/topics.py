"""The topics of a plan's ``trajectory.mcap``, stated once: names and ROS 2 message types, in the
order the file registers them (:data:`PLAN_TOPICS`)."""

from __future__ import annotations

from typing import NamedTuple

__all__ = [
    "ANALYSIS",
    "COM",
    "JOINT_STATES",
    "JOINT_TRAJECTORY",
    "MARKERS",
    "PER_ROW",
    "PLAN_TOPICS",
    "POSE",
    "P_BODY",
    "ROBOT_DESCRIPTION",
    "STRING",
    "SWING_PATH",
    "SWING_SOLE",
    "TERRAIN",
    "TF",
    "TF_STATIC",
    "TF_TOPIC",
    "THRUST",
    "ZMP",
    "Topic",
]

STRING, TF, POSE = "std_msgs/msg/String", "tf2_msgs/msg/TFMessage", "geometry_msgs/msg/PoseStamped"
MARKERS = "visualization_msgs/msg/MarkerArray"


class Topic(NamedTuple):
    """A channel of a file: its ROS 2 message type, whether it is published once and kept for late
    subscribers (transient local), and what it carries (for the docs)."""

    type: str
    latched: bool
    what: str


ROBOT_DESCRIPTION, TF_STATIC, TF_TOPIC, TERRAIN, SWING_PATH = ("/robot_description", "/tf_static", "/tf", "/terrain",
                                                               "/swing_path")
JOINT_TRAJECTORY, JOINT_STATES, THRUST, ANALYSIS = "/joint_trajectory", "/joint_states", "/thrust", "/analysis"
P_BODY, COM, ZMP, SWING_SOLE = "/p_body", "/com", "/zmp", "/swing_sole"

#: the topics of a plan's ``trajectory.mcap``, in the order the file registers them
PLAN_TOPICS: dict[str, Topic] = {
    ROBOT_DESCRIPTION: Topic(STRING, True, "the robot's URDF (viewers build the robot from it)"),
    TF_STATIC: Topic(TF, True, "every fixed joint's parent → child link"),
    TF_TOPIC: Topic(TF, False, "per row: world → trunk and every moving joint's parent → child link"),
    TERRAIN: Topic(MARKERS, True, "a CUBE per carton"),
    SWING_PATH: Topic(MARKERS, True, "a LINE_STRIP per step through its swing samples"),
    JOINT_TRAJECTORY: Topic("trajectory_msgs/msg/JointTrajectory", False,
                            "once, at the start: the servo commands `<joint>_cmd_rad`, a point per row "
                            "(`time_from_start` = `time_s`): what a JointTrajectoryController executes"),
    JOINT_STATES: Topic("sensor_msgs/msg/JointState", False,
                        "per row: joint angles `<joint>_rad` (position) and static torques `<joint>_tau_nm` "
                        "(effort)"),
    THRUST: Topic("jethr1_msgs/msg/Thrust", False,
                  "per row: thrust and command per fan, the thrust window (NaN where none), the ZMP margin, "
                  "the tolerance share (NaN under the minimal policy), phase, support, step, sample, feasible, "
                  "reason"),
    ANALYSIS: Topic("jethr1_msgs/msg/LegAnalysis", False, "per row: κ of each leg, yaw momentum"),
    P_BODY: Topic(POSE, False, "per row: the trunk's pose `pelvis_*`"),
    COM: Topic(POSE, False, "per row: the centre of mass `com_*_m`"),
    ZMP: Topic(POSE, False, "per row: the ZMP `zmp_*_m` on the support sole's height"),
    SWING_SOLE: Topic(POSE, False, "per swing row (none in transfers): the swing sole's sample `swing_*_m`"),
}
#: the topics with a message per row
PER_ROW = (JOINT_STATES, THRUST, ANALYSIS, P_BODY, COM, ZMP)
