"""`jethr1 balance-space`: outputs, independence from workers, physics re-check, agreement with exhaustive."""

from __future__ import annotations

import json

import numpy as np
import pytest

from jethr1_plan.balance_space.sweep import SweepSpec, sweep_layers
from jethr1_plan.cli import run
from jethr1_plan.files.balance_space import BALANCE_SPACE_TOPICS
from jethr1_plan.files.mcap import read_mcap
from jethr1_plan.geometry import inside_polygon, sole_polygon
from jethr1_plan.kinematics import Stance
from jethr1_plan.kinematics.placo import PlacoPostureSolver
from jethr1_plan.optimisers.exhaustive import exhaustive_cell
from jethr1_plan.optimisers.search import Evaluator
from jethr1_plan.physics.balance import edge_angle_error, minimal_thrust
from jethr1_plan.reasons import Reason

ARGS = ["balance-space", "--resolution", "0.1", "--no-progress"]


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    out = tmp_path_factory.mktemp("bs")
    assert run([*ARGS, "-o", str(out / "j1"), "-j", "1"]) == 0
    assert run([*ARGS, "-o", str(out / "j2"), "-j", "2"]) == 0
    return out


def _read(path):
    lines = path.read_text().strip().split("\n")
    header = lines[0].split(",")
    rows = [dict(zip(header, ln.split(",", len(header) - 1), strict=True)) for ln in lines[1:]]
    return header, rows


def test_outputs_do_not_depend_on_the_number_of_workers(swept):
    for name in ("balance_space.csv", "balance_space.mcap"):
        assert (swept / "j1" / name).read_bytes() == (swept / "j2" / name).read_bytes()
    a = json.loads((swept / "j1" / "summary.json").read_text())
    b = json.loads((swept / "j2" / "summary.json").read_text())
    a.pop("wall_s"), b.pop("wall_s")
    assert a == b


def test_summary_and_csv(swept):
    s = json.loads((swept / "j1" / "summary.json").read_text())
    assert s["support"] == {"side": "right", "position_m": [0.0, -0.1125, 0.0]}
    assert s["sole"] == {"length_m": 0.16, "width_m": 0.09}
    w, wo = s["with_thrust"], s["without_thrust"]
    assert w["cells"] > wo["cells"] > 0
    # the fan extends the reach, forward and sideways (Paper A, Fig. 5)
    assert w["max_forward_m"] > wo["max_forward_m"] + 0.15 and w["max_sideways_m"] > wo["max_sideways_m"] + 0.1
    assert s["verified_members"] == w["cells"]
    header, rows = _read(swept / "j1" / "balance_space.csv")
    assert header == ["x_m", "y_m", "z_m", "min_thrust_n", "pelvis_x_m", "pelvis_y_m", "pelvis_z_m",
                      "pelvis_yaw_rad", "reason"]
    members = [r for r in rows if r["min_thrust_n"] != ""]
    assert len(members) == w["cells"] and all(r["reason"] == "" for r in members)
    assert all(r["reason"] != "" for r in rows if r["min_thrust_n"] == "")
    assert sum(float(r["min_thrust_n"]) == 0.0 for r in members) == wo["cells"]
    assert max(float(r["min_thrust_n"]) for r in members) <= 23.0


def test_members_rebalance_with_placo(swept, robot):
    """Re-solve every member's written pelvis pose with PlaCo and recompute its thrust independently."""
    _, rows = _read(swept / "j1" / "balance_space.csv")
    solver = PlacoPostureSolver(robot)
    support = np.array([0.0, -0.1125, 0.0])
    sole = sole_polygon(support[:2], 0.0, robot.sole_length_m, robot.sole_width_m)
    fan_off = np.array(robot.fan_for("left").offset_m[:2])
    members = [r for r in rows if r["min_thrust_n"] != ""]
    for r in members[::3]:
        swing = np.array([float(r["x_m"]), float(r["y_m"]), float(r["z_m"])])
        p = np.array([float(r["pelvis_x_m"]), float(r["pelvis_y_m"]), float(r["pelvis_z_m"])])
        stance = Stance("right", support, 0.0, swing, 0.0, float(r["pelvis_yaw_rad"]))
        b = solver.solve_batch(stance, p[None])
        assert b.status[0] == Reason.OK
        f, zmp = minimal_thrust(b.com[0, :2], swing[:2] + fan_off, sole, robot.mass_kg)
        assert abs(float(f) - float(r["min_thrust_n"])) < 2e-3  # PlaCo stops within 1e-6 m of the soles
        assert inside_polygon(zmp, sole, tol_m=1e-9)
        assert edge_angle_error(support[:2], b.com[0, :2], swing[:2]) <= np.radians(5) + 1e-6
        if float(r["min_thrust_n"]) == 0.0:
            assert inside_polygon(b.com[0, :2], sole, tol_m=1e-9)


