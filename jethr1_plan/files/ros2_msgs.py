"""The ROS 2 message definitions the project's MCAP files carry, as ``.msg`` text.

Standard types are ROS 2 Jazzy's (the current LTS): their fields, constants and defaults as ROS 2
defines them, comments left out (decoders do not read them). ``visualization_msgs/msg/Marker``
differs between distributions (Iron added ``texture_resource``, ``texture``, ``uv_coordinates``
and ``mesh_file``); viewers read the definition stored in the file, and ``ros2 bag play`` of a
MarkerArray topic needs Jazzy or later.

The project's own types (package ``jethr1_msgs``) name every field with its SI unit; a file carries
their definitions, so any ROS 2 MCAP reader decodes them without a ROS package.
"""

from __future__ import annotations

__all__ = ["JETHR1_MSGS", "MSGDEFS", "STANDARD_MSGDEFS", "dependencies", "schema_text"]

from collections.abc import Mapping

from jethr1_plan.files.msg_schema import PRIMITIVES, SEPARATOR, parse_schema, resolve_type

#: the standard types used, as ROS 2 Jazzy defines them (without the comments)
STANDARD_MSGDEFS: dict[str, str] = {
    "builtin_interfaces/msg/Time": "int32 sec\nuint32 nanosec\n",
    "builtin_interfaces/msg/Duration": "int32 sec\nuint32 nanosec\n",
    "std_msgs/msg/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "std_msgs/msg/String": "string data\n",
    "std_msgs/msg/ColorRGBA": "float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n",
    "geometry_msgs/msg/Point": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/msg/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/msg/Quaternion": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
    "geometry_msgs/msg/Pose": "Point position\nQuaternion orientation\n",
    "geometry_msgs/msg/PoseStamped": "std_msgs/Header header\nPose pose\n",
    "geometry_msgs/msg/Transform": "Vector3 translation\nQuaternion rotation\n",
    "geometry_msgs/msg/TransformStamped": "std_msgs/Header header\nstring child_frame_id\nTransform transform\n",
    "tf2_msgs/msg/TFMessage": "geometry_msgs/TransformStamped[] transforms\n",
    "sensor_msgs/msg/JointState": ("std_msgs/Header header\n\nstring[] name\nfloat64[] position\nfloat64[] velocity\n"
                                   "float64[] effort\n"),
    "sensor_msgs/msg/PointField": ("uint8 INT8    = 1\nuint8 UINT8   = 2\nuint8 INT16   = 3\nuint8 UINT16  = 4\n"
                                   "uint8 INT32   = 5\nuint8 UINT32  = 6\nuint8 FLOAT32 = 7\nuint8 FLOAT64 = 8\n\n"
                                   "string name\nuint32 offset\nuint8  datatype\nuint32 count\n"),
    "sensor_msgs/msg/PointCloud2": ("std_msgs/Header header\n\nuint32 height\nuint32 width\n\nPointField[] fields\n\n"
                                    "bool    is_bigendian\nuint32  point_step\nuint32  row_step\nuint8[] data\n\n"
                                    "bool is_dense\n"),
    "sensor_msgs/msg/CompressedImage": "std_msgs/Header header\n\nstring format\n\nuint8[] data\n",
    "trajectory_msgs/msg/JointTrajectoryPoint": ("float64[] positions\nfloat64[] velocities\nfloat64[] accelerations\n"
                                                 "float64[] effort\n\nbuiltin_interfaces/Duration time_from_start\n"),
    "trajectory_msgs/msg/JointTrajectory": ("std_msgs/Header header\n\nstring[] joint_names\n\n"
                                            "JointTrajectoryPoint[] points\n"),
    "visualization_msgs/msg/UVCoordinate": "float32 u\nfloat32 v\n",
    "visualization_msgs/msg/MeshFile": "string filename\n\nuint8[] data\n",
    "visualization_msgs/msg/Marker": (
        "int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\nint32 LINE_STRIP=4\nint32 LINE_LIST=5\n"
        "int32 CUBE_LIST=6\nint32 SPHERE_LIST=7\nint32 POINTS=8\nint32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\n"
        "int32 TRIANGLE_LIST=11\nint32 ARROW_STRIP=12\n\nint32 ADD=0\nint32 MODIFY=0\nint32 DELETE=2\n"
        "int32 DELETEALL=3\n\nstd_msgs/Header header\nstring ns\nint32 id\nint32 type\nint32 action\n"
        "geometry_msgs/Pose pose\ngeometry_msgs/Vector3 scale\nstd_msgs/ColorRGBA color\n"
        "builtin_interfaces/Duration lifetime\nbool frame_locked\n\ngeometry_msgs/Point[] points\n"
        "std_msgs/ColorRGBA[] colors\n\nstring texture_resource\nsensor_msgs/CompressedImage texture\n"
        "UVCoordinate[] uv_coordinates\n\nstring text\n\nstring mesh_resource\nMeshFile mesh_file\n"
        "bool mesh_use_embedded_materials\n"),
    "visualization_msgs/msg/MarkerArray": "Marker[] markers\n",
}

