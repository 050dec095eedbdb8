"""``jethr1 view``: a plan (with its rehearsal), a walk and a balance space saved headless as Rerun
recordings and read back: the robot's links move as the files say, both robots are there, the
thrust, window and margin are plotted; without Rerun, without a display, or on a wrong path: one
line, exit 2."""

from __future__ import annotations

import sys
from collections import defaultdict

import numpy as np
import pytest

from jethr1_plan.cli import run
from jethr1_plan.folders.plan import read_plan
from jethr1_plan.robot.urdf import urdf_joints
from jethr1_plan.viewer.topics import VIEW_EXTRA

rerun_chunk = pytest.importorskip("rerun.chunk")


def _read(path) -> tuple[dict[str, set[str]], dict[str, list[dict]]]:
    """Entity → component names, and every row of each entity, from a saved recording."""
    components: dict[str, set[str]] = defaultdict(set)
    rows: dict[str, list[dict]] = defaultdict(list)
    for chunk in rerun_chunk.RrdReader(path).stream():
        batch = chunk.to_record_batch()
        names = [n for n in batch.schema.names if ":" in n]  # components (not the timelines)
        components[chunk.entity_path].update(names)
        rows[chunk.entity_path] += batch.select(names).to_pylist()
    return components, rows


def _moving_frames(rows: dict[str, list[dict]], prefix: str) -> dict[str, set[tuple]]:
    """Child frame → the distinct (rounded) transforms it takes over time, under ``/<prefix>/tf/``."""
    out: dict[str, set[tuple]] = defaultdict(set)
    for entity, rs in rows.items():
        if not entity.startswith(f"/{prefix}/tf/"):
            continue
        for r in rs:
            for child, q, xyz in zip(r.get("Transform3D:child_frame") or [], r.get("Transform3D:quaternion") or [],
                                     r.get("Transform3D:translation") or [], strict=True):
                out[child].add(tuple(np.round([*q, *xyz], 6)))
    return out


@pytest.fixture(scope="module")
def saved(written, tmp_path_factory):
    out = tmp_path_factory.mktemp("rrd")
    paths = {}
    for kind, folder in written.items():
        paths[kind] = out / f"{kind}.rrd"
        assert run(["view", str(folder), "--save", str(paths[kind])]) == 0
    return paths


def test_a_plan_and_its_rehearsal_move_in_rerun(saved, written):
    plan = read_plan(written["plan"])
    components, rows = _read(saved["plan"])
    joints = urdf_joints(plan.robot.urdf_path)
    table = plan.table
    turning = {j.child for j in joints
               if j.kind != "fixed" and np.ptp(table[f"{j.name}_rad"]) > 1e-6}
    assert len(turning) >= 8  # the side step turns hips, knees and ankles
    moving = _moving_frames(rows, "plan")
    assert set(moving) == {"trunk"} | {j.child for j in joints if j.kind != "fixed"}
    assert {f for f, poses in moving.items() if len(poses) > 1} == {"trunk"} | turning
    assert max(len(p) for p in moving.values()) > 100  # a pose per row, not a few
    rehearsal = _moving_frames(rows, "rehearsal")
    assert set(rehearsal) == {"sim/" + f for f in moving} and len(rehearsal["sim/trunk"]) > 100
    geometry = {e for e, c in components.items() if "/visual_geometries/" in e and "Boxes3D:half_sizes" in c}
    assert any(e.startswith("/plan/") for e in geometry) and any(e.startswith("/rehearsal/") for e in geometry)
    plots = {e for e in components if e.startswith("/plots/")}
    assert {"/plots/thrust/plan_left", "/plots/thrust/plan_right", "/plots/thrust/window_lo",
            "/plots/thrust/window_hi", "/plots/thrust/rehearsal_left", "/plots/zmp_margin/plan"} <= plots
    thrust = [v for r in rows["/plots/thrust/plan_left"] for v in (r.get("Scalars:scalars") or [])]
    np.testing.assert_allclose(np.ravel(thrust), table["thrust_left_n"])
    assert "Boxes3D:half_sizes" in components["/plan/terrain/cartons"]
    assert "LineStrips3D:strips" in components["/plan/swing_path/swing_paths_0"]
    # the rehearsal's landing beside the plan's foothold: the label names its error, slip and turn
    label = [lab for r in rows["/rehearsal/sim/steps/step_0"] for lab in (r.get("Points3D:labels") or [])]
    assert len(label) == 1 and label[0].startswith("step 0: ") and "mm off; support slip" in label[0]
    assert "Points3D:positions" in components["/rehearsal/sim/steps/step_0_0"]


