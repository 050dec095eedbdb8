"""Paper B's walking: the parts against independent computations, then `jethr1 walk`, `verify` of a
walk and `jethr1 walk-sweep` as a user runs them."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from jethr1_plan.cli import run
from jethr1_plan.io.record import RECORD
from tests.conftest import ROOT

DYROS_WALK = ROOT / "configs" / "walks" / "dyros_walk.yaml"
JETHR1_WALK = ROOT / "configs" / "walks" / "jethr1_walk.yaml"


@pytest.fixture(scope="module")
def dyros_spec():
    from jethr1_plan.walking.spec import load_walk

    return load_walk(DYROS_WALK)


# --- the parts ----------------------------------------------------------------------------------


def test_timeline_footholds_phases_and_zmp_reference(dyros_spec):
    """Repetitive footholds are one step length apart; a foot swings only between its lift and landing;
    in single support the ZMP reference is the support sole's centre."""
    spec = dyros_spec.varied(step_length_m=0.3)
    tl = spec.timeline()
    xs = [st.position_m[0] for st in tl.steps]
    assert np.allclose(np.diff([0.0, *xs[:-1]]), 0.3) and xs[-1] == xs[-2]  # the last closes the stance
    assert [st.side for st in tl.steps] == ["left", "right"] * 3
    t = np.linspace(0, tl.duration_s, 2001)
    support, _ = tl.phase(t)
    ref = tl.zmp_reference(t)
    for st in tl.steps:
        inside = (t > st.t_lift + 1e-6) & (t < st.t_land - 1e-6)
        other = "right" if st.side == "left" else "left"
        assert set(support[inside]) == {other}
        assert st.t_land - st.t_lift == pytest.approx(spec.timing.single_support_s)
    assert set(support[(t < tl.steps[0].t_lift)]) == {"both"}
    # in each single support the reference sits on the support sole's centre
    feet = dict(tl.start)
    for st in tl.steps:
        other = "right" if st.side == "left" else "left"
        mid = 0.5 * (st.t_lift + st.t_land)
        assert np.allclose(tl.zmp_reference(np.array([mid]))[0], feet[other][:2], atol=1e-12)
        feet[st.side] = st.position_m
    assert np.all(np.isfinite(ref))


def test_com_mpc_obeys_the_lipm_and_keeps_the_zmp_in_the_support(dyros_spec):
    """(B-18): the CoM's written ZMP is the LIPM's, p = c − (z_c/g)·c̈, recomputed here from the CoM
    rows by central second differences (exact for the cubic pieces of a constant jerk; at an MPC
    update the stencil straddles two jerks); it stays inside the support polygon shrunk by the margin."""
    from jethr1_plan.geometry import GRAVITY, polygon_margin
    from jethr1_plan.walking.com_mpc import plan_com

    spec = dyros_spec.varied(step_length_m=0.35)
    tl = spec.timeline()
    dt = 1.0 / spec.timing.control_hz
    plan = plan_com(tl, spec.com, dt)
    acc = (plan.pos[2:] - 2 * plan.pos[1:-1] + plan.pos[:-2]) / dt**2
    err = np.linalg.norm(plan.pos[1:-1] - spec.com.height_m / GRAVITY * acc - plan.zmp[1:-1], axis=1)
    per_update = round(spec.com.dt_s / dt)
    at_update = (np.arange(1, len(plan.t) - 1) % per_update) == 0
    assert np.max(err[~at_update]) < 1e-8 and np.max(err[at_update]) < 5e-3
    margins = [polygon_margin(plan.zmp[i], tl.support_polygon(float(plan.t[i]))) for i in range(len(plan.t))]
    assert min(margins) >= spec.com.zmp_margin_m - 1e-4
    assert np.allclose(plan.vel[0], 0.0) and np.allclose(plan.pos[0], 0.0, atol=1e-9)  # from rest between the feet


