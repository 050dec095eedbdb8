"""``verify`` restates the physics it checks (verify/balance.py, commands.py, motion.py, the footsteps of
verify/walk.py) instead of importing the planner's: here each restatement is held to the planner's own
function on random postures, so that a mistake in either is caught by the other, and a planner whose
formula is wrong has its plan refused."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from jethr1_plan.geometry import GRAVITY, SIDES, convex_hull, polygon_margin, sole_polygon
from jethr1_plan.physics.balance import Tolerance, balance_slack, shared_window, thrust_window, zmp_with_thrusts
from jethr1_plan.physics.share import row_shares
from jethr1_plan.verify import balance as vb
from tests.conftest import ROOT

N_POSTURES = 3000
SOLE = (0.15, 0.09)  # length, width [m] of the random soles


def _posture(rng: np.random.Generator) -> dict:
    """One random posture: one sole or two (the hull), shrunk or not; a CoM near them; 1 to 3 fans; shares
    of the total; thrusts inside and outside the window; a tolerance."""
    two = rng.random() < 0.5
    centres = [rng.uniform(-0.3, 0.3, 2)]
    if two:
        centres.append(centres[0] + rng.uniform([-0.3, 0.12], [0.3, 0.4]) * rng.choice([-1.0, 1.0]))
    shrink = rng.choice([0.0, rng.uniform(0.0, 0.02)])
    nf = int(rng.integers(1, 4))
    mid = np.mean(centres, axis=0)
    com = mid + rng.normal(0.0, 0.12, 2)
    fans = mid + rng.normal(0.0, 0.25, (nf, 2))
    share = rng.dirichlet(np.ones(nf)) if rng.random() < 0.7 else np.eye(nf)[rng.integers(nf)]
    tol = Tolerance(*(rng.uniform(0.0, 0.2), rng.uniform(0.0, 0.1), rng.uniform(0.0, 0.02)) if rng.random() < 0.8
                    else (0.0, 0.0, 0.0))
    return {"centres": centres, "shrink": float(shrink), "com": com, "fans": fans, "share": share, "tol": tol,
            "mass": float(rng.uniform(3.0, 30.0))}


def _v(tol: Tolerance) -> vb.Tolerance:
    return vb.Tolerance(tol.thrust, tol.mass, tol.com_m)


def _planner_polygon(p: dict) -> np.ndarray:
    polys = [sole_polygon(c, 0.0, *SOLE, p["shrink"]) for c in p["centres"]]
    return polys[0] if len(polys) == 1 else convex_hull(np.vstack(polys))


def _verify_edges(p: dict) -> tuple[np.ndarray, np.ndarray]:
    if len(p["centres"]) == 1:
        n, b = vb.sole_edges(p["centres"][0], *SOLE, p["shrink"])
        return n, b
    n, b = vb.hull_edges(p["centres"], *SOLE, p["shrink"])
    return n[None], b[None]


def test_verify_balance_agrees_with_the_planners_on_random_postures():
    """On N_POSTURES random postures, verify's support margin, ZMP, nominal window (its ray against the
    planner's edge inequalities), balance slack (the error box's corners against the folded |a| terms) and
    tolerance share (closed-form roots against bisection) equal the planner's."""
    rng = np.random.default_rng([37, 5])
    agree = {"margin": 0, "zmp": 0, "window": 0, "slack": 0, "share": 0}
    opened = shared = 0
    for _ in range(N_POSTURES):
        p = _posture(rng)
        poly = _planner_polygon(p)
        n, b = _verify_edges(p)
        com, fans, share, m = p["com"][None], p["fans"][None], p["share"][None], p["mass"]
        # the support polygon
        probe = p["com"] + rng.normal(0.0, 0.05, 2)
        assert vb.support_margin(probe[None], n, b)[0] == pytest.approx(float(polygon_margin(probe, poly)), abs=1e-12)
        agree["margin"] += 1
        # the nominal window of the fans in their shares
        lo, hi = vb.thrust_window(com, fans, share, n, b, m)
        if np.count_nonzero(p["share"]) == 1:
            k = int(np.flatnonzero(p["share"])[0])
            lo_p, hi_p = thrust_window(p["com"], p["fans"][k], poly, m)
        else:
            lo_p, hi_p = shared_window(p["com"], p["fans"], p["share"], poly, m)
            shared += 1
        if np.isfinite(lo_p):
            opened += 1
            # the planner caps the total a hair below the weight, 1e-9·M·g
            assert lo[0] == pytest.approx(float(lo_p), abs=1e-9 * (1.0 + m * GRAVITY))
            assert hi[0] == pytest.approx(float(hi_p), abs=2e-9 * m * GRAVITY)
        else:
            assert np.isinf(lo[0]) and np.isnan(hi[0]), (lo, hi, lo_p, hi_p)
        agree["window"] += 1
        # thrusts: inside the nominal window where it opens, else anywhere up to the weight
        top = float(hi_p) if np.isfinite(lo_p) else 0.9 * m * GRAVITY
        total = float(lo_p) + rng.random() * (top - float(lo_p)) if np.isfinite(lo_p) else rng.uniform(0, top)
        thrust = total * p["share"]
        zmp = vb.zmp_of_thrust(com, fans, thrust[None], m)[0]
        assert zmp == pytest.approx(zmp_with_thrusts(p["com"], p["fans"], thrust, m), abs=1e-12)
        agree["zmp"] += 1
        s = rng.uniform(0.0, 1.0)
        slack = vb.balance_slack(com, fans, thrust[None], n, b, m, _v(p["tol"]), np.array([s]))[0]
        slack_p = float(balance_slack(p["com"], p["fans"], thrust, poly, m, p["tol"].scaled(s)))
        assert slack == pytest.approx(slack_p, abs=1e-9 * (1.0 + m * GRAVITY))
        agree["slack"] += 1
        share_v = vb.largest_share(com, fans, thrust[None], n, b, m, _v(p["tol"]))[0]
        share_p = float(row_shares(p["com"], p["fans"], thrust, poly, m, p["tol"]))
        assert share_v == pytest.approx(share_p, abs=1e-9), (p, thrust)
        agree["share"] += 1
    assert agree == dict.fromkeys(agree, N_POSTURES)
    assert opened > N_POSTURES // 4 and shared > N_POSTURES // 4  # open windows and shared ones both tried


