"""The robot is wholly data: renamed joints, frames and fans plan the same; a third fan on the trunk
plans the ditch; the least total thrust of several fans is HiGHS's optimum."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml
from scipy.optimize import linprog

from jethr1_plan.cli import run
from jethr1_plan.files.plan_csv import read_trajectory_csv
from jethr1_plan.geometry import GRAVITY, halfplanes, sole_polygon
from jethr1_plan.physics.balance import Tolerance, least_thrust, shared_window, thrust_window
from jethr1_plan.robot.load import load_robot
from tests.conftest import JOINT_NAMES, ROOT
from tests.oracles.robot_copies import copy_scenario, renamed_jethr1


def _plan(scenario, out) -> tuple[int, dict, dict]:
    code = run(["plan", str(scenario), "-o", str(out), "--no-progress"])
    folder = out / scenario.stem
    summary = json.loads((folder / "summary.json").read_text())
    csv = folder / "trajectory.csv"
    return code, summary, read_trajectory_csv(csv.read_text()) if csv.exists() else {}


@pytest.fixture(scope="module")
def side_step(tmp_path_factory):
    out = tmp_path_factory.mktemp("jethr1")
    return _plan(ROOT / "configs" / "side_step.yaml", out)


def test_renamed_robot_plans_the_same(tmp_path, side_step):
    """Every link, joint and fan of Jet-HR1 renamed (the URDF and YAML rewritten, no code): the side
    step plans to the same thrust, bit for bit, and its CSV names the renamed joints and fans."""
    _, ref_summary, ref = side_step
    robot_yaml = renamed_jethr1(tmp_path / "renamed", lambda n: f"q_{n}", {"left": "port", "right": "starboard"})
    code, summary, c = _plan(copy_scenario("side_step", tmp_path, robot_yaml), tmp_path / "out")
    assert code == 0
    for key in ("peak_thrust_n", "mean_thrust_n", "smoothness_m2", "evaluations"):
        assert summary[key] == ref_summary[key], key
    np.testing.assert_array_equal(c["thrust_port_n"], ref["thrust_left_n"])
    np.testing.assert_array_equal(c["thrust_starboard_n"], ref["thrust_right_n"])
    for j in JOINT_NAMES:
        np.testing.assert_array_equal(c[f"q_{j}_rad"], ref[f"{j}_rad"])
    assert "thrust_left_n" not in c and "left_hip_yaw_rad" not in c


def test_legs_in_another_joint_order_plan_the_same(tmp_path, side_step):
    """Names that make PlaCo order the right leg's joints first: the legs are found by role, and the
    plan needs the same thrust (to rounding: PlaCo sums the CoM in another order) with the same
    number of evaluations; every joint column matches its counterpart."""
    _, ref_summary, ref = side_step
    new = {"left": "zz", "right": "aa"}

    def rename(name: str) -> str:
        side, _, rest = name.partition("_")
        return f"{new[side]}_{rest}" if side in new else f"body_{name}"

    robot_yaml = renamed_jethr1(tmp_path / "swapped", rename)
    robot = load_robot(str(robot_yaml))
    assert robot.joint_names[0].startswith("aa_") and list(robot.leg_index) == [*range(6, 12), *range(6)]
    code, summary, c = _plan(copy_scenario("side_step", tmp_path, robot_yaml), tmp_path / "out")
    assert code == 0
    assert summary["evaluations"] == ref_summary["evaluations"]
    assert summary["peak_thrust_n"] == pytest.approx(ref_summary["peak_thrust_n"], abs=1e-9)
    np.testing.assert_allclose(c["thrust_left_n"], ref["thrust_left_n"], atol=1e-9)
    for j in JOINT_NAMES:
        np.testing.assert_allclose(c[f"{rename(j)}_rad"], ref[f"{j}_rad"], atol=1e-9)


def test_a_third_fan_on_the_trunk_plans_the_ditch(tmp_path):
    """With every fan capped at 20 N, Jet-HR1 cannot cross the 450 mm ditch; with a third fan on its
    trunk it can: the thrust is shared, the trunk fan carrying only what the swing foot's fan (the
    longer lever) cannot, and the written plan passes ``verify``."""
    scenario = ROOT / "configs" / "forward_ditch_450_trunk_fan.yaml"
    code, summary, c = _plan(scenario, tmp_path / "out")
    assert code == 0 and summary["feasible"]
    robot = load_robot("jethr1_trunk_fan")
    assert [f.name for f in robot.fans] == ["left", "right", "trunk"] and robot.fans[2].on_trunk
    left, trunk = c["thrust_left_n"], c["thrust_trunk_n"]
    assert left.max() <= 20.0 + 1e-9 and trunk.max() > 1.0
    shared = trunk > 1e-9
    np.testing.assert_allclose(left[shared & (c["phase"] == "swing")], 20.0, atol=1e-6)  # least total
    per_fan = summary["trajectory"]["peak_thrust_per_fan_n"]
    assert per_fan["left"] == pytest.approx(20.0) and per_fan["trunk"] == pytest.approx(trunk.max())
    assert run(["verify", str(tmp_path / "out" / scenario.stem)]) == 0
    # sqp shares the thrust too (each fan its own variable)
    assert run(["plan", str(scenario), "-o", str(tmp_path / "sqp"), "--optimiser", "sqp", "--no-progress"]) == 0
    sqp = json.loads((tmp_path / "sqp" / scenario.stem / "summary.json").read_text())["trajectory"]
    assert sqp["peak_thrust_per_fan_n"]["left"] <= 20.0 + 1e-9 and sqp["peak_thrust_per_fan_n"]["trunk"] > 1.0
    # Jet-HR1 under the same cap
    doc = yaml.safe_load(scenario.read_text())
    doc["robot"] = "jethr1"
    doc.pop("expect")
    two = tmp_path / "two_fans.yaml"
    two.write_text(yaml.safe_dump(doc))
    assert run(["plan", str(two), "-o", str(tmp_path / "out"), "--no-progress"]) == 3


@pytest.mark.parametrize("fans, tol", [(1, Tolerance()), (2, Tolerance()), (2, Tolerance(0.1, 0.05, 0.01)),
                                       (3, Tolerance(0.1, 0.05, 0.01))])
def test_least_thrust_is_highs_optimum(fans, tol):
    """The compiled vertex enumeration against SciPy's HiGHS on random postures and fan layouts,
    with and without each fan's maximum."""
    rng = np.random.default_rng(fans)
    poly = sole_polygon(np.zeros(2), 0.0, 0.16, 0.09)
    n, b = halfplanes(poly)
    mass, weight = 6.8, 6.8 * GRAVITY
    com = rng.uniform(-0.15, 0.15, (400, 2))
    fan_xy = rng.uniform(-0.5, 0.5, (400, fans, 2))
    fmax = rng.uniform(8.0, 30.0, fans)
    feasible = 0
    for bounded in (True, False):
        total, split = least_thrust(com, fan_xy, poly, mass, fmax if bounded else None, tol)
        for j in range(len(com)):
            d = com[j] @ n.T - b + tol.com_m
            a = fan_xy[j] @ n.T - b
            lift = (a - tol.thrust * np.abs(a)).T  # (K, F)
            res = linprog(np.ones(fans), A_ub=np.vstack([-lift, np.full((1, fans), 1 + tol.thrust)]),
                          b_ub=np.concatenate([-weight * (d + tol.mass * np.abs(d)),
                                               [weight * (1 - tol.mass) * (1 - 1e-9)]]),
                          bounds=[(0, fmax[i] if bounded else None) for i in range(fans)], method="highs")
            if res.status == 2:
                assert not np.isfinite(total[j]), (j, total[j])
                continue
            assert res.status == 0
            feasible += 1
            assert total[j] == pytest.approx(res.fun, abs=1e-6)
            assert split[j].sum() == pytest.approx(total[j], abs=1e-9) and np.all(split[j] >= 0)
            if bounded:
                assert np.all(split[j] <= fmax + 1e-9)
    assert feasible > 80  # the sample exercises the balanced case too
    if fans == 1:  # one fan, no maximum: the lower end of its window, exactly
        lo, _ = thrust_window(com, fan_xy[:, 0], poly, mass, tol)
        total, _ = least_thrust(com, fan_xy, poly, mass, None, tol)
        np.testing.assert_array_equal(total, lo)


