"""``trajectory.mcap`` of a plan: every column of the plan's table comes back from the file as the
very float the CSV holds; the servo commands are one JointTrajectory a controller executes; /tf
composed from the file places every link where an independent URDF forward kinematics puts it; a
file with a row missing on one topic is bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jethr1_plan.errors import InputError
from jethr1_plan.files.mcap import Ros2Mcap, read_mcap
from jethr1_plan.files.messages import EPOCH_NS
from jethr1_plan.files.plan_csv import read_trajectory_csv
from jethr1_plan.files.plan_mcap import PLAN_TOPICS, read_trajectory_mcap
from jethr1_plan.files.plan_table import columns
from jethr1_plan.folders.plan import read_plan
from jethr1_plan.robot.urdf import urdf_joints


@pytest.fixture(scope="module")
def plan(written):
    return read_plan(written["plan"])


def _by_topic(path) -> dict[str, list]:
    out: dict[str, list] = {}
    for topic, _, msg, t in read_mcap(path.read_bytes()):
        out.setdefault(topic, []).append((t, msg))
    return out


def test_every_column_comes_back_as_the_csvs_float(plan, written):
    csv = read_trajectory_csv((written["plan"] / "trajectory.csv").read_text(), robot=plan.robot, complete=True)
    mcap = plan.tables[written["plan"] / "trajectory.mcap"]
    assert list(mcap) == columns(plan.robot)
    swinging = csv["phase"] == "swing"
    assert 0 < swinging.sum() < len(swinging)  # both swing rows and transfers (empty swing cells)
    for name in columns(plan.robot):
        a, b = csv[name], mcap[name]
        if a.dtype.kind in "Ob":
            assert list(a) == list(b), name
        else:
            np.testing.assert_array_equal(np.asarray(a, dtype=float), np.asarray(b, dtype=float), err_msg=name)
    assert np.isnan(mcap["swing_x_m"][~swinging]).all() and np.isfinite(mcap["swing_x_m"][swinging]).all()
    assert np.isnan(mcap["thrust_window_lo_n"]).any() == np.isnan(csv["thrust_window_lo_n"]).any()


def test_servo_commands_are_one_joint_trajectory_a_controller_executes(plan, written):
    """One point per row, ``time_from_start`` the row's time (strictly increasing), ``positions`` the
    ``<joint>_cmd_rad`` columns; stamp zero: the controller starts it on arrival."""
    ((log_ns, jt),) = _by_topic(written["plan"] / "trajectory.mcap")["/joint_trajectory"]
    table = plan.table
    assert log_ns == EPOCH_NS and (jt.header.stamp.sec, jt.header.stamp.nanosec) == (0, 0)
    assert list(jt.joint_names) == list(plan.robot.joint_names)
    assert len(jt.points) == len(table["time_s"]) > 100
    since = np.array([p.time_from_start.sec * 10**9 + p.time_from_start.nanosec for p in jt.points])
    assert np.all(np.diff(since) > 0)
    np.testing.assert_array_equal(since, np.round(table["time_s"] * 1e9).astype(np.int64))
    commands = np.column_stack([table[f"{j}_cmd_rad"] for j in plan.robot.joint_names])
    np.testing.assert_array_equal(np.array([p.positions for p in jt.points]), commands)
    assert all(len(p.velocities) == len(p.accelerations) == len(p.effort) == 0 for p in jt.points)


def _local(ts) -> tuple[str, np.ndarray]:
    tr, ro = ts.transform.translation, ts.transform.rotation
    x, y, z, w = ro.x, ro.y, ro.z, ro.w
    T = np.eye(4)
    T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    T[:3, 3] = (tr.x, tr.y, tr.z)
    return ts.header.frame_id, T


def _compose(frames: dict[str, tuple[str, np.ndarray]], frame: str) -> np.ndarray:
    T = np.eye(4)
    while frame != "world":
        parent, local = frames[frame]
        T = local @ T
        frame = parent
    return T


def test_tf_places_every_link_where_the_urdf_puts_it(plan, written, reference):
    """/tf_static and /tf composed from the file against an independent URDF forward kinematics."""
    topics = _by_topic(written["plan"] / "trajectory.mcap")
    table = plan.table
    static = {ts.child_frame_id: _local(ts) for ts in topics["/tf_static"][0][1].transforms}
    joints = plan.robot.joint_names
    assert len(topics["/tf"]) == len(table["time_s"])
    checked = 0
    for i in range(0, len(table["time_s"]), 97):
        t_ns, tf = topics["/tf"][i]
        assert t_ns == EPOCH_NS + round(table["time_s"][i] * 1e9)
        frames = {**static, **{ts.child_frame_id: _local(ts) for ts in tf.transforms}}
        yaw = 2 * math.atan2(table["pelvis_qz"][i], table["pelvis_qw"][i])
        p = [table[f"pelvis_{a}_m"][i] for a in "xyz"]
        poses = reference.link_poses(p, yaw, {j: table[f"{j}_rad"][i] for j in joints})
        for link, expected in poses.items():
            np.testing.assert_allclose(_compose(frames, link), expected, atol=1e-12, err_msg=link)
            checked += 1
    assert checked > 50
    moving = {ts.child_frame_id for ts in topics["/tf"][0][1].transforms}
    assert moving == {"trunk"} | {j.child for j in urdf_joints(plan.robot.urdf_path) if j.kind != "fixed"}


def test_cartons_swing_paths_and_the_swing_sole(plan, written):
    topics = _by_topic(written["plan"] / "trajectory.mcap")
    cartons = topics["/terrain"][0][1].markers
    assert len(cartons) == len(plan.cartons) > 0
    for marker, carton in zip(cartons, plan.cartons, strict=True):  # the top face where the carton's is
        assert marker.type == 1 and math.isclose(marker.pose.position.z + marker.scale.z / 2, carton.top_centre_m[2],
                                                 abs_tol=1e-12)
    paths = plan.swing_paths[written["plan"] / "trajectory.mcap"]
    assert len(paths) == len(topics["/swing_path"][0][1].markers) >= 1
    swing = np.column_stack([plan.table[f"swing_{a}_m"] for a in "xyz"])
    on = np.isfinite(swing).all(axis=1)
    assert len(topics["/swing_sole"]) == on.sum()
    # every planned swing sample lies on the swing path the file draws (on one of its segments)
    a = np.concatenate([p[:-1] for p in paths])
    b = np.concatenate([p[1:] for p in paths])
    for p in swing[on]:
        s = np.clip(np.einsum("ij,ij->i", p - a, b - a) / np.maximum(np.einsum("ij,ij->i", b - a, b - a), 1e-300), 0, 1)
        assert np.min(np.linalg.norm(a + s[:, None] * (b - a) - p, axis=1)) < 1e-9


def _rewrite_without(data: bytes, topic: str, index: int) -> bytes:
    """The file with message ``index`` of ``topic`` left out (raw CDR copied otherwise)."""
    import io

    from mcap.reader import make_reader
    from mcap.writer import Writer

    reader = make_reader(io.BytesIO(data))
    out = io.BytesIO()
    w = Writer(out)
    w.start(profile="ros2", library="test")
    schemas, channels, seen = {}, {}, 0
    for schema, channel, message in reader.iter_messages(log_time_order=False):
        if schema.id not in schemas:
            schemas[schema.id] = w.register_schema(schema.name, schema.encoding, schema.data)
        if channel.id not in channels:
            channels[channel.id] = w.register_channel(channel.topic, channel.message_encoding, schemas[schema.id],
                                                      channel.metadata)
        if channel.topic == topic:
            seen += 1
            if seen - 1 == index:
                continue
        w.add_message(channels[channel.id], message.log_time, message.data, message.publish_time)
    w.finish()
    return out.getvalue()


@pytest.mark.parametrize("topic, words", [("/com", "/com: 675 messages for 676 rows"),
                                          ("/thrust", "/joint_states: 676 messages for 675 rows")])
def test_a_row_missing_on_one_topic_is_bad_input(plan, written, topic, words):
    data = (written["plan"] / "trajectory.mcap").read_bytes()
    assert len(plan.table["time_s"]) == 676
    with pytest.raises(InputError, match=words.split(": ", 1)[1]) as err:
        read_trajectory_mcap(_rewrite_without(data, topic, 300), "t.mcap", plan.robot)
    assert words.split(":")[0] in str(err.value)


def test_an_empty_plan_file_reads_as_no_rows(robot):
    data = Ros2Mcap(PLAN_TOPICS).finish()
    table, paths = read_trajectory_mcap(data, "empty.mcap", robot)
    assert list(table) == columns(robot) and all(len(v) == 0 for v in table.values()) and paths == []