#: the project's own types: what no standard message says (SI units in every field name)
JETHR1_MSGS: dict[str, str] = {
    "jethr1_msgs/msg/Thrust": """\
# Planned fan thrust at one output row of a jethr1 plan, with the row's balance window.
std_msgs/Header header
string[] fan             # the robot's fans, as its YAML names them
float64[] thrust_n       # planned thrust of each fan [N]
float64[] thrust_cmd_n   # command to each fan, its first-order lag compensated [N]
float64 window_lo_n      # least total thrust that keeps the ZMP in the support polygon [N]; NaN: none
float64 window_hi_n      # most total thrust that keeps the ZMP in the support polygon [N]; NaN: none
float64 zmp_margin_m     # distance of the ZMP inside the support polygon [m]
float64 tolerance_share  # largest share of the plan's tolerance the row withstands (<= 1); NaN: minimal policy
string phase             # swing or transfer
string support           # left, right or both
int32 step               # index of the step in the scenario
int32 sample             # index of the swing sample in the step
bool feasible
string reason            # why the row is infeasible ('' when feasible)
""",
    "jethr1_msgs/msg/LegAnalysis": """\
# Figures of the legs at one output row of a jethr1 plan.
std_msgs/Header header
float64 kappa_left        # condition number of the left leg's Jacobian
float64 kappa_right       # condition number of the right leg's Jacobian
float64 yaw_momentum_nms  # yaw angular momentum about the CoM [N.m.s]
""",
    "jethr1_msgs/msg/FanThrust": """\
# Thrust applied by each fan (a rehearsal in the MuJoCo twin).
std_msgs/Header header
string[] frame      # the frame at which each fan's thrust acts
float64[] thrust_n  # thrust of each fan, along its axis [N]
""",
    "jethr1_msgs/msg/YawHorizon": """\
# The pelvic yaw reference over the MPC's horizon at one update (Paper B, Fig. 7).
std_msgs/Header header
float64 dt_s             # the MPC's period [s]
float64[] time_s         # time of each horizon sample from the walk's start [s]
float64[] yaw_ref_rad    # yaw reference at each horizon sample [rad]
float64 yaw_rad          # the pelvis' yaw now [rad]
float64 yaw_rate_rad_s   # the pelvis' yaw rate now [rad/s]
""",
    "jethr1_msgs/msg/WalkAnalysis": """\
# Figures of a walk at one control period (Paper B).
std_msgs/Header header
string support       # left, right or both
int32 step           # index of the step
float64 kappa        # condition number of the lower body's Jacobian (B-45)
float64 h_lower_nms  # yaw angular momentum of the lower body about the CoM (B-41) [N.m.s]
float64 h_upper_nms  # yaw angular momentum of the arms about the CoM (B-42) [N.m.s]
float64 zmp_margin_m # distance of the ZMP inside the support polygon [m]
float64 yaw_ref_rad  # pelvic yaw reference (B-30) [rad]
float64 yaw_rad      # pelvic yaw [rad]
""",
}

MSGDEFS: dict[str, str] = {**STANDARD_MSGDEFS, **JETHR1_MSGS}


def dependencies(type_name: str, msgdefs: Mapping[str, str] = MSGDEFS) -> list[str]:
    """The message types ``type_name`` uses, directly or not (full names), in the order of :func:`schema_text`."""
    return [resolve_type(line[5:], "") for line in schema_text(type_name, msgdefs).splitlines()
            if line.startswith("MSG: ")]


def schema_text(type_name: str, msgdefs: Mapping[str, str] = MSGDEFS) -> str:
    """The ``ros2msg`` schema of ``type_name`` as rosbag2 writes it: its definition, then each type it
    uses, once, depth first (a type's own in name order), after a blank line, a line of 80 ``=`` and
    ``MSG: pkg/Type`` (the name as the fields write it)."""
    seen: set[str] = set()

    def text_of(name: str) -> str:
        text = msgdefs[name]
        out = text
        for short in sorted({_short(f.type) for f in parse_schema(name, text)[name]
                             if f.type not in PRIMITIVES and f.type != "string"}):
            if short not in seen:
                seen.add(short)
                out += f"\n{SEPARATOR}\nMSG: {short}\n" + text_of(resolve_type(short, ""))
        return out

    return text_of(type_name)


def _short(full_name: str) -> str:
    """``pkg/msg/Type`` → ``pkg/Type``."""
    package, _, name = full_name.split("/")
    return f"{package}/{name}"
