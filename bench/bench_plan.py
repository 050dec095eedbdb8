"""Wall time of planning the trial: the default optimiser (sqp) against GAS, everything included, and
GAS against the bare PlaCo cost.

Part 1 (issue: the trial planned in under a second on one core): ``plan`` of the trial with the
default optimiser and with GAS (``--optimiser gas``), in this process, everything included (scenario
load, optimisation, the 50 Hz sequence, analysis, self-check, CSV + MCAP + summary written); the
first run in the process (compiled functions loaded) and the best of the warm runs; the ratios; a
profile of one warm default run.

Part 2 (GAS):
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

from jethr1_plan.files.plan_folder import write_plan
from jethr1_plan.kinematics.placo import PlacoPostureSolver
from jethr1_plan.pipeline.plan import self_check
from jethr1_plan.planning.plan import plan
from jethr1_plan.planning.report import plan_summary
from jethr1_plan.robot.load import load_robot
from jethr1_plan.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]


def write_outputs(result, folder: Path) -> None:
    """The plan's files, re-checked first (as ``jethr1 plan`` writes them)."""
    summary = plan_summary(result)
    write_plan(result, folder, summary, check=lambda text: self_check(text, result, summary, False))


def full_plan(config: str, method: str | None = None):
    """One ``jethr1 plan`` in this process, everything but the imports: (result, wall [s])."""
    t0 = time.perf_counter()
    scenario = load_scenario(ROOT / "configs" / f"{config}.yaml")
    result = plan(scenario, method=method)
    with tempfile.TemporaryDirectory() as d:
        write_outputs(result, Path(d))
    return result, time.perf_counter() - t0


def default_against_gas(config: str = "jet_hr1_trial", repeats: int = 7) -> None:
    """Part 1: the default optimiser's whole plan against GAS's, in one run."""
    import cProfile
    import io
    import pstats

    _, cold = full_plan(config)
    warm = [full_plan(config) for _ in range(repeats)]
    result, best = min(warm, key=lambda r: r[1])
    gas_runs = [full_plan(config, "gas") for _ in range(3)]
    gas, gas_best = min(gas_runs, key=lambda r: r[1])
    s, g = plan_summary(result), plan_summary(gas)
    print(f"{config}, whole plan (optimise, 50 Hz sequence, analysis, self-check, files), one core:")
    print(f"  default {result.method}: {best:.3f} s warm (best of {repeats}; median "
          f"{sorted(w[1] for w in warm)[repeats // 2]:.3f} s), {cold:.3f} s as the first plan in the process; "
          f"{result.evaluations} evaluations; max {s['peak_thrust_n']:.3f} N, mean {s['mean_thrust_n']:.3f} N, "
          f"Σ‖ΔP‖² {s['smoothness_m2']:.2e} m² (target < 1 s)")
    print(f"  gas: {gas_best:.3f} s (best of 3), {gas.evaluations} evaluations; max {g['peak_thrust_n']:.3f} N, "
          f"mean {g['mean_thrust_n']:.3f} N, Σ‖ΔP‖² {g['smoothness_m2']:.2e} m²")
    print(f"  ratio gas / default: wall {gas_best / best:.1f}x, "
          f"evaluations {gas.evaluations / result.evaluations:.1f}x")
    pr = cProfile.Profile()
    pr.enable()
    full_plan(config)
    pr.disable()
    out = io.StringIO()
    pstats.Stats(pr, stream=out).sort_stats("cumulative").print_stats(r"jethr1_plan", 14)
    print("  profile of one warm default plan (cumulative, jethr1_plan functions):")
    print("\n".join("    " + line for line in out.getvalue().splitlines() if "jethr1_plan" in line or "ncalls" in line))


def run_once(robot, config: str):
    solver = PlacoPostureSolver(robot)
    solver.replay_log = []
    t0 = time.perf_counter()
    scenario = load_scenario(ROOT / "configs" / f"{config}.yaml")
    result = plan(scenario, method="gas", solver=solver)
    t_plan = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as d:
        write_outputs(result, Path(d))
    wall = time.perf_counter() - t0
    log, solver.replay_log = solver.replay_log, None
    return result, wall, t_plan, bare_replay_seconds(robot, log), len(log)


def main(config: str = "jet_hr1_trial", repeats: int = 5) -> None:
    default_against_gas(config)
    print("GAS against the bare PlaCo cost:")
    robot = load_robot("jethr1")
    runs = [run_once(robot, config) for _ in range(int(repeats))]
    # this VM's timing is noisy (other tenants): each side's least-disturbed (fastest) run is compared
    result, wall, t_plan, _, n_ik = min(runs, key=lambda r: r[1])
    bare = min(r[3] for r in runs)
    s = plan_summary(result)
    print(f"{config}: {s['sample_count']} swing samples, {result.evaluations} evaluations "
          f"({n_ik} PlaCo IK runs; the {s['row_count']} output rows in closed form), feasible={s['feasible']}, "
          f"max thrust {s['peak_thrust_n']:.2f} N, mean {s['mean_thrust_n']:.2f} N")
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
        plan(load_scenario(ROOT / "configs" / f"{config}.yaml"), method="gas", solver=solver, build_rows=False)
        opt.append((time.perf_counter() - t0, bare_replay_seconds(robot, solver.replay_log)))
    o, b = min(x[0] for x in opt), min(x[1] for x in opt)
    print(f"optimiser alone   : {o:6.2f} s vs bare {b:.2f} s -> ratio {o / b:.2f}")


if __name__ == "__main__":
    main(*sys.argv[1:])
