"""What the rehearsal's, the walk's and the balance space's MCAP files say, decoded by ``rosbags``
from the definitions they carry: the rehearsal's frames all prefixed ``sim/``; the walk's servo
commands one JointTrajectory, its figures and yaw horizons; the cells of each balance space with
their least thrust."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jethr1_plan.files.messages import EPOCH_NS
from jethr1_plan.files.walk_folder import read_walk_csv

rosbags_highlevel = pytest.importorskip("rosbags.highlevel")
from rosbags.typesys import Stores, get_typestore  # noqa: E402


def _topics(path) -> dict[str, list]:
    out: dict[str, list] = {}
    with rosbags_highlevel.AnyReader([path], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        for c, t, raw in reader.messages():
            out.setdefault(c.topic, []).append((t, reader.deserialize(raw, c.msgtype)))
    return out


def test_the_rehearsal_prefixes_every_robot_frame(written):
    topics = _topics(written["plan"] / "simulation.mcap")
    tf, static = topics["/tf"][0][1].transforms, topics["/tf_static"][0][1].transforms
    frames = {ts.child_frame_id for ts in [*tf, *static]} | ({ts.header.frame_id for ts in tf} - {"world"})
    assert len(frames) == 17 and all(f.startswith("sim/") for f in frames)
    urdf = topics["/sim/robot_description"][0][1].data
    assert '<link name="sim/trunk"' in urdf and '<link name="trunk"' not in urdf
    thrust = topics["/sim/thrust"]
    assert [list(m.frame) for _, m in thrust[:1]] == [["sim/left_fan", "sim/right_fan"]]
    assert max(max(m.thrust_n) for _, m in thrust) > 1.0  # the side step's swing fan thrusts
    assert len(topics["/tf"]) == len(thrust) == len(topics["/sim/com"]) >= len(topics["/sim/cop"]) > 0


def test_the_walk_says_what_its_csv_says(written):
    csv = read_walk_csv((written["walk"] / "trajectory.csv").read_text())
    topics = _topics(written["walk"] / "trajectory.mcap")
    n = len(csv["time_s"])
    joints = [k[:-8] for k in csv if k.endswith("_cmd_rad")]
    states = topics["/joint_states"]
    assert len(states) == n == len(topics["/tf"]) == len(topics["/walk_analysis"])
    for i in (0, n // 2, n - 1):
        t_ns, js = states[i]
        assert t_ns == EPOCH_NS + round(csv["time_s"][i] * 1e9)
        assert list(js.name) == joints
        np.testing.assert_array_equal(js.position, [csv[f"{j}_rad"][i] for j in joints])
        np.testing.assert_array_equal(js.effort, [csv[f"{j}_tau_nm"][i] for j in joints])
        wa = topics["/walk_analysis"][i][1]
        assert (wa.support, wa.kappa, wa.yaw_rad) == (csv["support"][i], csv["kappa"][i], csv["yaw_rad"][i])
    ((_, jt),) = topics["/joint_trajectory"]
    assert len(jt.points) == n and list(jt.joint_names) == joints
    np.testing.assert_array_equal(np.array([p.positions for p in jt.points]),
                                  np.column_stack([csv[f"{j}_cmd_rad"] for j in joints]))
    horizons = topics["/yaw_horizon"]
    assert len(horizons) == math.ceil(n / 10)  # one per MPC update (0.1 s at 100 Hz)
    for t_ns, h in horizons:
        t0 = (t_ns - EPOCH_NS) / 1e9
        np.testing.assert_allclose(h.time_s, t0 + h.dt_s * np.arange(1, len(h.yaw_ref_rad) + 1), atol=1e-9)
    (feet,) = [m for _, m in topics["/footsteps"]]
    assert len(feet.markers) == 2 + 2  # the start soles and two footholds


def test_balance_space_cells_carry_the_least_thrust(written):
    import csv as csv_module

    rows = list(csv_module.DictReader((written["balance_space"] / "balance_space.csv").open()))
    members = np.array([[float(r["x_m"]), float(r["y_m"]), float(r["z_m"]), float(r["min_thrust_n"])]
                        for r in rows if r["min_thrust_n"]])
    topics = _topics(written["balance_space"] / "balance_space.mcap")
    cloud = topics["/balance_space/with_thrust"][0][1]
    assert [f.name for f in cloud.fields] == ["x", "y", "z", "min_thrust_n"]
    values = np.frombuffer(bytes(cloud.data), "<f4").reshape(-1, 4).astype(float)
    assert cloud.width == len(values) == len(members) > 0
    np.testing.assert_allclose(values, members, atol=1e-5)  # float32 of the CSV's cells
    cells = topics["/balance_space/cells"][0][1].markers
    assert [m.type for m in cells] == [6, 6] and len(cells[0].points) == len(members)  # CUBE_LIST
    assert all(math.isclose(m.scale.x, 0.1) for m in cells)
