"""Candidates per second of the evaluator (IK + CoM + thrust + edge angle) against a bare PlaCo loop.

Both run on one core in the same process, on the same candidates with the same IK iterations
(the evaluator records every IK run; the bare loop replays them): GA-like populations (200 over
±150 mm, 150 over ±25 mm) at every third sample of the 450 mm forward step. The two are timed
alternately five times; the ratio of the best times is reported (this machine's timing is noisy:
other tenants steal cycles, so the minimum is the figure least disturbed).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import jethr1_plan.arithmetic  # noqa: F401  (first: NumPy's and OpenBLAS's kernels pinned before they load)

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bare_loop import bare_replay_seconds

from jethr1_plan.kinematics.closed_form import ClosedFormPostureSolver
from jethr1_plan.kinematics.placo import PlacoPostureSolver
from jethr1_plan.optimisers.problem import evaluate_candidates
from jethr1_plan.physics.balance import body_yaw_eq4
from jethr1_plan.planning.problems import sample_problem
from jethr1_plan.robot.load import load_robot
from jethr1_plan.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]


def workload(robot):
    sc = load_scenario(ROOT / "configs" / "forward_ditch_450.yaml")
    step = sc.steps[0]
    support = sc.start["right"]
    rng = np.random.default_rng(0)
    problems, populations = [], []
    for i in range(0, len(step.path_m), 3):
        sw = step.path_m[i]
        fan = sw[:2] + np.asarray(robot.fan_for("left").offset_in_foot_m[:2])
        prob = sample_problem(sc, robot, "right", support, sw, float(body_yaw_eq4(support[:2], fan, "right")))
        centre = np.array([0.5 * (support[0] + sw[0]), -0.11, 0.30])
        for half, n in ((0.150, 200), (0.025, 150)):
            problems.append(prob)
            populations.append(centre + rng.uniform(-half, half, (n, 3)))
    return problems, populations


def main(repeats: int = 5) -> None:
    robot = load_robot("jethr1")
    problems, populations = workload(robot)
    n_cand = sum(len(p) for p in populations)
    solver = PlacoPostureSolver(robot)
    ours, bare = [], []
    for _ in range(repeats):
        solver.replay_log = []
        t0 = time.perf_counter()
        for prob, pop in zip(problems, populations, strict=True):
            evaluate_candidates(solver, prob, pop)
        ours.append(time.perf_counter() - t0)
        log, solver.replay_log = solver.replay_log, None
        bare.append(bare_replay_seconds(robot, log))
    iters = np.array([r[-1] for r in log])
    o, b = min(ours), min(bare)
    print(f"candidates: {n_cand} ({len(log)} IK runs, {iters.mean():.2f} iterations per run; "
          f"{n_cand - len(log)} rejected as out of reach without IK); best of {repeats} runs each")
    print(f"evaluator : {o / n_cand * 1e6:7.2f} us/candidate  {n_cand / o:9.0f} candidates/s")
    print(f"bare PlaCo: {b / n_cand * 1e6:7.2f} us/candidate  {n_cand / b:9.0f} candidates/s")
    print(f"ratio evaluator / bare loop: {o / b:.2f} (target <= 1.5); per run: "
          + ", ".join(f"{x / y:.2f}" for x, y in zip(ours, bare, strict=True)))
    # the closed-form numpy path on the same populations, and on one large batch (as in sweeps)
    analytic = ClosedFormPostureSolver(robot)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for prob, pop in zip(problems, populations, strict=True):
            evaluate_candidates(analytic, prob, pop)
        times.append(time.perf_counter() - t0)
    a = min(times)
    big = np.concatenate(populations)
    t0 = time.perf_counter()
    evaluate_candidates(analytic, problems[0], big)
    a_big = time.perf_counter() - t0
    print(f"analytic  : {a / n_cand * 1e6:7.2f} us/candidate in populations of 150-200 "
          f"({o / a:.1f}x the PlaCo evaluator), {a_big / len(big) * 1e6:.2f} us/candidate in one batch of "
          f"{len(big)} ({o / a_big * len(big) / n_cand:.1f}x)")


if __name__ == "__main__":
    main()
