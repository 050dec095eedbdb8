"""The MCAP writers (issue 23): size, messages and write time (best of 5) of each kind of file the
project writes, on the reference trial's plan, its feed-forward rehearsal (the first run's 50 Hz
record), the DYROS walk and a 5 cm balance space; and the whole ``jethr1 plan`` of the trial
(wall time of the command, best of 3, in a fresh process each). One core; about two minutes.

    .venv/bin/python bench/bench_mcap.py [--no-command]
"""

from __future__ import annotations

import io
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def best_of(f, n: int = 5) -> tuple[bytes, float]:
    best, out = float("inf"), b""
    for _ in range(n):
        t0 = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t0)
    return out, best


def messages(data: bytes) -> int:
    from mcap.reader import make_reader

    summary = make_reader(io.BytesIO(data)).get_summary()
    assert summary is not None and summary.statistics is not None
    return sum(summary.statistics.channel_message_counts.values())


def main() -> None:
    from jethr1_plan.balance_space.sweep import SweepSpec, sweep
    from jethr1_plan.files.balance_space import balance_space_mcap
    from jethr1_plan.files.plan_folder import write_plan
    from jethr1_plan.files.plan_mcap import trajectory_mcap
    from jethr1_plan.files.simulation import simulation_mcap
    from jethr1_plan.files.walk_folder import walk_mcap
    from jethr1_plan.pipeline.walk import run_walk
    from jethr1_plan.planning.plan import plan
    from jethr1_plan.planning.report import plan_summary
    from jethr1_plan.scenario import load_scenario
    from jethr1_plan.sim.rehearsal import Perturbation, simulate
    from jethr1_plan.walking.spec import load_walk

    scenario = load_scenario(ROOT / "configs" / "jet_hr1_trial.yaml")
    result = plan(scenario)
    robot, rows, cartons, paths = result.robot, result.rows, scenario.cartons, [st.path_m for st in result.steps]
    with tempfile.TemporaryDirectory() as tmp:
        folder, _ = write_plan(result, Path(tmp), plan_summary(result))
        record = simulate(folder, "feedforward", [Perturbation(1.0, (0.0, 0.0), 1.0, 0.05)], jobs=1)[0].record
    walk = run_walk(load_walk(ROOT / "configs" / "walks" / "dyros_walk.yaml"), rehearse=False)
    sx, sy, sz = (float(v) for v in robot.start_feet()["right"])
    space = sweep(SweepSpec(robot=robot, support_side="right", support_xyz=(sx, sy, sz), x_range=(sx - 0.8, sx + 0.9),
                            y_range=(sy - 0.7875, sy + 0.9125), z_range=(sz, sz + 0.3), resolution_m=0.05), jobs=1)
    sole = (robot.sole_length_m, robot.sole_width_m)
    cases = {"plan trajectory.mcap": lambda: trajectory_mcap(robot, rows, cartons, paths),
             "rehearsal simulation.mcap": lambda: simulation_mcap(robot, record, cartons),
             "walk trajectory.mcap": lambda: walk_mcap(walk),
             "balance_space.mcap (5 cm)": lambda: balance_space_mcap(space, *sole)}
    print(f"{'file':28s} {'bytes':>11s} {'write ms':>9s} {'messages':>9s}")
    for name, f in cases.items():
        data, t = best_of(f)
        print(f"{name:28s} {len(data):>11,d} {t * 1e3:9.1f} {messages(data):>9d}")


def command() -> None:
    """``jethr1 plan configs/jet_hr1_trial.yaml``, best of 3 fresh processes."""
    import os

    env = {**os.environ, "PYTHONPATH": str(ROOT)}  # this tree's code, whatever the venv installed
    best = float("inf")
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(3):
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-c", "from jethr1_plan.cli import entry; entry()", "plan",
                            str(ROOT / "configs" / "jet_hr1_trial.yaml"), "-o", tmp, "--no-progress"],
                           check=True, capture_output=True, cwd=ROOT, env=env)
            best = min(best, time.perf_counter() - t0)
    print(f"jethr1 plan configs/jet_hr1_trial.yaml: {best:.2f} s (best of 3 processes)")


if __name__ == "__main__":
    main()
    if "--no-command" not in sys.argv:
        command()