def test_a_walk_and_a_balance_space_in_rerun(saved):
    _, rows = _read(saved["walk"])
    moving = _moving_frames(rows, "walk")
    assert sum(len(p) > 1 for p in moving.values()) >= 12 and max(len(p) for p in moving.values()) > 100
    assert {"/plots/yaw/yaw", "/plots/momentum/upper", "/plots/kappa/kappa"} <= set(rows)
    components, rows = _read(saved["balance_space"])
    cells = [e for e in components if e.startswith("/balance_space/balance_space/cells/")]
    assert len(cells) == 2 and all("Boxes3D:centers" in components[e] for e in cells)
    assert "Boxes3D:half_sizes" in components["/balance_space/support_sole/support_sole"]
    # the two PointCloud2 topics: a point per cell of each space, where its cube is
    for k, space in enumerate(("with_thrust", "without_thrust")):
        points = [p for r in rows[f"/balance_space/balance_space/{space}"] for p in r["Points3D:positions"]]
        cubes = [c for r in rows[f"/balance_space/balance_space/cells/{space}_{k}"] for c in r["Boxes3D:centers"]]
        assert len(points) == len(cubes) > 0
        np.testing.assert_allclose(sorted(map(tuple, points)), sorted(map(tuple, cubes)), atol=1e-6)


def test_a_route_folder_and_its_route_mcap_in_rerun(small_route, tmp_path):
    """A route folder shows its plan (the robot moving, the thrust) and its route.mcap: the footholds, the
    footsteps with their numbers, the swing paths and the balance-space slice of each step at its time;
    route.mcap alone shows the route."""
    import json

    summary = json.loads((small_route / "summary.json").read_text())
    steps = len(summary["steps"])
    for target, plan in ((small_route, True), (small_route / "route.mcap", False)):
        rrd = tmp_path / f"{'folder' if plan else 'file'}.rrd"
        assert run(["view", str(target), "--save", str(rrd)]) == 0
        components, rows = _read(rrd)
        assert "Boxes3D:centers" in components["/route/route/footholds/footholds_0"]
        assert "Boxes3D:centers" in components["/route/route/footsteps/landings"]
        labels = [x for r in rows["/route/route/footsteps/step_numbers"] for x in r["Points3D:labels"]]
        assert labels == [str(k + 1) for k in range(steps)]
        assert sum(e.startswith("/route/route/swing_paths/") for e in components) == steps
        clouds = [r["Points3D:positions"] for r in rows["/route/route/balance_space"]]
        assert len(clouds) == steps and all(len(c) > 10 for c in clouds)
        assert (len(_moving_frames(rows, "plan")) > 10) == plan
        assert ("/plots/thrust/plan_left" in components) == plan


def test_without_rerun_without_a_display_or_on_a_wrong_path_one_line_exit_2(written, tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    if sys.platform.startswith("linux"):
        assert run(["view", str(written["plan"])]) == 2
        err = capsys.readouterr().err
        assert "--save FILE.rrd" in err and len(err.strip().splitlines()) == 1
    for args in (["view", str(tmp_path / "nowhere")], ["view", str(tmp_path)],
                 ["view", str(written["plan"]), "--save", str(tmp_path / "x.png")]):
        assert run(args) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    old = tmp_path / "old"  # a JSON MCAP, as jethr1 wrote before its files were ROS 2 bags
    old.mkdir()
    _json_mcap(old / "trajectory.mcap")
    assert run(["view", str(old), "--save", str(tmp_path / "old.rrd")]) == 2  # not a whole plan folder
    err = capsys.readouterr().err
    assert "trajectory.csv: missing" in err and len(err.strip().splitlines()) == 1
    assert run(["view", str(old / "trajectory.mcap"), "--save", str(tmp_path / "old.rrd")]) == 2
    err = capsys.readouterr().err
    assert "not 'ros2'" in err and len(err.strip().splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old"]  # nothing written
    monkeypatch.setitem(sys.modules, "rerun", None)  # as if the extra were not installed
    assert run(["view", str(written["plan"]), "--save", str(tmp_path / "x.rrd")]) == 2
    assert capsys.readouterr().err.strip() == VIEW_EXTRA == \
        "jethr1 view needs the optional extra: pip install 'jethr1-plan[view]'"
    assert not (tmp_path / "x.rrd").exists()


def _json_mcap(path) -> None:
    from mcap.writer import Writer

    with path.open("wb") as f:
        w = Writer(f)
        w.start()
        sid = w.register_schema("jethr1.Thrust", "jsonschema", b'{"type": "object"}')
        channel = w.register_channel("/thrust", "json", sid)
        w.add_message(channel, 0, b"{}", 0)
        w.finish()


def test_planning_does_not_import_rerun():
    import subprocess

    code = ("import sys; from jethr1_plan.cli import main; import jethr1_plan.files.plan_folder, "
            "jethr1_plan.pipeline.plan; print('rerun' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