def test_the_shares_are_not_all_trivial():
    """The random postures of the test above reach shares strictly between 0 and 1 (where the two
    methods differ most: a root against a bisection)."""
    rng = np.random.default_rng([37, 5])
    inner = 0
    for _ in range(600):
        p = _posture(rng)
        poly = _planner_polygon(p)
        n, b = _verify_edges(p)
        if np.count_nonzero(p["share"]) != 1 or p["tol"] == Tolerance():
            continue
        k = int(np.flatnonzero(p["share"])[0])
        lo_p, hi_p = thrust_window(p["com"], p["fans"][k], poly, p["mass"])
        if not np.isfinite(lo_p):
            continue
        thrust = float(lo_p + 0.5 * (hi_p - lo_p)) * p["share"]
        s = vb.largest_share(p["com"][None], p["fans"][None], thrust[None], n, b, p["mass"], _v(p["tol"]))[0]
        inner += 0.0 < s < 1.0
    assert inner >= 20


def test_verify_commands_agree_with_the_planners():
    from jethr1_plan.control import commands
    from jethr1_plan.verify import commands as vc

    rng = np.random.default_rng([37, 6])
    for _ in range(50):
        n, nj, nf = int(rng.integers(1, 60)), 12, int(rng.integers(1, 4))
        q, tau = rng.normal(0, 0.5, (n, nj)), rng.normal(0, 3.0, (n, nj))
        k, rate = rng.uniform(5, 50, nj), float(rng.choice([10.0, 50.0, 100.0]))
        for filter_s in (vc.PLAN_SAG_FILTER_S, vc.WALK_SAG_FILTER_S, float(rng.uniform(0.01, 1.0))):
            np.testing.assert_allclose(vc.servo_commands(q, tau, k, rate, filter_s),
                                       commands.servo_commands(q, tau, k, rate, filter_s), rtol=0, atol=1e-12)
        thrust = np.abs(rng.normal(10, 8, (n, nf)))
        lag, fmax = rng.uniform(0.0, 0.2, nf), rng.uniform(15, 30, nf)
        np.testing.assert_allclose(vc.fan_commands(thrust, rate, lag, fmax),
                                   commands.fan_commands(thrust, rate, lag, fmax), rtol=0, atol=1e-9)
    # the constants each states are the same
    assert vc.PLAN_SAG_FILTER_S == commands.SAG_FILTER_S
    from jethr1_plan.walking.result import WALK_SAG_FILTER_S

    assert vc.WALK_SAG_FILTER_S == WALK_SAG_FILTER_S


