"""``trajectory.mcap`` of a plan: its table (:mod:`.plan_table`) as ROS 2 messages, written and read
back here (:mod:`.mcap`). Every column of the table is recoverable from the file as the same float
the CSV holds: ``verify`` compares the two.

Topics: :data:`PLAN_TOPICS`. Times from the plan's start after the fixed epoch of :mod:`.mcap`.
"""

from __future__ import annotations

import numpy as np

from jethr1_plan.errors import InputError
from jethr1_plan.files.mcap import Ros2Mcap, read_mcap
from jethr1_plan.files.messages import (
    EPOCH_NS,
    carton_markers,
    header,
    joint_state,
    joint_trajectory,
    pose_stamped,
    robot_transforms,
    seconds,
    swing_path_markers,
    urdf_message,
)
from jethr1_plan.files.plan_table import plan_table
from jethr1_plan.records import plan_columns as col
from jethr1_plan.records import topics as tp
from jethr1_plan.records.plan_columns import BOOL_COLUMNS, INT_COLUMNS, TEXT_COLUMNS, columns, stack
from jethr1_plan.records.plan_rows import RowField, Rows
from jethr1_plan.records.topics import PLAN_TOPICS
from jethr1_plan.robot.model import RobotModel

__all__ = ["MAX_MCAP_BYTES", "PLAN_TOPICS", "read_trajectory_mcap", "table_mcap", "trajectory_mcap"]

MAX_MCAP_BYTES = 500_000_000



def trajectory_mcap(robot: RobotModel, rows: Rows, cartons, paths, table: dict[str, np.ndarray] | None = None) -> bytes:
    """The MCAP bytes of a planned trajectory: the plan's table (the CSV's numbers; ``table`` if the
    caller has it already) with the ZMP at the support sole's height, the cartons and the swing paths."""
    if table is None:
        table = plan_table(robot, rows)
    ground = rows.array(RowField.GROUND_Z_M).astype(float) if len(rows) else None
    return table_mcap(robot, table, cartons, paths, ground)


