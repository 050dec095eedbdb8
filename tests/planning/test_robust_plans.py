"""Plans under the robust policy, re-checked from the written rows with an independent PlaCo robot."""

from __future__ import annotations

import json
from dataclasses import asdict

import numpy as np
import pytest
import yaml

from jethr1_plan.cli import run
from jethr1_plan.control.commands import low_pass
from jethr1_plan.files.plan_csv import read_trajectory_csv
from jethr1_plan.geometry import polygon_margin, pose_from_quaternion, sole_polygon
from jethr1_plan.physics.balance import thrust_window, zmp_with_thrust
from tests.conftest import JOINT_NAMES, ROOT

SIDE = ROOT / "configs" / "side_step.yaml"


@pytest.fixture(scope="module")
def side_plans(tmp_path_factory):
    out = tmp_path_factory.mktemp("robust")
    for policy in ("robust", "minimal"):
        assert run(["plan", str(SIDE), "-o", str(out / policy), "--policy", policy, "--no-progress"]) == 0
    return {p: out / p / "side_step" for p in ("robust", "minimal")}


def _fk(robot, c):
    """Per row from the written pose and joints: CoM, support and swing sole centres, the left fan."""
    w = robot.wrapper()
    n = len(c["time_s"])
    out = {"com": np.zeros((n, 3)), "right": np.zeros((n, 3)), "left": np.zeros((n, 3)), "fan": np.zeros((n, 2))}
    for i in range(n):
        w.set_T_world_fbase(pose_from_quaternion([c[f"pelvis_{k}_m"][i] for k in "xyz"],
                                                 [c[f"pelvis_q{k}"][i] for k in "xyzw"]))
        w.state.q[7:] = [c[f"{j}_rad"][i] for j in JOINT_NAMES]
        w.update_kinematics()
        out["com"][i] = w.com_world()
        for s in ("left", "right"):
            out[s][i] = w.get_T_world_frame(f"{s}_foot")[:3, 3]
        out["fan"][i] = w.get_T_world_frame("left_fan")[:2, 3]
    return out


def test_every_swing_row_survives_every_error_within_the_tolerance(side_plans, robot):
    """Brute force from the written joints: thrust ±10 %, mass ±5 % and the CoM moved 10 mm in any of
    72 directions keep the ZMP in the support sole on every swing row; the minimal plan's rows do not
    survive even 1 % less thrust."""
    s = json.loads((side_plans["robust"] / "summary.json").read_text())
    tol = s["balance"]["tolerance"]
    assert (s["balance"]["policy"], tol) == ("robust", {"thrust_error": 0.1, "mass_error": 0.05, "com_error_m": 0.01})
    angles = np.linspace(0, 2 * np.pi, 72, endpoint=False)
    ring = tol["com_error_m"] * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    for policy, path in side_plans.items():
        c = read_trajectory_csv((path / "trajectory.csv").read_text())
        rows = np.flatnonzero((c["phase"] == "swing") & (c["thrust_left_n"] > 0.5))[::7]
        fk = _fk(robot, {k: v[rows] for k, v in c.items()})
        worst = []
        for k, i in enumerate(rows):
            sole = sole_polygon(fk["right"][k, :2], 0.0, robot.sole_length_m, robot.sole_width_m)
            f = c["thrust_left_n"][i]
            if policy == "robust":
                margins = [polygon_margin(zmp_with_thrust(fk["com"][k, :2] + ring, fk["fan"][k], f * (1 + e),
                                                          robot.mass_kg * (1 + m)), sole).min()
                           for e in (-0.1, 0.1) for m in (-0.05, 0.05)]
            else:
                margins = [polygon_margin(zmp_with_thrust(fk["com"][k, :2], fk["fan"][k], 0.99 * f, robot.mass_kg),
                                          sole)]
            worst.append(min(margins))
        assert len(rows) > 20
        if policy == "robust":
            assert min(worst) >= -1e-6
        else:
            assert max(worst) < 0


def test_robustness_costs_thrust(side_plans):
    r, m = (json.loads((side_plans[p] / "summary.json").read_text()) for p in ("robust", "minimal"))
    assert r["peak_thrust_n"] > m["peak_thrust_n"] + 1.0 and r["mean_thrust_n"] > m["mean_thrust_n"]
    assert r["robustness"]["least_zmp_margin_m"] >= 0.01 - 1e-6 > m["robustness"]["least_zmp_margin_m"]