@pytest.mark.parametrize("n", [1, 2, 255, 256, 257, 513, 3000])
def test_the_verifiers_low_pass_in_closed_form_agrees_with_a_stepped_filter_across_its_blocks(n):
    """The verifier's block-wise closed form of the sag filter against SciPy's ``lfilter`` and the planner's
    own loop, at a plan's 500 Hz and across the blocks' seams (256 rows)."""
    from scipy.signal import lfilter

    from jethr1_plan.control import commands
    from jethr1_plan.verify import commands as vc

    rng = np.random.default_rng([37, 7, n])
    tau = rng.normal(0, 3.0, (n, 12)) + np.linspace(0.0, 20.0, n)[:, None]
    for filter_s in (vc.PLAN_SAG_FILTER_S, 0.004, 3.0):
        alpha = 1.0 - math.exp(-1.0 / (500.0 * filter_s))
        stepped, _ = lfilter([alpha], [1.0, alpha - 1.0], tau, axis=0, zi=(1.0 - alpha) * tau[:1])
        np.testing.assert_allclose(vc.low_pass(tau, alpha), stepped, rtol=0, atol=1e-9)
        np.testing.assert_allclose(vc.low_pass(tau, alpha), commands.low_pass(tau, 500.0, filter_s), rtol=0, atol=1e-9)


def test_verify_motion_agrees_with_the_planners_row_dynamics(robot, side_step_plan):
    """The ground's vertical force of a written plan's rows (verify's SE(3) logarithm from quaternions,
    PlaCo's inverse dynamics) is the planner's ``physics.row_dynamics``' on every row."""
    from jethr1_plan.files.plan_csv import read_trajectory_csv
    from jethr1_plan.geometry import pose_from_quaternion
    from jethr1_plan.physics.row_dynamics import row_dynamics
    from jethr1_plan.verify.motion import vertical_ground_force

    c = read_trajectory_csv((side_step_plan / "trajectory.csv").read_text(), robot=robot)
    rows = slice(130, 230)  # a transfer into the swing: the trunk accelerates
    pos = np.stack([c[f"pelvis_{a}_m"] for a in "xyz"], axis=1).astype(float)[rows]
    quat = np.stack([c[f"pelvis_q{a}"] for a in "xyzw"], axis=1).astype(float)[rows]
    q = np.stack([c[f"{j}_rad"] for j in robot.joint_names], axis=1).astype(float)[rows]
    thrust = np.stack([c[f"thrust_{f.name}_n"] for f in robot.fans], axis=1).astype(float)[rows]
    dt = 1.0 / json.loads((side_step_plan / "summary.json").read_text())["trajectory"]["rate_hz"]
    mine = vertical_ground_force(robot, pos, quat, q, thrust, dt)
    base = np.array([pose_from_quaternion(p, qt) for p, qt in zip(pos, quat, strict=True)])
    theirs = row_dynamics(robot, base, q, thrust, c["support"][rows], dt).vertical_force_n
    np.testing.assert_allclose(mine, theirs, rtol=0, atol=1e-8)
    assert np.ptp(mine) > 0.01  # the rows move: the force is not the weight alone


@pytest.mark.parametrize("name", ["side_step", "scattered_steps", "forward_ditch_450_trunk_fan"])
def test_verify_sequence_and_feet_agree_with_the_planners(name):
    from jethr1_plan.control.time_laws import swing_row_positions
    from jethr1_plan.planning.problems import feet_before_each_step
    from jethr1_plan.scenario import load_scenario
    from jethr1_plan.verify.plan_rows import expected_sequence, scenario_feet

    sc = load_scenario(ROOT / "configs" / f"{name}.yaml")
    rate = sc.timing.rate_hz
    seq = expected_sequence(sc, rate)
    for k, st in enumerate(sc.steps):
        swing = [r for r in seq if r[0] == "swing" and r[1] == k]
        assert len(swing) == len(swing_row_positions(len(st.path_m), sc.timing.swing_s, rate))
    phase = np.array([r[0] for r in seq])
    step = np.array([r[1] for r in seq])
    feet = scenario_feet(sc, step, phase)
    before = feet_before_each_step(sc)
    for i, (ph, k) in enumerate(zip(phase, step, strict=True)):
        if ph == "transfer" and k < len(sc.steps):
            for s in SIDES:
                np.testing.assert_array_equal(feet[s][i], before[k][s])