def table_mcap(robot: RobotModel, table: dict[str, np.ndarray], cartons, paths,
               zmp_height_m: np.ndarray | None = None) -> bytes:
    """The MCAP bytes of a plan's ``table`` (``zmp_height_m``: the ZMP's height per row [m], else 0)."""
    out = Ros2Mcap(PLAN_TOPICS)
    out.write(tp.ROBOT_DESCRIPTION, 0.0, urdf_message(robot))
    out.write(tp.TERRAIN, 0.0, carton_markers(cartons))
    out.write(tp.SWING_PATH, 0.0, swing_path_markers(paths))
    t = np.asarray(table[col.TIME], dtype=float)
    n = len(t)
    if not n:
        return out.finish()
    names = list(robot.joint_names)
    fans = [f.name for f in robot.fans]
    p = stack(table, col.PELVIS)
    quat = stack(table, col.PELVIS_QUAT)
    q = stack(table, [col.joint_column(j) for j in names])
    tf, tf_static = robot_transforms(robot, t, p, quat, q)
    out.write(tp.TF_STATIC, 0.0, tf_static)
    out.write_rows(tp.TF_TOPIC, t, tf)
    out.write(tp.JOINT_TRAJECTORY, 0.0, joint_trajectory(names, t, stack(table, [col.cmd_column(j) for j in names])))
    out.write_rows(tp.JOINT_STATES, t, joint_state(t, names, q, stack(table, [col.tau_column(j) for j in names])))
    out.write_rows(tp.THRUST, t, {
        "header": header(t), "fan": fans,
        "thrust_n": stack(table, [col.thrust_column(f) for f in fans]),
        "thrust_cmd_n": stack(table, [col.thrust_cmd_column(f) for f in fans]),
        "window_lo_n": np.asarray(table[col.WINDOW[0]], dtype=float),
        "window_hi_n": np.asarray(table[col.WINDOW[1]], dtype=float),
        col.ZMP_MARGIN: np.asarray(table[col.ZMP_MARGIN], dtype=float),
        col.TOLERANCE_SHARE: np.asarray(table[col.TOLERANCE_SHARE], dtype=float),
        col.PHASE: [str(s) for s in table[col.PHASE]], col.SUPPORT: [str(s) for s in table[col.SUPPORT]],
        col.STEP: np.asarray(table[col.STEP], dtype=np.int32),
        col.SAMPLE: np.asarray(table[col.SAMPLE], dtype=np.int32),
        col.FEASIBLE: np.asarray(table[col.FEASIBLE], dtype=bool), col.REASON: [str(s) for s in table[col.REASON]]})
    out.write_rows(tp.ANALYSIS, t, {"header": header(t), col.KAPPA[0]: np.asarray(table[col.KAPPA[0]], dtype=float),
                                    col.KAPPA[1]: np.asarray(table[col.KAPPA[1]], dtype=float),
                                    col.YAW_MOMENTUM: np.asarray(table[col.YAW_MOMENTUM], dtype=float)})
    out.write_rows(tp.P_BODY, t, pose_stamped(t, "world", p, quat))
    out.write_rows(tp.COM, t, pose_stamped(t, "world", stack(table, col.COM)))
    height = np.zeros(n) if zmp_height_m is None else np.asarray(zmp_height_m, dtype=float).reshape(n)
    out.write_rows(tp.ZMP, t, pose_stamped(t, "world", np.column_stack([stack(table, col.ZMP),
                                                                        height])))
    swing = stack(table, col.SWING)
    at = np.flatnonzero(np.isfinite(swing).all(axis=1))
    out.write_rows(tp.SWING_SOLE, t[at], pose_stamped(t[at], "world", swing[at]))
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
        messages = read_mcap(data, [*tp.PER_ROW, tp.JOINT_TRAJECTORY, tp.SWING_PATH, tp.SWING_SOLE], ordered=False,
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
            for _, msg in by_topic.get(tp.SWING_PATH, []) for m in msg.markers]
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
        raise InputError(source, "", f"not a trajectory of this format ({type(exc).__name__}: "
                         f"{str(exc)[:60]})") from None