def test_window_margin_and_command_columns(side_plans, robot):
    """The window columns hold the planned thrust and are the balancing interval recomputed from the
    written joints; the margin column is the ZMP's distance to the sole's edges; the summary names the
    least margin and the narrowest window; the commands are posture + low-passed torque / the stiffest
    servo's stiffness (1.25 × the robot YAML's)."""
    path = side_plans["robust"]
    c = read_trajectory_csv((path / "trajectory.csv").read_text())
    s = json.loads((path / "summary.json").read_text())
    swing = np.flatnonzero(c["phase"] == "swing")
    rows = swing[::11]
    fk = _fk(robot, {k: v[rows] for k, v in c.items()})
    for k, i in enumerate(rows):
        sole = sole_polygon(fk["right"][k, :2], 0.0, robot.sole_length_m, robot.sole_width_m)
        lo, hi = thrust_window(fk["com"][k, :2], fk["fan"][k], sole, robot.mass_kg)
        assert c["thrust_window_lo_n"][i] == pytest.approx(float(lo), abs=1e-3)
        assert c["thrust_window_hi_n"][i] == pytest.approx(min(float(hi), 23.0), abs=1e-3)
        assert lo - 1e-3 <= c["thrust_left_n"][i] <= min(hi, 23.0) + 1e-3
        zmp = zmp_with_thrust(fk["com"][k, :2], fk["fan"][k], c["thrust_left_n"][i], robot.mass_kg)
        assert c["zmp_margin_m"][i] == pytest.approx(float(polygon_margin(zmp, sole)), abs=1e-6)
    rob = s["robustness"]
    assert rob["least_zmp_margin_m"] == pytest.approx(c["zmp_margin_m"].min())
    assert c["zmp_margin_m"][rob["least_zmp_margin_at"]["row"]] == rob["least_zmp_margin_m"]
    width = np.where(c["thrust_left_n"] + c["thrust_right_n"] > 0, c["thrust_window_hi_n"] - c["thrust_window_lo_n"],
                     np.inf)
    assert rob["narrowest_window_width_n"] == pytest.approx(np.nanmin(width))
    tau = np.stack([c[f"{j}_tau_nm"] for j in JOINT_NAMES], axis=1)
    q = np.stack([c[f"{j}_rad"] for j in JOINT_NAMES], axis=1)
    cmd = np.stack([c[f"{j}_cmd_rad"] for j in JOINT_NAMES], axis=1)
    np.testing.assert_allclose(cmd, q + low_pass(tau, 50.0, 0.2) / (1.25 * robot.servo_stiffness_nm_per_rad),
                               atol=1e-12)
    lead = c["thrust_cmd_left_n"] - c["thrust_left_n"]
    rising = np.flatnonzero(np.diff(c["thrust_left_n"]) > 0.01)[5:-5]
    assert np.all(lead[rising] > 0)  # the command leads a rising thrust by the fan's lag
    # Jet-HR1 senses itself by its IMU and encoders alone: its law is the IMU's, with the gains its YAML gives
    from jethr1_plan.control.imu_thrust import ImuGains

    assert s["controller"]["law"] == "imu_tilt_pid" and s["controller"]["sensors_read"] == ["imu", "encoders"]
    assert s["controller"]["gains"] == asdict(ImuGains.of(robot))
    # the placement `simulate --controller feedback` runs by default, stated with its settings
    from jethr1_plan.control.swing_placement import PlacementGains

    assert s["controller"]["swing_placement"]["settings"] == asdict(PlacementGains())


@pytest.fixture(scope="module")
def ditch_450(plan_of):
    return plan_of("forward_ditch_450")


def test_the_450_ditch_takes_the_largest_share_its_samples_reach(ditch_450):
    """Paper A's 450 mm ditch, planned robust: no posture near the landing reaches the whole tolerance
    within 23 N, so those samples carry a share of it, falling towards the landing; the summary names
    the least and what it means in %, % and mm."""
    s = json.loads((ditch_450 / "summary.json").read_text())
    share = s["robustness"]["tolerance_share"]
    assert s["feasible"] and s["balance"]["policy"] == "robust" and s["peak_thrust_n"] <= 23.0
    assert 0.3 < share["least"] < 0.9 and share["rows_below_full"] > 20
    assert share["least_at"]["phase"] == "swing" and share["least_at"]["sample"] > 200  # near the landing
    assert share["tolerance"]["thrust_error"] == pytest.approx(0.1 * share["least"])
    assert share["tolerance"]["com_error_m"] == pytest.approx(0.01 * share["least"])
    step = s["steps"][0]
    assert step["least_share"] == pytest.approx(share["least"], abs=0.01) and step["samples_below_full_share"] >= 5
    c = read_trajectory_csv((ditch_450 / "trajectory.csv").read_text())
    assert np.all(np.isfinite(c["tolerance_share"])) and c["tolerance_share"].max() == 1.0
    assert c["tolerance_share"].min() == share["least"]


