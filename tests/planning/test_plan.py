"""`jethr1 plan` end to end: outputs re-checked independently of the planner's internals."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from jethr1_plan.cli import run
from jethr1_plan.files.mcap import read_mcap
from jethr1_plan.files.plan_csv import columns, read_trajectory_csv
from jethr1_plan.files.plan_mcap import PLAN_TOPICS
from jethr1_plan.geometry import convex_hull, inside_polygon, sole_polygon
from jethr1_plan.io.record import RECORD
from jethr1_plan.physics.balance import zmp_with_thrust
from jethr1_plan.scenario import load_scenario
from tests.conftest import JOINT_NAMES, ROOT

FORWARD = ROOT / "configs" / "forward_ditch_450.yaml"


@pytest.fixture(scope="module")
def planned(plan_of):
    return plan_of(FORWARD.stem)


def test_outputs_exist_and_summary_reports(planned):
    assert sorted(p.name for p in planned.iterdir() if p.name != RECORD) == ["optimised_steps.json", "summary.json",
                                                                            "trajectory.csv", "trajectory.mcap"]
    s = json.loads((planned / "summary.json").read_text())
    assert s["feasible"] is True and s["optimiser"] == "sqp" and s["seed"] == 1  # sqp: the default
    assert 0 < s["peak_thrust_n"] <= 23.0
    assert s["evaluations"] > 0 and s["wall_s"] > 0 and s["sample_count"] == 60
    for key in ("smoothness_m2", "max_step_m", "max_thrust_jump_n", "mean_thrust_n", "version", "steps"):
        assert key in s


def test_csv_header_is_the_contract(planned, robot):
    header = (planned / "trajectory.csv").read_text().split("\n", 1)[0].split(",")
    assert header == columns(robot)
    assert header[:6] == ["time_s", "step", "phase", "sample", "support", "feasible"]
    assert header[13:25] == [f"{j}_rad" for j in JOINT_NAMES]
    assert header[25:35] == ["swing_x_m", "swing_y_m", "swing_z_m", "thrust_left_n", "thrust_right_n",
                             "com_x_m", "com_y_m", "com_z_m", "zmp_x_m", "zmp_y_m"]


def test_trajectory_rechecked_with_placo(planned, robot):
    """Put the written pose and joints into a fresh PlaCo robot and re-check every row."""
    sc = load_scenario(FORWARD)
    c = read_trajectory_csv((planned / "trajectory.csv").read_text())
    wrapper = robot.wrapper()
    n = len(c["time_s"])
    assert n == round((3 * 2 + 7.5) * 50) + 1
    np.testing.assert_allclose(np.diff(c["time_s"]), 1 / 50, atol=1e-9)
    assert np.all(c["feasible"])
    q = np.stack([c[f"{j}_rad"] for j in JOINT_NAMES], axis=1)
    assert np.all(q >= robot.lower_rad - 1e-12) and np.all(q <= robot.upper_rad + 1e-12)
    path = sc.steps[0].path_m
    start = sc.start
    landing = sc.steps[0].landing_m
    for i in range(n):
        T = np.eye(4)
        qx, qy, qz, qw = c["pelvis_qx"][i], c["pelvis_qy"][i], c["pelvis_qz"][i], c["pelvis_qw"][i]
        assert qx == 0 and qy == 0 and abs(qz * qz + qw * qw - 1) < 1e-12  # trunk level (Precondition 1)
        yaw = 2 * np.arctan2(qz, qw)
        T[:3, :3] = [[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]]
        T[:3, 3] = [c["pelvis_x_m"][i], c["pelvis_y_m"][i], c["pelvis_z_m"][i]]
        wrapper.set_T_world_fbase(T)
        wrapper.state.q[7:] = q[i]
        wrapper.update_kinematics()
        right = wrapper.get_T_world_frame("right_foot")
        left = wrapper.get_T_world_frame("left_foot")
        # support foot fixed and flat
        assert np.linalg.norm(right[:3, 3] - start["right"]) < 1e-6
        for foot in (left, right):
            assert np.linalg.norm(foot[:3, :3] - np.eye(3)) < 2e-6
        com = wrapper.com_world()
        np.testing.assert_allclose(com, [c["com_x_m"][i], c["com_y_m"][i], c["com_z_m"][i]], atol=1e-12)
        thrust = {"left": c["thrust_left_n"][i], "right": c["thrust_right_n"][i]}
        assert 0 <= thrust["left"] <= 23.0 and thrust["right"] == 0.0
        fan = wrapper.get_T_world_frame("left_fan")[:2, 3]
        zmp = zmp_with_thrust(com[:2], fan, thrust["left"], robot.mass_kg)
        np.testing.assert_allclose(zmp, [c["zmp_x_m"][i], c["zmp_y_m"][i]], atol=1e-9)
        if c["phase"][i] == "swing":
            swing = np.array([c["swing_x_m"][i], c["swing_y_m"][i], c["swing_z_m"][i]])
            assert np.linalg.norm(left[:3, 3] - swing) < 1e-6  # swing sole on its sample
            seg = _distance_to_polyline(swing, path)
            assert seg < 1e-9  # the sample lies on the scenario's swing path
            sole = sole_polygon(start["right"][:2], 0.0, robot.sole_length_m, robot.sole_width_m)
            assert inside_polygon(zmp, sole, tol_m=1e-9)
        else:
            feet_left = start["left"] if c["step"][i] == 0 else landing
            assert np.linalg.norm(left[:3, 3] - feet_left) < 1e-6
            hull = convex_hull(np.vstack([sole_polygon(p[:2], 0.0, robot.sole_length_m, robot.sole_width_m)
                                          for p in (feet_left, start["right"])]))
            assert inside_polygon(zmp, hull, tol_m=1e-9)


def _distance_to_polyline(p, pts):
    best = np.inf
    for a, b in itertools.pairwise(pts):
        t = np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0, 1)
        best = min(best, np.linalg.norm(a + t * (b - a) - p))
    return best


def test_mcap_carries_the_declared_topics_and_the_robot_frames(planned, robot):
    msgs = read_mcap((planned / "trajectory.mcap").read_bytes())
    assert {(m[0], m[1]) for m in msgs} == {(name, t.type) for name, t in PLAN_TOPICS.items()}
    tf = [m for m in msgs if m[0] == "/tf"]
    (static,) = [m[2] for m in msgs if m[0] == "/tf_static"]
    moving = {t.child_frame_id for t in tf[0][2].transforms}
    fixed = {t.child_frame_id for t in static.transforms}
    assert {"left_foot", "right_foot", "left_fan", "right_fan"} == fixed  # the sole and fan frames
    assert "trunk" in moving and len(moving) == 1 + 12  # world→trunk, 12 revolute joints
    times = [m[3] for m in tf]
    assert times == sorted(times) and len(times) == len(set(times))
    (terrain,) = [m[2] for m in msgs if m[0] == "/terrain"]
    assert len(terrain.markers) == 3 and all(m.type == 1 for m in terrain.markers)  # CUBE per carton


def test_same_seed_same_bytes(planned, tmp_path):
    assert run(["plan", str(FORWARD), "-o", str(tmp_path), "--no-progress"]) == 0
    for name in ("trajectory.csv", "trajectory.mcap"):
        assert (tmp_path / "forward_ditch_450" / name).read_bytes() == (planned / name).read_bytes()


def _small_two_step(tmp_path: Path, **balance) -> Path:
    doc = yaml.safe_load((ROOT / "configs" / "jet_hr1_trial.yaml").read_text())
    doc["optimiser"] = {"initial": {"population": 40, "generations": 10},
                        "intermediate": {"population": 40, "generations": 8}}
    for st in doc["steps"]:
        st["path"]["samples"] = 25
    doc["steps"][1]["landing_m"] = [0.45, -0.1125, 0.0]
    doc["terrain"]["cartons"][3]["top_centre_m"] = [0.45, -0.1125, 0.0]
    doc["timing"] = {"swing_s": 3.0, "transfer_s": 1.5, "rate_hz": 20.0}  # (the soles' grip: a GA this small jumps
    # its path between samples; faster, a row needs more friction than μ / 2)
    doc["balance"] = {"thrust_max_n": 23.0, "policy": "minimal", **balance}  # a GA this small: Paper A's policy
    p = tmp_path / "small_two_step.yaml"
    p.write_text(yaml.safe_dump(doc))
    return p


@pytest.mark.parametrize("optimiser", ["gas", "sqp"])
def test_parallel_steps_give_identical_bytes(tmp_path, optimiser):
    """Steps planned in worker processes give the same bytes as in one process (sqp did not, by up to
    4.6 mm of P_body: a multi-threaded BLAS in the main process sums in another order)."""
    path = _small_two_step(tmp_path)
    for folder, jobs in (("a", "1"), ("b", "2")):
        assert run(["plan", str(path), "-o", str(tmp_path / folder), "--no-progress", "-j", jobs,
                    "--optimiser", optimiser]) == 0
    for name in ("trajectory.csv", "trajectory.mcap"):
        assert (tmp_path / "a" / "small_two_step" / name).read_bytes() == \
            (tmp_path / "b" / "small_two_step" / name).read_bytes()


def test_no_thrust_over_the_ditch_is_exit_3(tmp_path, capsys):
    doc = yaml.safe_load(FORWARD.read_text())
    doc["balance"]["thrust_max_n"] = 0.0
    path = tmp_path / "no_fan.yaml"
    path.write_text(yaml.safe_dump(doc))
    assert run(["plan", str(path), "-o", str(tmp_path / "o"), "--no-progress"]) == 3
    err = capsys.readouterr().err
    assert "sample" in err and "thrust" in err
    folder = tmp_path / "o" / "no_fan"
    assert sorted(p.name for p in folder.iterdir() if p.name != RECORD) == ["summary.json"]
    s = json.loads((folder / "summary.json").read_text())
    assert s["feasible"] is False
    bad = s["first_infeasible"]
    # the least thrust there is above the 0 N limit, or none balances at all (sqp reports the latter)
    assert bad["step"] == 0 and bad["phase"] == "swing" and (bad["thrust_n"] is None or bad["thrust_n"] > 0)
    # the first samples, with the swing foot still beside the support foot, balance without thrust
    assert bad["sample"] > 0 and s["steps"][0]["samples"] == bad["sample"] + 1


def test_write_infeasible_marks_rows(tmp_path):
    path = _small_two_step(tmp_path, thrust_max_n=0.0)
    assert run(["plan", str(path), "-o", str(tmp_path / "o"), "--no-progress", "--write-infeasible"]) == 3
    c = read_trajectory_csv((tmp_path / "o" / "small_two_step" / "trajectory.csv").read_text())
    bad = ~c["feasible"]
    assert bad.any() and np.all(c["reason"][bad] != "") and np.all(c["reason"][~bad] == "")
    # with no thrust allowed, every row that needs thrust is marked infeasible, and the others are not
    needs_thrust = (c["thrust_left_n"] > 0) | (c["thrust_right_n"] > 0)
    assert needs_thrust.any() and np.all(bad[needs_thrust])


def test_json_summary_on_stdout(tmp_path, capsys):
    path = _small_two_step(tmp_path)
    assert run(["plan", str(path), "-o", str(tmp_path / "o"), "--no-progress", "--json"]) == 0
    out = capsys.readouterr().out
    assert json.loads(out) == json.loads((tmp_path / "o" / "small_two_step" / "summary.json").read_text())


def _compose(transforms: list, frame: str) -> np.ndarray:
    """World pose of ``frame`` from geometry_msgs/TransformStamped messages (parent → child)."""
    by_child = {t.child_frame_id: t for t in transforms}
    T = np.eye(4)
    while frame != "world":
        t = by_child[frame]
        r, p = t.transform.rotation, t.transform.translation
        x, y, z, w = r.x, r.y, r.z, r.w
        R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                      [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                      [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        local = np.eye(4)
        local[:3, :3] = R
        local[:3, 3] = [p.x, p.y, p.z]
        T = local @ T
        frame = t.header.frame_id
    return T


def test_tf_moves_the_feet_where_the_csv_says(planned):
    """Composing /tf from world to each sole reproduces the planned feet (what Foxglove will show)."""
    sc = load_scenario(FORWARD)
    c = read_trajectory_csv((planned / "trajectory.csv").read_text())
    msgs = read_mcap((planned / "trajectory.mcap").read_bytes())
    tf = [m for m in msgs if m[0] == "/tf"]
    (static,) = [m[2].transforms for m in msgs if m[0] == "/tf_static"]
    assert len(tf) == len(c["time_s"])
    for i in range(0, len(tf), 37):
        transforms = [*tf[i][2].transforms, *static]
        right = _compose(transforms, "right_foot")
        np.testing.assert_allclose(right[:3, 3], sc.start["right"], atol=1e-6)
        np.testing.assert_allclose(right[:3, :3], np.eye(3), atol=2e-6)
        if c["phase"][i] == "swing":
            left = _compose(transforms, "left_foot")
            np.testing.assert_allclose(left[:3, 3], [c["swing_x_m"][i], c["swing_y_m"][i], c["swing_z_m"][i]],
                                       atol=1e-6)


def test_torques_kappa_and_energy_are_written(planned, robot):
    from jethr1_plan.physics.statics import leg_condition_numbers, static_torques

    c = read_trajectory_csv((planned / "trajectory.csv").read_text())
    s = json.loads((planned / "summary.json").read_text())
    tau = np.stack([c[f"{j}_tau_nm"] for j in JOINT_NAMES], axis=1)
    assert s["torques"]["rows_over_servo_limit"] == int(np.sum((np.abs(tau) / robot.servo_limit_nm).max(axis=1) > 1))
    assert s["torques"]["max_ratio_to_servo_limit"] == pytest.approx((np.abs(tau) / robot.servo_limit_nm).max())
    assert s["energy_j"] > 0 and s["kappa"]["max_left"] >= 1 and s["yaw_momentum_peak_nms"] >= 0
    # one swing row recomputed from its written posture
    i = int(np.argmax(np.where(c["phase"] == "swing", c["thrust_left_n"], -1)))
    wrapper = robot.wrapper()
    yaw = 2 * np.arctan2(c["pelvis_qz"][i], c["pelvis_qw"][i])
    T = np.eye(4)
    T[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
    T[:3, 3] = [c["pelvis_x_m"][i], c["pelvis_y_m"][i], c["pelvis_z_m"][i]]
    wrapper.set_T_world_fbase(T)
    wrapper.state.q[7:] = [c[f"{j}_rad"][i] for j in JOINT_NAMES]
    wrapper.update_kinematics()
    expect, _ = static_torques(robot, wrapper, np.array([c["thrust_left_n"][i], 0.0]), ("right",))
    np.testing.assert_allclose(tau[i], expect, atol=1e-9)
    k = leg_condition_numbers(robot, wrapper)
    assert c["kappa_left"][i] == pytest.approx(k["left"]) and c["kappa_right"][i] == pytest.approx(k["right"])


def test_strict_torque_makes_weak_servos_infeasible(tmp_path):
    import shutil

    robot_dir = tmp_path / "weakbot"
    shutil.copytree(ROOT / "robots" / "jethr1", robot_dir)
    (robot_dir / "jethr1.yaml").write_text((robot_dir / "jethr1.yaml").read_text()
                                           .replace("stall_torque_nm: 7.8", "stall_torque_nm: 1.0"))
    path = _small_two_step(tmp_path)
    doc = yaml.safe_load(path.read_text())
    doc["robot"] = str(robot_dir)
    path.write_text(yaml.safe_dump(doc))
    assert run(["plan", str(path), "-o", str(tmp_path / "o"), "--no-progress"]) == 0
    s = json.loads((tmp_path / "o" / "small_two_step" / "summary.json").read_text())
    assert s["torques"]["rows_over_servo_limit"] > 0  # flagged, not fatal
    assert run(["plan", str(path), "-o", str(tmp_path / "o2"), "--no-progress", "--strict-torque"]) == 3
    s = json.loads((tmp_path / "o2" / "small_two_step" / "summary.json").read_text())
    assert "servo limit" in s["first_infeasible"]["reason"]


def test_explicit_point_path_plans(tmp_path):
    """A `kind: points` swing path is followed sample by sample."""
    doc = yaml.safe_load((ROOT / "configs" / "side_step.yaml").read_text())
    from jethr1_plan.swing_path import arc_path

    pts = arc_path(np.array([0.0, 0.1125, 0.0]), np.array([0.0, 0.35, 0.0]), 0.08, 12)
    doc["steps"][0]["path"] = {"kind": "points", "points_m": pts.tolist()}
    doc["optimiser"] = {"initial": {"population": 60, "generations": 12},
                        "intermediate": {"population": 40, "generations": 5}}
    doc["timing"] = {"swing_s": 1.0, "transfer_s": 0.5, "rate_hz": 20.0}
    doc["balance"]["policy"] = "minimal"
    path = tmp_path / "points.yaml"
    path.write_text(yaml.safe_dump(doc))
    assert run(["plan", str(path), "-o", str(tmp_path / "o"), "--no-progress"]) == 0
    c = read_trajectory_csv((tmp_path / "o" / "points" / "trajectory.csv").read_text())
    swing = np.stack([c["swing_x_m"], c["swing_y_m"], c["swing_z_m"]], axis=1)[c["phase"] == "swing"]
    assert max(_distance_to_polyline(p, pts) for p in swing) < 1e-9
    assert swing[:, 2].max() > 0.06  # it follows the raised points, not the chord


def test_the_mcap_shows_the_robot_by_itself(planned, robot):
    """The URDF travels in the file (std_msgs/String: the topic form Foxglove's URDF layer and Rerun
    read), times start at the documented epoch, every chunk's CRC is valid."""
    import datetime

    from jethr1_plan.files.messages import EPOCH_NS

    msgs = read_mcap((planned / "trajectory.mcap").read_bytes())  # validates the CRCs
    desc = [m for m in msgs if m[0] == "/robot_description"]
    assert len(desc) == 1 and desc[0][1] == "std_msgs/msg/String"
    assert desc[0][2].data == robot.urdf_path.read_text()
    first = min(m[3] for m in msgs)
    assert first == EPOCH_NS
    assert datetime.datetime.fromtimestamp(first / 1e9, datetime.UTC).isoformat() == "2000-01-01T00:00:00+00:00"


def test_torques_do_not_jump_where_a_foot_lands_or_lifts(planned, robot):
    """The double-support split moves the load over with the ZMP (``physics.statics.load_split``): a
    transfer starts on the sole the swing before stood on and ends on the one the next swing stands on, so
    the static torques, and the servo commands built on them, change across a touchdown or a lift-off no
    more than between two rows of one phase (a least-norm split jumps by a large part of the knee's load)."""
    c = read_trajectory_csv((planned / "trajectory.csv").read_text())
    tau = np.stack([c[f"{j}_tau_nm"] for j in JOINT_NAMES], axis=1)
    step = np.abs(np.diff(tau, axis=0)).max(axis=1)
    change = c["phase"][1:] != c["phase"][:-1]
    assert change.sum() >= 2  # a touchdown and a lift-off at least
    assert step[change].max() <= max(0.05, 2.0 * step[~change].max())