def test_mcap_point_clouds(swept):
    msgs = read_mcap((swept / "j1" / "balance_space.mcap").read_bytes())
    s = json.loads((swept / "j1" / "summary.json").read_text())
    assert {(m[0], m[1]) for m in msgs} == {(name, t.type) for name, t in BALANCE_SPACE_TOPICS.items()}
    counts = {}
    for topic, schema, msg, _ in msgs:
        if schema == "sensor_msgs/msg/PointCloud2":
            raw = bytes(msg.data)
            assert len(raw) == msg.point_step * msg.width
            pts = np.frombuffer(raw, dtype="<f4").reshape(-1, 4)
            counts[topic] = len(pts)
            assert [f.name for f in msg.fields] == ["x", "y", "z", "min_thrust_n"]
            assert np.all(pts[:, 3] <= 23.0 + 1e-4)
    assert counts == {"/balance_space/with_thrust": s["with_thrust"]["cells"],
                      "/balance_space/without_thrust": s["without_thrust"]["cells"]}
    (cells,) = [m[2] for m in msgs if m[0] == "/balance_space/cells"]
    assert [len(m.points) for m in cells.markers] == [counts["/balance_space/with_thrust"],
                                                       counts["/balance_space/without_thrust"]]
    png = (swept / "j1" / "balance_space.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20000


@pytest.mark.parametrize("z", [0.05, 0.15, 0.25])
def test_continuation_against_exhaustive_on_sampled_cells(robot, z):
    """The default search against the paper's exhaustive search (a 5 mm P_body grid refined to 1 mm and
    then to 0.04 mm, grid points moved into the legs' reach and joint limits) on randomly sampled cells
    of a 1 cm sweep across the edge of the space with thrust: same membership and thrust within 0.1 N
    (the issue's criterion).

    Measured on 1,000 cells of the default sweep (docs/balance_space.md): 999 agree (the one other is
    0.105 N higher); on another 1,000 (seed 2), 1,000.
    """
    spec = SweepSpec(x_range=(0.25, 0.75), y_range=(-0.35, 0.35))
    layer = sweep_layers(spec, (z,))
    ev = Evaluator(robot, spec.support_stance())
    cells = ev.cells(layer.swing)
    rng = np.random.default_rng(4)
    reachable = np.flatnonzero((layer.reason != Reason.OVERLAP) & ev.reach_possible(cells))
    picks = rng.choice(reachable, 24, replace=False)
    members = 0
    for i in picks:
        _, f_ex, r_ex = exhaustive_cell(ev, cells, i, 0.005)
        assert (layer.reason[i] == Reason.OK) == (r_ex == Reason.OK), (layer.swing[i], layer.thrust[i], f_ex)
        if r_ex == Reason.OK:
            members += 1
            assert abs(layer.thrust[i] - f_ex) <= 0.1, (layer.swing[i], layer.thrust[i], f_ex)
    assert 6 <= members <= 18  # the window straddles the space's edge: both kinds are sampled


def test_dask_executor_writes_identical_output(tmp_path):
    pytest.importorskip("distributed")
    args = ["balance-space", "--resolution", "0.1", "--z-range", "0.0", "0.2", "--no-progress", "-j", "2"]
    assert run([*args, "-o", str(tmp_path / "loky")]) == 0
    assert run([*args, "-o", str(tmp_path / "dask"), "--executor", "dask"]) == 0
    for name in ("balance_space.csv", "balance_space.mcap"):
        assert (tmp_path / "loky" / name).read_bytes() == (tmp_path / "dask" / name).read_bytes()


def test_left_support_mirrors_the_space(tmp_path, capsys):
    assert run(["balance-space", "--support", "left", "--resolution", "0.1", "--z-range", "0.0", "0.1",
                "--no-progress", "--json", "-o", str(tmp_path / "left")]) == 0
    left = json.loads(capsys.readouterr().out)
    assert run(["balance-space", "--support", "right", "--resolution", "0.1", "--z-range", "0.0", "0.1",
                "--no-progress", "--json", "-o", str(tmp_path / "right")]) == 0
    right = json.loads(capsys.readouterr().out)
    assert left["support"] == {"side": "left", "position_m": [0.0, 0.1125, 0.0]} and left["swing"] == "right"
    # the robot is left-right symmetric: the mirrored sweep finds the same spaces
    for space in ("with_thrust", "without_thrust"):
        assert left[space]["cells"] == pytest.approx(right[space]["cells"], rel=0.05)
        assert left[space]["max_sideways_m"] == pytest.approx(right[space]["max_sideways_m"], abs=0.1001)