def test_shared_window_holds_the_split_in_every_error():
    """Along a split, the window's ends are the totals at which some edge's worst case is exactly
    met: just inside, every sampled error keeps the ZMP in the sole; just outside, one does not."""
    rng = np.random.default_rng(5)
    poly = sole_polygon(np.zeros(2), 0.0, 0.16, 0.09)
    tol = Tolerance(0.1, 0.05, 0.01)
    mass, weight = 6.8, 6.8 * GRAVITY
    n, b = halfplanes(poly)
    checked = 0
    for _ in range(300):
        com = rng.uniform(-0.15, 0.15, 2)
        fans = rng.uniform(-0.5, 0.5, (2, 2))
        share = rng.dirichlet([1.0, 1.0])
        lo, hi = shared_window(com, fans, share, poly, mass, tol)
        if not np.isfinite(lo) or hi - lo < 0.05:
            continue
        checked += 1
        for total, inside in ((lo + 1e-6, True), (0.5 * (lo + hi), True), (hi - 1e-6, True), (lo - 0.02, False)):
            if total < 0:
                continue
            worst = np.inf  # the least ZMP margin over the corners of the error box (exact: each is linear)
            for ex in (-tol.thrust, tol.thrust):
                for ey in (-tol.thrust, tol.thrust):
                    for m in (-tol.mass, tol.mass):
                        for angle in np.linspace(0, 2 * np.pi, 16, endpoint=False):
                            c = com + tol.com_m * np.array([np.cos(angle), np.sin(angle)])
                            f = total * share * (1 + np.array([ex, ey]))
                            w = weight * (1 + m)
                            zmp = (w * c - f @ fans) / (w - f.sum())
                            worst = min(worst, float((b - n @ zmp).min()))
            assert (worst >= -1e-9) == inside, (lo, hi, total, worst)
    assert checked > 50