def test_reference_yaw_turns_the_leading_hip_forward():
    """(B-30..B-32): a left foot ahead and a right foot behind give a negative yaw about +z (the left
    hip forward); mirrored feet the opposite; feet side by side none; the size grows with k_pel."""
    from jethr1_plan.walking.pelvis_yaw import reference_yaw

    pelvis = np.zeros((1, 2))
    ahead_left = reference_yaw(pelvis, np.array([[0.2, 0.1]]), np.array([[-0.2, -0.1]]), 0.4)[0]
    ahead_right = reference_yaw(pelvis, np.array([[-0.2, 0.1]]), np.array([[0.2, -0.1]]), 0.4)[0]
    level = reference_yaw(pelvis, np.array([[0.0, 0.1]]), np.array([[0.0, -0.1]]), 0.4)[0]
    assert ahead_left < 0 < ahead_right and ahead_left == pytest.approx(-ahead_right) and level == 0
    assert ahead_left == pytest.approx(-math.atan(0.4 * 0.2 / 0.1))
    assert abs(reference_yaw(pelvis, np.array([[0.2, 0.1]]), np.array([[-0.2, -0.1]]), 0.25)[0]) < abs(ahead_left)


# --- one walk, end to end -----------------------------------------------------------------------


@pytest.fixture(scope="module")
def dyros_folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("walk")
    code = run(["walk", str(DYROS_WALK), "-o", str(out)])
    assert code == 0
    return out / "dyros_walk"


