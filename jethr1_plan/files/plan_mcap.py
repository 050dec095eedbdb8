"""``trajectory.mcap`` of a plan: its table (:mod:`.plan_table`) as ROS 2 messages, written and read
back here (:mod:`.mcap`). Every column of the table is recoverable from the file as the same float
the CSV holds: ``verify`` compares the two.

Topics: :data:`PLAN_TOPICS`. Times from the plan's start after the fixed epoch of :mod:`.mcap`.
"""

from __future__ import annotations

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.files.mcap import (
    EPOCH_NS,
    MARKERS,
    POSE,
    STRING,
    TF,
    Ros2Mcap,
    Topic,
    carton_markers,
    header,
    joint_state,
    joint_trajectory,
    pose_stamped,
    read_mcap,
    robot_transforms,
    seconds,
    swing_path_markers,
    urdf_message,
)
from jethr1_plan.files.plan_table import BOOL_COLUMNS, INT_COLUMNS, TEXT_COLUMNS, columns, plan_table, stack
from jethr1_plan.planning.sequence import Rows
from jethr1_plan.robot.model import RobotModel

__all__ = ["MAX_MCAP_BYTES", "PLAN_TOPICS", "read_trajectory_mcap", "table_mcap", "trajectory_mcap"]

MAX_MCAP_BYTES = 500_000_000

#: the topics of a plan's ``trajectory.mcap``, in the order the file registers them
PLAN_TOPICS: dict[str, Topic] = {
    "/robot_description": Topic(STRING, True, "the robot's URDF (viewers build the robot from it)"),
    "/tf_static": Topic(TF, True, "every fixed joint's parent → child link"),
    "/tf": Topic(TF, False, "per row: world → trunk and every moving joint's parent → child link"),
    "/terrain": Topic(MARKERS, True, "a CUBE per carton"),
    "/swing_path": Topic(MARKERS, True, "a LINE_STRIP per step through its swing samples"),
    "/joint_trajectory": Topic("trajectory_msgs/msg/JointTrajectory", False,
                               "once, at the start: the servo commands `<joint>_cmd_rad`, a point per row "
                               "(`time_from_start` = `time_s`): what a JointTrajectoryController executes"),
    "/joint_states": Topic("sensor_msgs/msg/JointState", False,
                           "per row: joint angles `<joint>_rad` (position) and static torques `<joint>_tau_nm` "
                           "(effort)"),
    "/thrust": Topic("jethr1_msgs/msg/Thrust", False,
                     "per row: thrust and command per fan, the thrust window (NaN where none), the ZMP margin, "
                     "the tolerance share (NaN under the minimal policy), phase, support, step, sample, feasible, "
                     "reason"),
    "/analysis": Topic("jethr1_msgs/msg/LegAnalysis", False, "per row: κ of each leg, yaw momentum"),
    "/p_body": Topic(POSE, False, "per row: the trunk's pose `pelvis_*`"),
    "/com": Topic(POSE, False, "per row: the centre of mass `com_*_m`"),
    "/zmp": Topic(POSE, False, "per row: the ZMP `zmp_*_m` on the support sole's height"),
    "/swing_sole": Topic(POSE, False, "per swing row (none in transfers): the swing sole's sample `swing_*_m`"),
}
_PER_ROW = ("/joint_states", "/thrust", "/analysis", "/p_body", "/com", "/zmp")


def trajectory_mcap(robot: RobotModel, rows: Rows, cartons, paths, table: dict[str, np.ndarray] | None = None) -> bytes:
    """The MCAP bytes of a planned trajectory: the plan's table (the CSV's numbers; ``table`` if the
    caller has it already) with the ZMP at the support sole's height, the cartons and the swing paths."""
    if table is None:
        table = plan_table(robot, rows)
    c = rows.columns
    ground = np.asarray(c["ground_z"], dtype=float) if "ground_z" in c and len(rows) else None
    return table_mcap(robot, table, cartons, paths, ground)


