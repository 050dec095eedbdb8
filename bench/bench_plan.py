"""Wall time of planning the trial with GAS at the paper's parameters, against the bare PlaCo cost.

The planner runs on one core with its PostureSolver recording every IK run; the bare PlaCo loop
then replays exactly those runs (same candidates, same start joints, same iterations) in the same
process. Both are repeated and each side's fastest run is compared (the per-run ratios are printed).
Target: total wall time (optimiser, sequence building, analysis, self-check and writing CSV + MCAP)
at most 2× the bare cost.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bare_loop import bare_replay_seconds

from jethr1_plan.io.plan_files import write_plan_outputs
from jethr1_plan.kinematics.placo import PlacoPostureSolver
from jethr1_plan.planning import plan, plan_summary
from jethr1_plan.robot.model import load_robot
from jethr1_plan.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]


def run_once(robot, config: str):
    solver = PlacoPostureSolver(robot)
    solver.replay_log = []
    t0 = time.perf_counter()
    scenario = load_scenario(ROOT / "configs" / f"{config}.yaml")
    result = plan(scenario, solver=solver)
    t_plan = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as d:
        write_plan_outputs(result, Path(d), plan_summary(result), trajectory=True)
    wall = time.perf_counter() - t0
    log, solver.replay_log = solver.replay_log, None
    return result, wall, t_plan, bare_replay_seconds(robot, log), len(log)


def main(config: str = "jet_hr1_trial", repeats: int = 5) -> None:
    robot = load_robot("jethr1")
    runs = [run_once(robot, config) for _ in range(int(repeats))]
    # this VM's timing is noisy (other tenants): each side's least-disturbed (fastest) run is compared
    result, wall, t_plan, _, n_ik = min(runs, key=lambda r: r[1])
    bare = min(r[3] for r in runs)
    s = plan_summary(result)
    print(f"{config}: {s['sample_count']} swing samples, {result.evaluations} evaluations "
          f"({n_ik} IK runs incl. {s['row_count']} output rows), feasible={s['feasible']}, "
          f"max thrust {s['max_thrust_n']:.2f} N, mean {s['mean_thrust_n']:.2f} N")
    print(f"best of {repeats} runs for each side:")
    print(f"planner wall time : {wall:6.2f} s (optimise + sequence {t_plan:.2f} s, write {wall - t_plan:.2f} s), "
          f"{result.evaluations / wall:,.0f} evaluations/s")
    print(f"bare PlaCo replay : {bare:6.2f} s")
    print(f"ratio wall / bare : {wall / bare:.2f} (target <= 2); per run: "
          + ", ".join(f"{r[1] / r[3]:.2f}" for r in runs))
    # the optimiser alone (no 50 Hz sequence, analysis, self-check or files)
    opt = []
    for _ in range(int(repeats)):
        solver = PlacoPostureSolver(robot)
        solver.replay_log = []
        t0 = time.perf_counter()
        plan(load_scenario(ROOT / "configs" / f"{config}.yaml"), solver=solver, build_rows=False)
        opt.append((time.perf_counter() - t0, bare_replay_seconds(robot, solver.replay_log)))
    o, b = min(x[0] for x in opt), min(x[1] for x in opt)
    print(f"optimiser alone   : {o:6.2f} s vs bare {b:.2f} s -> ratio {o / b:.2f}")


if __name__ == "__main__":
    main(*sys.argv[1:])
