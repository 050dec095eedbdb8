"""A step the robot can neither re-anchor nor optimise from where it stands, optimised again over a finer
swing path (``stepwise.plan_anew``): the displaced stances of two trials of the route of terrain seed 2
(``jethr1 terrain random --seed 2``, ``jethr1 route``; ``bench/bench_stepwise.py``, trials 44 and 86 of
200) that made the robot stop; now planned, every row held to the scenario's own limits (restated here
from the rows: the edge angle of (A-10) from the URDF's own forward kinematics, the friction the rows'
motion needs from verify's own dynamics) and executed in the twin with Jet-HR1's own sensors."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from jethr1_plan.control.time_laws import swing_row_positions
from jethr1_plan.errors import InfeasiblePlan
from jethr1_plan.planning.plan import plan
from jethr1_plan.records.plan_rows import RowField
from jethr1_plan.scenario import Step, load_scenario_text
from jethr1_plan.sim import stepwise
from jethr1_plan.sim.certificate import draws
from jethr1_plan.sim.stepwise import execute, executed_plan, reanchor_ends, refined_path, replan_step
from jethr1_plan.swing_path import Carton, arc_path

#: the route of terrain seed 2, one step of it: its cartons, the soles before the step (STANCE), the step
ROUTE_STEP = """\
name: random_2_step
robot: jethr1
seed: 2
start: {{left: {left}, right: {right}}}
terrain:
  cartons:
    - {{top_centre_m: [0.0, 0.1125, 0.0], size_m: [0.21, 0.11, 0.14]}}
    - {{top_centre_m: [0.0, -0.1125, 0.0], size_m: [0.21, 0.11, 0.14]}}
    - {{top_centre_m: [0.3242, 0.1898, -0.04], size_m: [0.21, 0.11, 0.1]}}
    - {{top_centre_m: [0.6449, -0.0628, -0.005], size_m: [0.21, 0.11, 0.135]}}
    - {{top_centre_m: [0.9028, 0.1384, -0.035], size_m: [0.21, 0.11, 0.105]}}
    - {{top_centre_m: [0.8931, -0.0553, -0.035], size_m: [0.21, 0.11, 0.105]}}
    - {{top_centre_m: [1.1746, 0.0, 0.005], size_m: [0.21, 0.4, 0.145]}}
steps:
  - {{swing: {swing}, landing_m: {landing}, path: {{kind: arc, clearance_m: 0.1, samples: 25, lift_m: 0.02,
     descent_m: 0.02}}}}