def table_mcap(robot: RobotModel, table: dict[str, np.ndarray], cartons, paths,
               zmp_height_m: np.ndarray | None = None) -> bytes:
    """The MCAP bytes of a plan's ``table`` (``zmp_height_m``: the ZMP's height per row [m], else 0)."""
    out = Ros2Mcap(PLAN_TOPICS)
    out.write("/robot_description", 0.0, urdf_message(robot))
    out.write("/terrain", 0.0, carton_markers(cartons))
    out.write("/swing_path", 0.0, swing_path_markers(paths))
    t = np.asarray(table["time_s"], dtype=float)
    n = len(t)
    if not n:
        return out.finish()
    names = list(robot.joint_names)
    fans = [f.name for f in robot.fans]
    p = stack(table, ("pelvis_x_m", "pelvis_y_m", "pelvis_z_m"))
    quat = stack(table, ("pelvis_qx", "pelvis_qy", "pelvis_qz", "pelvis_qw"))
    q = stack(table, [f"{j}_rad" for j in names])
    tf, tf_static = robot_transforms(robot, t, p, quat, q)
    out.write("/tf_static", 0.0, tf_static)
    out.write_rows("/tf", t, tf)
    out.write("/joint_trajectory", 0.0, joint_trajectory(names, t, stack(table, [f"{j}_cmd_rad" for j in names])))
    out.write_rows("/joint_states", t, joint_state(t, names, q, stack(table, [f"{j}_tau_nm" for j in names])))
    out.write_rows("/thrust", t, {
        "header": header(t), "fan": fans,
        "thrust_n": stack(table, [f"thrust_{f}_n" for f in fans]),
        "thrust_cmd_n": stack(table, [f"thrust_cmd_{f}_n" for f in fans]),
        "window_lo_n": np.asarray(table["thrust_window_lo_n"], dtype=float),
        "window_hi_n": np.asarray(table["thrust_window_hi_n"], dtype=float),
        "zmp_margin_m": np.asarray(table["zmp_margin_m"], dtype=float),
        "tolerance_share": np.asarray(table["tolerance_share"], dtype=float),
        "phase": [str(s) for s in table["phase"]], "support": [str(s) for s in table["support"]],
        "step": np.asarray(table["step"], dtype=np.int32), "sample": np.asarray(table["sample"], dtype=np.int32),
        "feasible": np.asarray(table["feasible"], dtype=bool), "reason": [str(s) for s in table["reason"]]})
    out.write_rows("/analysis", t, {"header": header(t), "kappa_left": np.asarray(table["kappa_left"], dtype=float),
                                    "kappa_right": np.asarray(table["kappa_right"], dtype=float),
                                    "yaw_momentum_nms": np.asarray(table["yaw_momentum_nms"], dtype=float)})
    out.write_rows("/p_body", t, pose_stamped(t, "world", p, quat))
    out.write_rows("/com", t, pose_stamped(t, "world", stack(table, ("com_x_m", "com_y_m", "com_z_m"))))
    height = np.zeros(n) if zmp_height_m is None else np.asarray(zmp_height_m, dtype=float).reshape(n)
    out.write_rows("/zmp", t, pose_stamped(t, "world", np.column_stack([stack(table, ("zmp_x_m", "zmp_y_m")),
                                                                        height])))
    swing = stack(table, ("swing_x_m", "swing_y_m", "swing_z_m"))
    at = np.flatnonzero(np.isfinite(swing).all(axis=1))
    out.write_rows("/swing_sole", t[at], pose_stamped(t[at], "world", swing[at]))
    return out.finish()


