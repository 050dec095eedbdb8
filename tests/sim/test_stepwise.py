"""A plan of several steps executed step by step in the twin: each step planned from where the robot
estimates its soles stand to where it perceives the next foothold, in one continuous run."""

from __future__ import annotations

import numpy as np
import pytest

from jethr1_plan.planning.plan import plan
from jethr1_plan.scenario import load_scenario_text
from jethr1_plan.sim.rehearsal import Perturbation, rehearse
from jethr1_plan.sim.stepwise import execute, executed_plan, reanchor_ends
from jethr1_plan.sim.track import track_of
from jethr1_plan.swing_path import arc_path

#: two short steps forward onto two cartons (short swings: a fast test)
TWO_STEPS = """\
name: two_steps
robot: jethr1
seed: 1
start: {left: [0.0, 0.1125, 0.0], right: [0.0, -0.1125, 0.0]}
terrain:
  cartons:
    - {top_centre_m: [0.0, 0.1125, 0.0]}
    - {top_centre_m: [0.0, -0.1125, 0.0]}
    - {top_centre_m: [0.22, 0.1125, 0.0]}
    - {top_centre_m: [0.22, -0.1125, 0.0]}
steps:
  - {swing: left, landing_m: [0.22, 0.1125, 0.0], path: {kind: arc, clearance_m: 0.04, samples: 16, lift_m: 0.015,
     descent_m: 0.015}}
  - {swing: right, landing_m: [0.22, -0.1125, 0.0], path: {kind: arc, clearance_m: 0.04, samples: 16, lift_m: 0.015,
     descent_m: 0.015}}
timing: {swing_s: 4.0, transfer_s: 2.0, rate_hz: 50.0}
"""


@pytest.fixture(scope="module")
def two_steps():
    sc = load_scenario_text(TWO_STEPS, "two_steps.yaml")
    return sc, plan(sc)