def test_walk_writes_its_files_and_paper_b_measures(dyros_folder):
    """The folder holds the CSV, MCAP, summary and three figures; the arms cancel at least half of
    the yaw momentum the arms-held walk has (Figs. 12, 16); the twin walks it and ends on its footholds."""
    names = {p.name for p in dyros_folder.iterdir()} - {RECORD}
    assert names == {"trajectory.csv", "trajectory.mcap", "summary.json", "yaw.png", "momentum.png", "kappa.png"}
    for png in ("yaw.png", "momentum.png", "kappa.png"):
        assert (dyros_folder / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    s = json.loads((dyros_folder / "summary.json").read_text())
    assert s["kind"] == "walk" and s["ok"] and s["rows"] == round(s["duration_s"] * 100)
    mom = s["yaw_momentum"]
    assert mom["peak_total_nms"] <= 0.5 * mom["peak_with_arms_held_nms"]
    twin = s["rehearsal"]
    assert twin["survived"] and twin["landing_error_m"] < s["spec"]["success"]["landing_tolerance_m"]
    assert s["least_knee_bend_rad"] >= s["spec"]["success"]["knee_margin_rad"]
    assert 0 < s["peak_yaw_rad"] < math.radians(45)


def test_the_rows_say_what_the_summary_says_up_to_the_last_row(dyros_folder):
    """summary.json's least ZMP margin and peak friction are the judged rows' own (the CSV's columns), and
    the end rows, which are written but not judged, are no outliers: the walk ends with its CoM still
    moving, and its last row's torques, ZMP and servo commands are those of the rows' motion, not of a
    stop within one row beyond it (which wrote a −0.378 m margin, 128 N·m at an ankle and a last servo
    command 7 mrad off, the posture the robot then holds)."""
    import csv

    s = json.loads((dyros_folder / "summary.json").read_text())
    with (dyros_folder / "trajectory.csv").open() as f:
        rows = list(csv.DictReader(f))
    col = {k: np.array([float(r[k]) for r in rows]) for k in rows[0] if k not in ("support",)}
    margin, friction = col["zmp_margin_m"], col["friction_ratio"]
    assert s["least_zmp_margin_m"] == margin[1:-1].min()
    assert s["peak_friction_ratio"] == friction[1:-1].max()
    speed = np.hypot(*(np.diff(np.column_stack([col["com_x_m"], col["com_y_m"]])[-2:], axis=0)[0])) * 100
    assert speed > 0.03  # the walk ends moving [m/s]: the ends see only the rows
    for end, inner in ((0, 1), (-1, -2)):
        assert abs(margin[end] - margin[inner]) < 2e-3
        assert margin[end] >= s["least_zmp_margin_m"]
        assert abs(friction[end] - friction[inner]) < 0.01
        tau = [k for k in col if k.endswith("_tau_nm")]
        assert max(abs(col[k][end] - col[k][inner]) for k in tau) < 0.5
        cmd = [k for k in col if k.endswith("_cmd_rad")]
        sag = {k: col[k] - col[k.replace("_cmd_rad", "_rad")] for k in cmd}
        assert max(abs(sag[k][end] - sag[k][inner]) for k in cmd) < 1e-3


def test_walk_csv_rows_hold_by_forward_kinematics_and_the_mcap_plays_it(dyros_folder):
    """Each sole that bears weight sits on its foothold (forward kinematics from the written rows, in
    a fresh PlaCo robot, independent of the generator); the MCAP carries the robot, the footsteps,
    one /joint_states per row and one yaw horizon per MPC update."""
    from jethr1_plan.files.mcap import read_mcap
    from jethr1_plan.files.walk_folder import read_walk_csv
    from jethr1_plan.robot.load import load_robot

    s = json.loads((dyros_folder / "summary.json").read_text())
    c = read_walk_csv((dyros_folder / "trajectory.csv").read_text())
    robot = load_robot("dyros_jet_like")
    w = robot.wrapper()
    last = s["steps"][-1]
    for i in (0, len(c["time_s"]) - 1):  # standing at the start and at the end
        quat = [c[f"pelvis_q{a}"][i] for a in "xyzw"]
        w.state.q[:3] = [c["pelvis_x_m"][i], c["pelvis_y_m"][i], c["pelvis_z_m"][i]]
        w.state.q[3:7] = quat
        w.state.q[7:] = [c[f"{j}_rad"][i] for j in robot.joint_names]
        w.update_kinematics()
        T = w.get_T_world_frame(robot.legs[last["side"]].sole)
        if i:
            assert np.linalg.norm(T[:3, 3] - last["position_m"]) < 1e-3
        else:
            assert np.linalg.norm(T[:3, 3] - s["start_m"][last["side"]]) < 1e-3
    topics: dict[str, int] = {}
    for topic, *_ in read_mcap((dyros_folder / "trajectory.mcap").read_bytes()):
        topics[topic] = topics.get(topic, 0) + 1
    assert topics["/robot_description"] == 1 and topics["/footsteps"] == 1
    assert topics["/joint_states"] == s["rows"] == topics["/tf"]
    assert topics["/yaw_horizon"] == math.ceil(s["rows"] / round(s["spec"]["com"]["dt_s"] * 100))


def test_verify_holds_a_walk_and_catches_a_moved_foothold(dyros_folder, tmp_path, capsys):
    """verify re-checks the walk (exit 0); with a landing moved 2 cm in summary.json, or a joint
    cell changed in the CSV, it names the failing rows (exit 5)."""
    import shutil

    assert run(["verify", str(dyros_folder)]) == 0
    bad = tmp_path / "moved"
    shutil.copytree(dyros_folder, bad)
    s = json.loads((bad / "summary.json").read_text())
    s["steps"][2]["position_m"][0] += 0.02
    (bad / "summary.json").write_text(json.dumps(s))
    capsys.readouterr()
    assert run(["verify", str(bad)]) == 5
    assert "from its foothold" in capsys.readouterr().err
    bad2 = tmp_path / "joint"
    shutil.copytree(dyros_folder, bad2)
    lines = (bad2 / "trajectory.csv").read_text().splitlines()
    header = lines[0].split(",")
    k = header.index("L_KneePitch_rad")
    row = lines[400].split(",")
    row[k] = repr(float(row[k]) + 0.05)
    lines[400] = ",".join(row)
    (bad2 / "trajectory.csv").write_text("\n".join(lines) + "\n")
    assert run(["verify", str(bad2)]) == 5
    err = capsys.readouterr().err
    assert "row 399" in err and "MCAP" in err  # the CSV no longer matches its MCAP either


def test_pelvic_rotation_lowers_kappa_and_lengthens_the_step(dyros_spec):
    """Fig. 13 and the step length: at 0.30 m the lower body's peak κ (B-45) is lower with pelvic
    rotation; at 0.40 m the walk without rotation reaches the straight leg (the knee margin, or the IK
    losing the sole there) while paper_b holds."""
    from jethr1_plan.pipeline.walk import run_walk

    spec = replace(dyros_spec, success=replace(dyros_spec.success, rehearse=False))
    k = {m: float(np.max(run_walk(spec.varied(step_length_m=0.3, mode=m, arms=False)).analysis.kappa))
         for m in ("none", "paper_b")}
    assert k["paper_b"] < 0.8 * k["none"]
    none = run_walk(spec.varied(step_length_m=0.4, mode="none"))
    rot = run_walk(spec.varied(step_length_m=0.4, mode="paper_b"))
    assert not none.ok and ("knee" in none.failure[1] or "off its target" in none.failure[1])  # the straight leg
    assert rot.ok


def test_walk_that_fails_exits_3_with_time_and_reason(tmp_path, capsys):
    """A step too long for the knees: exit 3, the first failing time and reason; summary.json only."""
    text = DYROS_WALK.read_text().replace("step_length_m: 0.30", "step_length_m: 0.45").replace(
        "mode: paper_b", "mode: none")
    f = tmp_path / "long.yaml"
    f.write_text(text)
    assert run(["walk", str(f), "-o", str(tmp_path / "out"), "--no-rehearse"]) == 3
    err = capsys.readouterr().err
    assert "the walk fails at t = " in err and ("knee" in err or "off its target" in err)
    assert {p.name for p in (tmp_path / "out" / "long").iterdir()} - {RECORD} == {"summary.json"}
    assert json.loads((tmp_path / "out" / "long" / "summary.json").read_text())["ok"] is False


@pytest.mark.parametrize("patch, key", [
    ({"bogus": 1}, "bogus"),
    ({"com": {"dt_s": 0.015}}, "com.dt_s"),
    ({"footsteps": {"kind": "repetitive", "step_width_m": 0.1}}, "footsteps.step_width_m"),
    ({"footsteps": {"kind": "explicit", "landings": [{"side": "left", "position_m": [0.0, 0.1215, 0.1]}]}},
     "footsteps.landings[0].position_m"),
    ({"timing": {"control_hz": float("nan")}}, "timing.control_hz"),
    ({"pelvis_rotation": {"mode": "spin"}}, "pelvis_rotation.mode"),
    ({"footsteps": {"kind": "repetitive", "count": 200, "step_length_m": 0.1}, "timing": {"single_support_s": 100}},
     "timing"),
])
def test_bad_walk_files_exit_2_naming_the_key(tmp_path, capsys, patch, key):
    import yaml

    doc = yaml.safe_load(DYROS_WALK.read_text())
    for k, v in patch.items():
        doc[k] = v
    f = tmp_path / "bad.yaml"
    f.write_text(yaml.safe_dump(doc))
    assert run(["walk", str(f), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and str(f) in err and key in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_bad_bytes_and_sweep_options_exit_2(tmp_path, capsys):
    f = tmp_path / "bytes.yaml"
    f.write_bytes(b"\xff\xfe\x00name: x")
    assert run(["walk", str(f)]) == 2
    explicit = tmp_path / "explicit.yaml"
    explicit.write_text("robot: dyros_jet_like\nfootsteps: {kind: explicit, landings: [{side: left, "
                        "position_m: [0.3, 0.1215, 0.0]}]}\n")
    assert run(["walk-sweep", str(explicit), "--steps-m", "0.2:0.3:0.1"]) == 2
    assert "footsteps.kind" in capsys.readouterr().err
    assert run(["walk-sweep", str(DYROS_WALK), "--rotation", "none,twirl"]) == 2
    assert run(["walk-sweep", str(DYROS_WALK), "--steps-m", "0.3:0.2:0.01"]) == 2


def test_walk_sweep_finds_the_longer_step_with_rotation_and_ignores_jobs(tmp_path):
    """Between 0.32 and 0.36 m the Dyros-Jet-like walk without rotation stops (knee margin) while
    paper_b walks on; the document is the same bytes with -j 1 and -j 2."""
    docs = []
    for jobs in (1, 2):
        out = tmp_path / f"j{jobs}"
        assert run(["walk-sweep", str(DYROS_WALK), "--steps-m", "0.32:0.36:0.02", "--no-rehearse", "-j", str(jobs),
                    "-o", str(out), "--no-progress"]) == 0
        docs.append((out / "walk_sweep.json").read_bytes())
        assert (out / "walk_sweep.png").read_bytes()[:4] == b"\x89PNG"
    assert docs[0] == docs[1]
    doc = json.loads(docs[0])
    assert doc["max_step_m"] == {"none": 0.32, "paper_b": 0.36}
    rows = {(r["mode"], r["step_m"]): r for r in doc["rows"]}
    assert not rows[("none", 0.34)]["ok"] and "KneePitch" in rows[("none", 0.34)]["reason"]
    assert rows[("paper_b", 0.32)]["peak_kappa"] < rows[("none", 0.32)]["peak_kappa"]