def test_verify_walk_footsteps_and_rules_agree_with_the_walks(robot, tmp_path):
    """verify/walk.py's footsteps (from the summary alone) give the walk generator's support, footholds and
    air phases at every row time; its default criteria and limits are the walk's."""
    from dataclasses import asdict

    from jethr1_plan.verify import walk as vw
    from jethr1_plan.walking import analysis
    from jethr1_plan.walking.ik import IKSettings
    from jethr1_plan.walking.timeline import Timeline

    summary = {"spec": {"timing": {"start_s": 1.0, "single_support_s": 0.8, "double_support_s": 0.4, "end_s": 1.0,
                                   "swing_height_m": 0.05}},
               "start_m": {"left": [0.0, 0.12, 0.0], "right": [0.0, -0.12, 0.0]}}
    holds = [("left", [0.3, 0.12, 0.0]), ("right", [0.55, -0.12, 0.02]), ("left", [0.8, 0.1, 0.0]),
             ("right", [0.8, -0.12, 0.0])]
    tl = Timeline.build({s: np.array(v) for s, v in summary["start_m"].items()},
                        [(s, np.array(p)) for s, p in holds], 1.0, 0.8, 0.4, 1.0, 0.05, robot.sole_length_m,
                        robot.sole_width_m)
    summary["steps"] = [{"side": st.side, "position_m": st.position_m.tolist(), "lift_s": st.t_lift,
                         "land_s": st.t_land} for st in tl.steps]
    steps = vw._footsteps(summary, "summary.json")
    t = np.round(np.arange(0.0, tl.duration_s + 1e-9, 0.01), 9)
    support, _ = tl.phase(t)
    assert list(steps.support(t)) == list(support)
    feet, air = steps.feet(t)
    feet_p, air_p = tl.feet(t)
    for s in SIDES:
        assert np.array_equal(air[s], air_p[s])
        np.testing.assert_array_equal(feet[s][~air[s]], feet_p[s][~air[s]])
    criteria = asdict(analysis.SuccessCriteria())
    assert {k: criteria[k] for k in vw.CRITERIA} == vw.CRITERIA
    assert IKSettings().max_joint_acceleration_rad_s2 == vw.MAX_JOINT_ACCELERATION
    assert (vw.EDGE_ROWS, vw.ACCELERATION_TOL) == (analysis.EDGE_ROWS, analysis.ACCELERATION_TOL)
    summary["steps"][2]["lift_s"] += 0.01  # a step whose timing the summary contradicts
    with pytest.raises(Exception, match=r"steps\[2\]"):
        vw._footsteps(summary, "summary.json")


SHORT_SIDE_STEP = {"path": {"kind": "arc", "clearance_m": 0.05, "samples": 12}, "timing": {"swing_s": 2.0,
                                                                                           "transfer_s": 1.0,
                                                                                           "rate_hz": 25.0}}


def _short_side_step(tmp_path):
    import yaml

    from jethr1_plan.scenario import load_scenario

    doc = yaml.safe_load((ROOT / "configs" / "side_step.yaml").read_text())
    doc["steps"][0]["path"] = SHORT_SIDE_STEP["path"]
    doc["timing"] = SHORT_SIDE_STEP["timing"]
    path = tmp_path / "short_side_step.yaml"
    path.write_text(yaml.safe_dump(doc))
    return load_scenario(path)


@pytest.mark.parametrize("broken, check", [
    ("window", "thrust window column wrong"),
    ("share", "tolerance share column wrong"),
])
def test_a_planner_with_a_wrong_formula_has_its_plan_refused(tmp_path, monkeypatch, broken, check):
    """The planner's window function made 5 % too wide at its upper end (the thrust it chooses, the lower end,
    unchanged), or its tolerance share made 5 % too small: every other check still holds, and verify, which
    no longer calls the planner's function, refuses the plan as its self-check (nothing written). Before
    verify restated the physics it recomputed the window and the share with the very functions broken here,
    and the plan was written."""
    import jethr1_plan.physics.balance as balance
    import jethr1_plan.planning.sequence as sequence
    from jethr1_plan.errors import SelfCheckFailed
    from jethr1_plan.physics import share as share_mod
    from jethr1_plan.pipeline.plan import plan_to_folder

    sc = _short_side_step(tmp_path)
    if broken == "window":
        right = balance.thrust_window

        def wide(*args, **kwargs):
            lo, hi = right(*args, **kwargs)
            return lo, lo + 1.05 * (hi - lo)

        monkeypatch.setattr(balance, "thrust_window", wide)
        monkeypatch.setattr(sequence, "thrust_window", wide)
    else:
        right_share = share_mod.row_shares

        def small(*args, **kwargs):
            return 0.95 * right_share(*args, **kwargs)

        monkeypatch.setattr(share_mod, "row_shares", small)
        monkeypatch.setattr(sequence, "row_shares", small)
    with pytest.raises(SelfCheckFailed, match=check):
        plan_to_folder(sc, tmp_path / "out")
    assert not (tmp_path / "out" / "short_side_step" / "trajectory.csv").exists()
    monkeypatch.undo()
    _, summary, folder, _ = plan_to_folder(sc, tmp_path / "out")  # the right formulas: the plan verifies
    assert (folder / "trajectory.csv").is_file() and summary["feasible"]