def test_a_path_moved_to_new_ends_keeps_its_shape_between_them():
    path = arc_path(np.array([0.0, 0.1125, 0.0]), np.array([0.27, 0.13, 0.0]), 0.05, 40, 0.02, 0.02)
    start, end = path[0] + np.array([-0.004, 0.003, 0.0]), path[-1] + np.array([0.005, -0.002, 0.0])
    moved = reanchor_ends(path, start, end)
    assert np.array_equal(moved[0], start) and np.array_equal(moved[-1], end)
    off = moved - path
    # the offsets blend from one end's to the other's, level (the heights unchanged)
    assert np.array_equal(moved[:, 2], path[:, 2])
    assert np.all(np.linalg.norm(off - off[0], axis=1)[1:] > 0)
    np.testing.assert_allclose(off[len(path) // 2], (off[0] + off[-1]) / 2, atol=1.5e-3)


def test_step_by_step_each_step_lands_on_its_foothold_from_where_the_robot_stands(two_steps):
    """The robot is put down 8 mm off the plan's start (it does not know). Replayed whole, the plan carries
    that offset to every landing; step by step, the robot aims each step at the foothold it perceives
    relative to its support sole, and every landing comes within 6 mm of the plan's foothold; each step
    starts from the soles its sensors estimate (within 2 mm of where they are)."""
    sc, nominal = two_steps
    placed = (0.008, 0.0)
    ex = execute(sc, nominal.steps, "feedback", placed_m=placed)
    assert ex.run.survived and ex.refused is None and len(ex.steps) == 2
    for rec in ex.steps:
        assert rec["landing_error_m"] < 0.006, rec
        assert np.hypot(*rec["perception_error_m"]) <= sc.robot.sensors.perception_error_m + 1e-12
    # the second step started from the soles as estimated: compare with where the first one landed
    est = np.asarray(ex.steps[1]["estimated_start_m"]["left"])
    assert np.hypot(*(est[:2] - np.asarray(ex.steps[0]["landed_m"][:2]))) < 0.002
    # the same plan replayed whole from the displaced start: every landing off by about the offset
    from jethr1_plan.files.plan_table import plan_table

    track = track_of(plan_table(sc.robot, nominal.rows), sc.robot, sc.cartons, 50.0, 23.0,
                     {"thrust_error": 0.1, "mass_error": 0.05, "com_error_m": 0.01})
    track.pelvis[:, 0] += placed[0]
    whole = rehearse(track, "feedback")
    landed = [np.asarray(s["landed_m"]) for s in whole.steps]
    for k, st in enumerate(sc.steps):
        assert np.hypot(*(landed[k][:2] - st.landing_m[:2])) > 0.006


def test_the_executed_steps_are_a_plan_verify_accepts(two_steps, tmp_path):
    """The executed steps written as a plan folder: every sole where it truly landed, every row held by
    the planner's rules, and ``verify`` accepts it against its own scenario, executed.yaml."""
    from jethr1_plan.cli import run
    from jethr1_plan.files.plan_folder import PLAN_FILES, write_plan
    from jethr1_plan.planning.report import plan_summary

    sc, nominal = two_steps
    ex = execute(sc, nominal.steps, "feedback", Perturbation(thrust_gain=0.9, servo_stiffness_scale=0.85))
    assert ex.run.survived
    folder = tmp_path / "executed"
    result, text = executed_plan(sc, ex, folder)
    assert text and result.feasible
    for k, st in enumerate(result.scenario.steps):
        np.testing.assert_allclose(st.landing_m[:2], ex.steps[k]["landed_m"][:2], atol=1e-12)
    write_plan(result, folder, plan_summary(result), folder=folder, extra={"executed.yaml": text.encode()},
               own=PLAN_FILES | {"executed.yaml"})
    assert run(["verify", str(folder)]) == 0


def test_the_same_draw_gives_the_same_run(two_steps):
    sc, nominal = two_steps
    p = Perturbation.draw(np.random.default_rng([5, 0]), sc.robot.sensors, len(sc.robot.joint_names))
    a, b = (execute(sc, nominal.steps, "feedback", p) for _ in range(2))
    assert a.steps == b.steps and a.run.max_trunk_tilt_deg == b.run.max_trunk_tilt_deg


def test_a_feedforward_robot_reads_its_sensors_every_tick_while_it_estimates(two_steps, monkeypatch):
    """Executed step by step, the plan's commands alone still estimate between plans where the soles stand: the
    sensors are ticked at every control tick (read, or their truth kept for the next reading: ``SensorModel.tick``),
    so a delayed reading is the state that many ticks before, not the reading taken at the previous estimate (which,
    on a plan of four steps, put the third step's swing sole 0.31 m from where it stood, and the robot fell).
    Replayed whole, nothing reads them."""
    from jethr1_plan.sim import sensors as sensors_mod

    sc, nominal = two_steps
    reads = []  # every tick at which the sensors' truth is kept (read, or kept for a later reading)
    for name in ("read", "tick"):
        real = getattr(sensors_mod.SensorModel, name)
        monkeypatch.setattr(sensors_mod.SensorModel, name,
                            lambda self, d, t, *a, real=real, **k: reads.append(t) or real(self, d, t, *a, **k))
    ex = execute(sc, nominal.steps, "feedforward")
    ticks = np.diff(reads)
    assert ex.run.survived and len(reads) > 1000 and np.all(ticks >= 0) and np.max(ticks) < 0.0021
    # the second step starts from its swing sole estimated where it stands (it has not moved since the start)
    est = np.asarray(ex.steps[1]["estimated_start_m"]["right"])
    assert np.hypot(*(est[:2] - sc.start["right"][:2])) < 0.003
    from jethr1_plan.files.plan_table import plan_table

    reads.clear()
    rehearse(track_of(plan_table(sc.robot, nominal.rows), sc.robot, sc.cartons, 50.0, 23.0,
                      {"thrust_error": 0.1, "mass_error": 0.05, "com_error_m": 0.01}), "feedforward")
    assert reads == []


def test_the_run_names_each_landing_by_its_step_and_records_each_instant_once(two_steps):
    """The run's landings (``simulation.json``'s ``landing_errors_m``) name the scenario's step and the sole that
    swung, not the step within each executed one-step plan (which is 0 for every one); the record
    (``simulation.mcap``'s 50 Hz samples) holds each instant once: where one step's plan hands over to the next,
    the next plan's first tick carries the run's clock where the last one left it, and is not recorded again
    (a repeated stamp on ``/tf``: two transforms of every frame at one time, which tf2 rejects)."""
    sc, nominal = two_steps
    ex = execute(sc, nominal.steps, "feedback", record=True)
    assert ex.run.survived
    assert [(e["step"], e["sole"]) for e in ex.run.landing_errors_m] == [(k, st.swing) for k, st in enumerate(sc.steps)]
    t = np.asarray(ex.run.record["t"])
    np.testing.assert_allclose(np.diff(t), 0.02, atol=1e-9)  # 50 Hz throughout, across the hand-over
    assert len(t) == round(t[-1] / 0.02) + 1 and t[0] == 0.0