balance: {{policy: robust, thrust_max_n: 23.0, sole_margin_m: 0.005}}
"""
R1, R2, R3A = [0.3242, 0.1898, -0.04], [0.6449, -0.0628, -0.005], [0.9028, 0.1384, -0.035]
#: per trial: the route's step, the soles before it as planned, where the robot's kinematics put its swing sole
#: (the support sole where the plan has it: the step's frame), the foothold as it perceived it, the cartons'
#: shift in the step's frame (the support sole's true offset) [m], and the refusal's kind
CASES = {
    "trial 44, step 2": ("left", {"left": R1, "right": R2},
                         [0.3200012669535674, 0.18668746311594822, -0.03930511483852766],
                         [0.8982043767642728, 0.1394959201552103, -0.03440953460986635],
                         [-0.0023313108875637756, -0.0014615312463035213, 0.0005904653901336503], "edge angle"),
    # (the plain optimisation's refusal of this one turns on micrometres: rounded to 10 µm, it plans)
    "trial 86, step 1": ("right", {"left": R1, "right": [0.0, -0.1125, 0.0]},
                         [0.0006288973851306112, -0.11198198774947402, 0.00045253955585670275],
                         [0.6482341579589082, -0.06373446794189398, -0.004435818465385807],
                         [0.0019060412360987211, 0.001530965180317867, 0.0005641815346141901], "friction ratio"),
}


def _case(name):
    swing, feet, start_swing, target, shift, kind = CASES[name]
    landing = R3A if swing == "left" else R2
    sc = load_scenario_text(ROUTE_STEP.format(left=feet["left"], right=feet["right"], swing=swing, landing=landing),
                            "random_2_step.yaml")
    start = {s: np.asarray(v, dtype=float) for s, v in feet.items()}
    start[swing] = np.asarray(start_swing, dtype=float)
    cartons = tuple(Carton(tuple(float(c.top_centre_m[j] + shift[j]) for j in range(3)), c.size_m)
                    for c in sc.cartons)
    return sc, start, np.asarray(target, dtype=float), cartons, kind


@pytest.fixture(scope="module", params=sorted(CASES))
def refused(request):
    sc, start, target, cartons, kind = _case(request.param)
    return sc, plan(sc).steps[0], start, target, cartons, kind


def test_a_refined_path_puts_every_row_s_swing_sole_where_the_path_did():
    """The rows place the swing sole at min_jerk(k / n)·(N − 1) along the samples, linear between them: the
    path with every segment split in 2 or 4 places every row's sole at the same point (1e-12 m), while the
    trunk gets 2 or 4 times as many samples."""
    path = arc_path(np.array([0.0, -0.1125, 0.0]), np.array([0.6449, -0.0628, -0.005]), 0.1, 25, 0.02, 0.02)
    for factor in (2, 4):
        fine = refined_path(path, factor)
        assert fine.shape == (24 * factor + 1, 3)
        np.testing.assert_array_equal(fine[::factor], path)
        rows = [np.column_stack([np.interp(swing_row_positions(len(p), 8.0, 50.0), np.arange(len(p)), p[:, j])
                                 for j in range(3)]) for p in (path, fine)]
        np.testing.assert_allclose(rows[1], rows[0], atol=1e-12)


def _edge_angles_deg(robot, rows, support_xy: np.ndarray) -> np.ndarray:
    """(A-10)'s |θ_ZC − θ_CA| [deg] of every single-support row, the CoM from the URDF's own forward kinematics
    (tests/oracles) of the written trunk pose and joints, Z the support sole, A the swing sole."""
    from tests.oracles.urdf_reference import UrdfReference

    ref = UrdfReference(robot.urdf_path)
    c = rows.columns
    out = []
    for i in np.flatnonzero(np.asarray(c[RowField.PHASE]) == "swing"):
        q = dict(zip(robot.joint_names, np.asarray(c[RowField.Q_RAD][i], dtype=float), strict=True))
        _, com = ref.com(np.asarray(c[RowField.P_BODY_M][i]), float(c[RowField.YAW_RAD][i]), q)
        u, v = com[:2] - support_xy, np.asarray(c[RowField.SWING_M][i])[:2] - com[:2]
        out.append(math.degrees(math.atan2(abs(u[0] * v[1] - u[1] * v[0]), float(u @ v))))
    return np.array(out)


def _friction_ratios(robot, rows, dt: float) -> np.ndarray:
    """The horizontal over the vertical force the ground must give for the rows' motion, per row (the ends'
    stencils aside), by verify's own second differences and PlaCo's dynamics (``verify.motion``)."""
    from jethr1_plan.geometry import pose_from_quaternion
    from jethr1_plan.verify.motion import base_wrench, row_motion

    c = rows.columns
    pos = np.asarray(c[RowField.P_BODY_M], dtype=float)
    yaw = np.asarray(c[RowField.YAW_RAD], dtype=float)
    quat = np.column_stack([np.zeros_like(yaw), np.zeros_like(yaw), np.sin(yaw / 2), np.cos(yaw / 2)])
    q = np.asarray(c[RowField.Q_RAD], dtype=float)
    thrust = rows.fan_array().sum(axis=1)
    v, acc = row_motion(pos, quat, q, dt)
    w = robot.wrapper()
    out = np.zeros(len(q))
    for i in range(1, len(q) - 1):
        w.state.q[:3], w.state.q[3:7], w.state.q[7:] = pos[i], quat[i], q[i]
        w.state.qd, w.state.qdd = v[i], acc[i]
        w.update_kinematics()
        force, _ = base_wrench(pose_from_quaternion(pos[i], quat[i]), w.mass_matrix() @ acc[i] + w.non_linear_effects())
        out[i] = float(np.hypot(force[0], force[1]) / (force[2] - thrust[i]))
    return out


def test_a_step_refused_from_a_displaced_stance_is_planned_over_a_finer_path_within_every_limit(refused, monkeypatch):
    """Re-anchored (the plan's postures out of the legs' reach by millimetres) and optimised anew (25 samples: the
    trunk crouches by 2–5 cm between two of them, and the rows interpolating it leave the (A-10) cone by up to
    0.4° or need 0.53 of friction at the kink) both refuse the step; over the path with twice the samples the
    optimiser plans it, every row feasible under the scenario's own ρ = 5° and μ / 2 (trial 86's; trial 44's is now
    optimised again from the plan's own samples first, ``test_stepwise_reoptimised``: here that is left out)."""
    sc, nominal, start, target, cartons, kind = refused
    monkeypatch.setattr(stepwise, "reoptimised", lambda *a: None)  # trial 44's is: test_stepwise_reoptimised
    refinements = stepwise.REFINEMENTS
    monkeypatch.setattr(stepwise, "REFINEMENTS", ())
    with pytest.raises(InfeasiblePlan, match=kind):
        replan_step(sc, 0, nominal, start, target, cartons)
    monkeypatch.setattr(stepwise, "REFINEMENTS", refinements)
    result, mode = replan_step(sc, 0, nominal, start, target, cartons)
    assert mode == "optimised-fine"
    st = result.steps[0]
    assert len(st.path_m) == 49 and result.scenario.timing == sc.timing
    assert result.scenario.balance.rho_rad == sc.balance.rho_rad and result.scenario.cartons == cartons
    path = reanchor_ends(sc.steps[0].path_m, start[st.swing], target)
    np.testing.assert_allclose(st.path_m[::2], path, atol=1e-15)
    assert all(result.rows.columns[RowField.FEASIBLE])
    edges = _edge_angles_deg(sc.robot, result.rows, start[st.support][:2])
    assert edges.max() <= math.degrees(sc.balance.rho_rad) + 1e-3
    ratios = _friction_ratios(sc.robot, result.rows, 1.0 / sc.timing.rate_hz)
    assert ratios.max() <= sc.robot.sole_friction / 2.0 + 1e-3