def test_the_share_column_is_the_largest_share_over_the_tolerance_corners(ditch_450, robot):
    """Brute force from the written joints: at each row's written share s every corner of s × the
    tolerance (thrust ±sX, mass ±sY, the CoM sε away in any of 72 directions) keeps the ZMP in the
    support sole; at s + 0.01 some corner tips it out (where s < 1)."""
    c = read_trajectory_csv((ditch_450 / "trajectory.csv").read_text())
    rows = np.flatnonzero((c["phase"] == "swing") & (c["thrust_left_n"] > 0.5))
    rows = np.concatenate([rows[::25], rows[-6:]])
    fk = _fk(robot, {k: v[rows] for k, v in c.items()})
    angles = np.linspace(0, 2 * np.pi, 72, endpoint=False)
    ring = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    below = 0

    def worst(k, i, s):
        sole = sole_polygon(fk["right"][k, :2], 0.0, robot.sole_length_m, robot.sole_width_m)
        f = c["thrust_left_n"][i]
        return min(polygon_margin(zmp_with_thrust(fk["com"][k, :2] + 0.01 * s * ring, fk["fan"][k], f * (1 + e),
                                                  robot.mass_kg * (1 + m)), sole).min()
                   for e in (-0.1 * s, 0.1 * s) for m in (-0.05 * s, 0.05 * s))

    for k, i in enumerate(rows):
        s = c["tolerance_share"][i]
        assert worst(k, i, s) >= -1e-6
        if s < 1.0:
            below += 1
            assert worst(k, i, s + 0.01) < 0
    assert below >= 5


def test_min_share_refuses_a_plan_below_it_and_names_the_sample(tmp_path, capsys):
    doc = yaml.safe_load((ROOT / "configs" / "forward_ditch_450.yaml").read_text())
    doc["balance"]["robust"]["min_share"] = 0.6
    path = tmp_path / "ditch_450_min_share.yaml"
    path.write_text(yaml.safe_dump(doc))
    assert run(["plan", str(path), "-o", str(tmp_path / "o"), "--no-progress"]) == 3
    err = capsys.readouterr().err
    assert "min_share 0.6" in err and "% of the tolerance" in err
    bad = json.loads((tmp_path / "o" / path.stem / "summary.json").read_text())["first_infeasible"]
    share = bad["tolerance_share"]
    assert bad["phase"] == "swing" and 50 <= bad["sample"] < 60 and 0 < share["share"] < 0.6
    assert share["thrust_error"] == pytest.approx(0.1 * share["share"]) and share["min_share"] == 0.6
    # Paper A's minimal policy: the least thrust, no tolerance, no share column
    assert run(["plan", str(ROOT / "configs" / "forward_ditch_450.yaml"), "-o", str(tmp_path / "p"),
                "--policy", "minimal", "--no-progress"]) == 0
    s = json.loads((tmp_path / "p" / "forward_ditch_450" / "summary.json").read_text())
    assert "tolerance_share" not in s["robustness"] and s["peak_thrust_n"] < 21.0


def test_a_minimal_plan_says_it_holds_no_margin_and_a_robust_one_does_not(tmp_path, capsys):
    """The minimal policy's plan (the ZMP on the sole's edge: the twin tips it over at the smallest model error)
    is written, and the command warns in one line; the robust plan of the same scenario carries no warning."""
    said = {}
    for policy in ("minimal", "robust"):
        assert run(["plan", str(SIDE), "-o", str(tmp_path / policy), "--policy", policy, "--no-progress"]) == 0
        said[policy] = capsys.readouterr().err
        assert (tmp_path / policy / "side_step" / "trajectory.csv").is_file()
    warning = [line for line in said["minimal"].splitlines() if line.startswith("warning: the minimal policy")]
    assert len(warning) == 1 and "tips over" in warning[0] and "policy: robust" in warning[0]
    assert "minimal policy" not in said["robust"]