def read_trajectory_mcap(data: bytes, source: str, robot: RobotModel, max_expanded_bytes: int | None = None
                         ) -> tuple[dict[str, np.ndarray], list[np.ndarray]]:
    """A plan's table from its MCAP (every column of :func:`~.plan_table.columns`, the numbers the
    CSV holds) and its swing paths; the chunks expanding to at most ``max_expanded_bytes``
    (:func:`~.mcap.mcap_expanded_bytes`).

    Raises:
        InputError: not an MCAP file, or not a plan of ``robot`` in this format.
    """
    if len(data) > MAX_MCAP_BYTES:
        raise InputError(source, "", f"{len(data):,} bytes: larger than any plan's MCAP")
    try:
        messages = read_mcap(data, [*_PER_ROW, "/joint_trajectory", "/swing_path", "/swing_sole"], ordered=False,
                             max_expanded_bytes=max_expanded_bytes)
    except Exception as exc:  # the mcap readers raise many kinds on a corrupt file
        raise InputError(source, "", f"not a valid MCAP file ({type(exc).__name__}: {str(exc)[:80]})") from None
    by_topic: dict[str, list] = {}
    for topic, _, msg, t in messages:
        by_topic.setdefault(topic, []).append((t, msg))
    for topic, got in by_topic.items():  # in log-time order (stable: in file order at equal times)
        by_topic[topic] = sorted(got, key=lambda tm: tm[0])
    try:
        return _table(by_topic, source, robot), [
            np.array([[p.x, p.y, p.z] for p in m.points], dtype=float).reshape(-1, 3)
            for _, msg in by_topic.get("/swing_path", []) for m in msg.markers]
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
        raise InputError(source, "", f"not a trajectory of this format ({type(exc).__name__}: "
                         f"{str(exc)[:60]})") from None


def _table(by_topic: dict[str, list], source: str, robot: RobotModel) -> dict[str, np.ndarray]:
    """The table from each topic's (log time [ns], message) in log-time order."""
    times = np.array([t for t, _ in by_topic.get("/thrust", [])], dtype=np.int64)
    if len(np.unique(times)) != len(times):
        i = int(np.flatnonzero(np.diff(times) == 0)[0])
        raise InputError(source, "/thrust", f"two messages at t = {seconds(times[i]):.3f} s")
    for topic in _PER_ROW:
        own = np.array([t for t, _ in by_topic.get(topic, [])], dtype=np.int64)
        if len(own) != len(times) or np.any(own != times):
            odd = np.setxor1d(own, times)
            at = odd[0] if len(odd) else own[0]
            raise InputError(source, topic, f"{len(own)} messages for {len(times)} rows (t = {seconds(at):.3f} s)")
    rows = {topic: [m for _, m in by_topic[topic]] for topic in _PER_ROW if topic in by_topic}
    out: dict[str, np.ndarray] = {"time_s": seconds(times)}
    n = len(times)
    joints, fans = list(robot.joint_names), [f.name for f in robot.fans]
    if not n:
        return {k: np.zeros(0, dtype=object if k in TEXT_COLUMNS else bool if k in BOOL_COLUMNS else float)
                for k in columns(robot)}
    th = rows["/thrust"]
    for k in ("phase", "support", "reason"):
        out[k] = np.array([getattr(m, k) for m in th], dtype=object)
    out["step"] = np.array([m.step for m in th], dtype=int)
    out["sample"] = np.array([m.sample for m in th], dtype=int)
    out["feasible"] = np.array([m.feasible for m in th], dtype=bool)
    thrust = _by_name(th, "fan", "thrust_n", fans, source, "/thrust")
    command = _by_name(th, "fan", "thrust_cmd_n", fans, source, "/thrust")
    for c, f in enumerate(fans):
        out[f"thrust_{f}_n"], out[f"thrust_cmd_{f}_n"] = thrust[:, c], command[:, c]
    out["thrust_window_lo_n"] = np.array([m.window_lo_n for m in th], dtype=float)
    out["thrust_window_hi_n"] = np.array([m.window_hi_n for m in th], dtype=float)
    out["zmp_margin_m"] = np.array([m.zmp_margin_m for m in th], dtype=float)
    out["tolerance_share"] = np.array([m.tolerance_share for m in th], dtype=float)
    pose = rows["/p_body"]
    for a in "xyz":
        out[f"pelvis_{a}_m"] = np.array([getattr(m.pose.position, a) for m in pose], dtype=float)
    for a in "xyzw":
        out[f"pelvis_q{a}"] = np.array([getattr(m.pose.orientation, a) for m in pose], dtype=float)
    js = rows["/joint_states"]
    position = _by_name(js, "name", "position", joints, source, "/joint_states")
    effort = _by_name(js, "name", "effort", joints, source, "/joint_states")
    for a in "xyz":
        out[f"com_{a}_m"] = np.array([getattr(m.pose.position, a) for m in rows["/com"]], dtype=float)
    for a in "xy":
        out[f"zmp_{a}_m"] = np.array([getattr(m.pose.position, a) for m in rows["/zmp"]], dtype=float)
    an = rows["/analysis"]
    out["kappa_left"] = np.array([m.kappa_left for m in an], dtype=float)
    out["kappa_right"] = np.array([m.kappa_right for m in an], dtype=float)
    out["yaw_momentum_nms"] = np.array([m.yaw_momentum_nms for m in an], dtype=float)
    swing = np.full((n, 3), np.nan)
    index = {int(t): i for i, t in enumerate(times)}
    for t, m in by_topic.get("/swing_sole", []):
        if int(t) not in index:
            raise InputError(source, "/swing_sole", f"a message at t = {seconds(t):.3f} s, between rows")
        p = m.pose.position
        swing[index[int(t)]] = (p.x, p.y, p.z)
    for c, a in enumerate("xyz"):
        out[f"swing_{a}_m"] = swing[:, c]
    command_rad = _commands(by_topic.get("/joint_trajectory", []), times, joints, source)
    for c, j in enumerate(joints):
        out[f"{j}_rad"], out[f"{j}_tau_nm"], out[f"{j}_cmd_rad"] = position[:, c], effort[:, c], command_rad[:, c]
    for name in INT_COLUMNS:
        out[name] = out[name].astype(int)
    return {k: out[k] for k in columns(robot)}