def test_the_step_so_planned_is_executed_with_the_imu_law_and_lands_on_its_foothold(monkeypatch, tmp_path):
    """Trial 44's own draw (thrust ×0.93, servos ×0.81, its sensors' errors) in its step's frame as the world (the
    support sole where the plan put it, on its carton as the twin had it, 0.6 mm into it; the swing sole where the
    robot's kinematics put it; the foothold where it perceived it): without the fall-back the robot stops; with
    it, it plans the step over the finer path and executes it in the twin with its IMU law: upright, on its
    carton, within the route's 8 mm edge margin of the foothold; the executed plan holds the step as planned
    (its 49 samples' trunk postures) from where the sole stood to where it landed."""
    sc, start, target, cartons, _ = _case("trial 44, step 2")
    nominal = plan(sc).steps[0]
    robot = replace(sc.robot, sensors=replace(sc.robot.sensors, perception_error_m=0.0))  # it perceives `target`
    path = reanchor_ends(sc.steps[0].path_m, start["left"], target)
    half = 0.5 * (path - sc.steps[0].path_m)  # the trunk following half the sole's shift, as re-anchoring does
    moved = replace(nominal, path_m=path, samples=[replace(x, best=replace(x.best, p_body=x.best.p_body + half[i]))
                                                     for i, x in enumerate(nominal.samples)])
    here = replace(sc, robot=robot, start=start, cartons=cartons, steps=(Step("left", path),))
    monkeypatch.setattr(stepwise, "reoptimised", lambda *a: None)  # (it is re-optimised: test_stepwise_reoptimised)
    refinements = stepwise.REFINEMENTS
    monkeypatch.setattr(stepwise, "REFINEMENTS", ())
    with pytest.raises(InfeasiblePlan, match="edge angle"):
        replan_step(here, 0, moved, start, target, cartons)
    monkeypatch.setattr(stepwise, "REFINEMENTS", refinements)
    p = draws(0, 45, "default", None, robot)[44]
    assert p.thrust_gain == pytest.approx(0.9331232409900909)  # the bench's trial 44
    ex = execute(here, [moved], "feedback", p)
    assert ex.refused is None and ex.run.survived, (ex.refused, ex.run.fell)
    (rec,) = ex.steps
    assert rec["mode"] == "optimised-fine" and rec["path_samples"] == 49 and rec["survived_step"]
    assert rec["landing_error_m"] < 0.008
    done, _ = executed_plan(here, ex, tmp_path / "executed")
    (st,) = done.steps
    assert len(st.path_m) == 49 and np.array_equal(st.path_m[0], start["left"])
    np.testing.assert_allclose(st.path_m[-1][:2], rec["landed_m"][:2], atol=1e-12)
    np.testing.assert_allclose(st.p_body, ex.plans[0].result.steps[0].p_body, atol=1e-12)  # the world is the frame