def test_robot_yaml_names_legs_by_role(tmp_path, capsys):
    """A robot YAML whose leg lacks a role, names an unknown joint or frame, or whose trunk is not the
    URDF's root: one line naming the key, exit 2."""
    src = ROOT / "robots" / "jethr1" / "jethr1.yaml"
    cases = {
        "legs.left.joints.knee": lambda d: d["legs"]["left"]["joints"].pop("knee"),
        "legs.right.joints.hip_roll": lambda d: d["legs"]["right"]["joints"].update(hip_roll="elbow"),
        "legs.left.sole": lambda d: d["legs"]["left"].update(sole="no_such_frame"),
        "trunk": lambda d: d.update(trunk="left_foot"),
        "fans[2].mount": lambda d: d["fans"].append({"frame": "left_fan", "mount": "left_shank", "thrust_max_n": 5}),
    }
    for key, change in cases.items():
        doc = yaml.safe_load(src.read_text())
        doc["urdf"] = str(ROOT / "robots" / "jethr1" / "jethr1.urdf")
        change(doc)
        folder = tmp_path / key.replace(".", "_").replace("[", "").replace("]", "")
        folder.mkdir()
        (folder / "r.yaml").write_text(yaml.safe_dump(doc))
        assert run(["robot", "show", str(folder / "r.yaml")]) == 2, key
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and key in err, (key, err)