def _table(by_topic: dict[str, list], source: str, robot: RobotModel) -> dict[str, np.ndarray]:
    """The table from each topic's (log time [ns], message) in log-time order."""
    times = np.array([t for t, _ in by_topic.get(tp.THRUST, [])], dtype=np.int64)
    if len(np.unique(times)) != len(times):
        i = int(np.flatnonzero(np.diff(times) == 0)[0])
        raise InputError(source, tp.THRUST, f"two messages at t = {seconds(times[i]):.3f} s")
    for topic in tp.PER_ROW:
        own = np.array([t for t, _ in by_topic.get(topic, [])], dtype=np.int64)
        if len(own) != len(times) or np.any(own != times):
            odd = np.setxor1d(own, times)
            at = odd[0] if len(odd) else own[0]
            raise InputError(source, topic, f"{len(own)} messages for {len(times)} rows (t = {seconds(at):.3f} s)")
    rows = {topic: [m for _, m in by_topic[topic]] for topic in tp.PER_ROW if topic in by_topic}
    out: dict[str, np.ndarray] = {col.TIME: seconds(times)}
    n = len(times)
    joints, fans = list(robot.joint_names), [f.name for f in robot.fans]
    if not n:
        return {k: np.zeros(0, dtype=object if k in TEXT_COLUMNS else bool if k in BOOL_COLUMNS else float)
                for k in columns(robot)}
    th = rows[tp.THRUST]
    for k in TEXT_COLUMNS:  # the Thrust message's fields are named as the columns
        out[k] = np.array([getattr(m, k) for m in th], dtype=object)
    out[col.STEP] = np.array([m.step for m in th], dtype=int)
    out[col.SAMPLE] = np.array([m.sample for m in th], dtype=int)
    out[col.FEASIBLE] = np.array([m.feasible for m in th], dtype=bool)
    thrust = _by_name(th, "fan", "thrust_n", fans, source, tp.THRUST)
    command = _by_name(th, "fan", "thrust_cmd_n", fans, source, tp.THRUST)
    for c, f in enumerate(fans):
        out[col.thrust_column(f)], out[col.thrust_cmd_column(f)] = thrust[:, c], command[:, c]
    out[col.WINDOW[0]] = np.array([m.window_lo_n for m in th], dtype=float)
    out[col.WINDOW[1]] = np.array([m.window_hi_n for m in th], dtype=float)
    out[col.ZMP_MARGIN] = np.array([m.zmp_margin_m for m in th], dtype=float)
    out[col.TOLERANCE_SHARE] = np.array([m.tolerance_share for m in th], dtype=float)
    pose = rows[tp.P_BODY]
    for a, name in zip("xyz", col.PELVIS, strict=True):
        out[name] = np.array([getattr(m.pose.position, a) for m in pose], dtype=float)
    for a, name in zip("xyzw", col.PELVIS_QUAT, strict=True):
        out[name] = np.array([getattr(m.pose.orientation, a) for m in pose], dtype=float)
    js = rows[tp.JOINT_STATES]
    position = _by_name(js, "name", "position", joints, source, tp.JOINT_STATES)
    effort = _by_name(js, "name", "effort", joints, source, tp.JOINT_STATES)
    for a, name in zip("xyz", col.COM, strict=True):
        out[name] = np.array([getattr(m.pose.position, a) for m in rows[tp.COM]], dtype=float)
    for a, name in zip("xy", col.ZMP, strict=True):
        out[name] = np.array([getattr(m.pose.position, a) for m in rows[tp.ZMP]], dtype=float)
    an = rows[tp.ANALYSIS]
    out[col.KAPPA[0]] = np.array([m.kappa_left for m in an], dtype=float)
    out[col.KAPPA[1]] = np.array([m.kappa_right for m in an], dtype=float)
    out[col.YAW_MOMENTUM] = np.array([m.yaw_momentum_nms for m in an], dtype=float)
    swing = np.full((n, 3), np.nan)
    index = {int(t): i for i, t in enumerate(times)}
    for t, m in by_topic.get(tp.SWING_SOLE, []):
        if int(t) not in index:
            raise InputError(source, tp.SWING_SOLE, f"a message at t = {seconds(t):.3f} s, between rows")
        p = m.pose.position
        swing[index[int(t)]] = (p.x, p.y, p.z)
    for c, name in enumerate(col.SWING):
        out[name] = swing[:, c]
    command_rad = _commands(by_topic.get(tp.JOINT_TRAJECTORY, []), times, joints, source)
    for c, j in enumerate(joints):
        out[col.joint_column(j)], out[col.tau_column(j)] = position[:, c], effort[:, c]
        out[col.cmd_column(j)] = command_rad[:, c]
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
        raise InputError(source, tp.JOINT_TRAJECTORY, f"{len(messages)} messages, expected one")
    jt = messages[0][1]
    if len(jt.points) != len(times):
        raise InputError(source, tp.JOINT_TRAJECTORY, f"{len(jt.points)} points for {len(times)} rows")
    since = np.array([p.time_from_start.sec * 10**9 + p.time_from_start.nanosec for p in jt.points], dtype=np.int64)
    off = np.flatnonzero(since != times - EPOCH_NS)
    if len(off):
        raise InputError(source, tp.JOINT_TRAJECTORY, f"point {off[0]} at {since[off[0]] / 1e9:.3f} s from the start, "
                         f"its row at {seconds(times[off[0]]):.3f} s")
    index = {name: k for k, name in enumerate(jt.joint_names)}
    missing = [j for j in joints if j not in index]
    if missing:
        raise InputError(source, tp.JOINT_TRAJECTORY, f"no joint {missing[0]!r}")
    positions = np.array([p.positions for p in jt.points], dtype=float).reshape(len(times), -1)
    return positions[:, [index[j] for j in joints]]