def _by_name(messages: list, names_field: str, values_field: str, wanted: list[str], source: str,
             topic: str) -> np.ndarray:
    """(rows, len(wanted)) of a per-name array field (``position`` by ``name``), in ``wanted``'s order."""
    out = np.empty((len(messages), len(wanted)))
    for i, m in enumerate(messages):
        got = dict(zip(getattr(m, names_field), getattr(m, values_field), strict=True))
        missing = [w for w in wanted if w not in got]
        if missing:
            raise InputError(source, topic, f"no {values_field} of {missing[0]!r} at t = "
                             f"{(m.header.stamp.sec * 10**9 + m.header.stamp.nanosec - EPOCH_NS) / 1e9:.3f} s")
        out[i] = [got[w] for w in wanted]
    return out


def _commands(messages: list, times: np.ndarray, joints: list[str], source: str) -> np.ndarray:
    """The servo commands (rows, J) from the one JointTrajectory, a point per row."""
    if len(messages) != 1:
        raise InputError(source, "/joint_trajectory", f"{len(messages)} messages, expected one")
    jt = messages[0][1]
    if len(jt.points) != len(times):
        raise InputError(source, "/joint_trajectory", f"{len(jt.points)} points for {len(times)} rows")
    since = np.array([p.time_from_start.sec * 10**9 + p.time_from_start.nanosec for p in jt.points], dtype=np.int64)
    off = np.flatnonzero(since != times - EPOCH_NS)
    if len(off):
        raise InputError(source, "/joint_trajectory", f"point {off[0]} at {since[off[0]] / 1e9:.3f} s from the start, "
                         f"its row at {seconds(times[off[0]]):.3f} s")
    index = {name: k for k, name in enumerate(jt.joint_names)}
    missing = [j for j in joints if j not in index]
    if missing:
        raise InputError(source, "/joint_trajectory", f"no joint {missing[0]!r}")
    positions = np.array([p.positions for p in jt.points], dtype=float).reshape(len(times), -1)
    return positions[:, [index[j] for j in joints]]
