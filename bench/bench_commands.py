"""Whole commands as users feel them, against a bare PlaCo loop measured in the same run.

Each command runs as a shell would run it (a fresh process: interpreter start, imports, compiled
kernels loaded from numba's cache, the work, the files written), ``repeats`` times, interleaved with
the yardstick so that both see the same load; the best wall time of each is kept, and the CPU time
(user + system) of that run is printed beside it.

The yardstick (issue 28): 60,000 bare PlaCo evaluations in this process, each one candidate as the
planner's evaluator sees it: the trunk put at a candidate pose, the legs warm-started from the previous
candidate, three IK iterations (``update_kinematics`` + ``solve``) on the two sole tasks, then
``update_kinematics`` + ``com_world`` (docs/benchmarks.md). Target: ``jethr1 plan`` of the trial at
most 1 unit.

Usage: ``python bench/bench_commands.py [--repeats N] [--jethr1 PREFIX] [--baseline PREFIX] [--only TEXT]``: a prefix is
the command that runs a jethr1 (default: this venv's); ``--baseline`` times a second one (another checkout,
e.g. ``"env PYTHONPATH=/path/to/old .venv/bin/python -P -c 'from jethr1_plan.cli import entry; entry()'"``;
``-P``: the commands run in this repository, whose own package ``python -c`` would import first) in the same
run, interleaved, for a before/after table.
"""

from __future__ import annotations

import argparse
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import jethr1_plan.arithmetic  # noqa: F401  (first: NumPy's and OpenBLAS's kernels pinned before they load)

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
EVALUATIONS = 60_000
IK_ITERATIONS = 3


def bare_evaluations_seconds(n: int = EVALUATIONS, iterations: int = IK_ITERATIONS) -> tuple[float, float]:
    """(wall [s], CPU [s]) of ``n`` bare PlaCo evaluations (trunk pose, warm IK, CoM) of Jet-HR1."""
    import placo

    from jethr1_plan.robot.load import load_robot

    model = load_robot("jethr1")
    robot = model.wrapper()
    solver = placo.KinematicsSolver(robot)
    solver.mask_fbase(True)
    tasks = []
    for side in ("left", "right"):
        sole = model.legs[side].sole
        task = solver.add_frame_task(sole, np.eye(4))
        task.configure(sole, "soft", 1.0, 1.0)
        T = np.eye(4)
        T[:3, 3] = (0.0, 0.09 if side == "left" else -0.09, 0.0)
        task.T_world_frame = T
        tasks.append(task)
    q = np.clip(np.zeros(len(model.joint_names)), model.lower_rad, model.upper_rad)
    for side in ("left", "right"):  # bent knees: the planner's seed
        q[np.asarray(model.legs[side].index)] = (0.0, 0.0, -0.5, 1.0, -0.5, 0.0)
    robot.state.q[7:] = q
    rng = np.random.default_rng(0)
    trunk = np.tile(np.eye(4), (n, 1, 1))
    trunk[:, :3, 3] = np.array([0.0, 0.0, 0.30]) + rng.uniform(-0.03, 0.03, (n, 3))
    w0, c0 = time.perf_counter(), time.process_time()
    for k in range(n):
        robot.set_T_world_fbase(trunk[k])
        for _ in range(iterations):
            robot.update_kinematics()
            solver.solve(True)
        robot.update_kinematics()
        robot.com_world()
    return time.perf_counter() - w0, time.process_time() - c0


def run_command(argv: list[str], cwd: Path, env: dict[str, str] | None = None, said: list[str] | None = None
                ) -> tuple[float, float, int]:
    """(wall [s], CPU of the process and its children [s], exit code) of one command (``said``: its stderr lines
    appended)."""
    w0 = time.perf_counter()
    proc = subprocess.Popen(argv, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - w0
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode() if proc.stderr else ""
    if proc.stderr:
        proc.stderr.close()
    if proc.returncode not in (0, 5, 6):
        raise SystemExit(f"{shlex.join(argv)} exited {proc.returncode}:\n{err[-2000:]}")
    if said is not None:
        said.extend(err.splitlines())
    return wall, usage.ru_utime + usage.ru_stime, proc.returncode


IMPORTS = "import numpy, placo, numba, scipy.optimize, mcap"  # the floor of a plan's imports
CACHED = """import numba


@numba.njit(cache=True)
def one(x):
    return x + 1.0
"""  # the smallest function numba can load from its cache: what the first of any kernels costs (its code generator)


def commands(jethr1: list[str], out: Path) -> dict[str, list[str]]:
    """The whole commands timed (in order: later ones read what earlier ones wrote); the first two are the floor
    any plan pays before it plans: the imports, then one compiled function loaded from numba's cache."""
    py = [sys.executable, "-c"]
    (out / "floor").mkdir(parents=True, exist_ok=True)
    (out / "floor" / "cached_one.py").write_text(CACHED)
    floor = f"{IMPORTS}; import sys; sys.path.insert(0, {str(out / 'floor')!r}); import cached_one; cached_one.one(1.0)"
    subprocess.run([*py, floor], check=True)  # (numba's cache of it written now, outside the timing)
    return {
        "imports only: numpy, placo, numba, scipy.optimize, mcap": [*py, IMPORTS],
        "floor: those imports + 1 function from numba's cache": [*py, floor],
        "imports of jethr1 plan's own modules (numba not among them)": [
            *py, "import jethr1_plan.cli, jethr1_plan.cli.plan, jethr1_plan.pipeline.plan"],
        "jethr1 --help": [*jethr1, "--help"],
        "jethr1 plan configs/jet_hr1_trial.yaml": [*jethr1, "plan", "configs/jet_hr1_trial.yaml", "-o",
                                                   str(out), "--no-progress"],
        "jethr1 verify <the trial's plan>": [*jethr1, "verify", str(out / "jet_hr1_trial")],
        "jethr1 simulate <the trial's plan>": [*jethr1, "simulate", str(out / "jet_hr1_trial"), "--no-progress"],
        "jethr1 walk configs/walks/jethr1_walk.yaml": [*jethr1, "walk", "configs/walks/jethr1_walk.yaml", "-o",
                                                       str(out)],
        "jethr1 verify <the walk>": [*jethr1, "verify", str(out / "jethr1_walk")],
        "jethr1 robot show": [*jethr1, "robot", "show"],
    }


TERRAINS = ("configs/terrains/jet_hr1_trial.yaml", "configs/terrains/jet_hr1_trial_robust.yaml")


def first_commands(jethr1: list[str], out: Path) -> dict[str, list[str]]:
    """The commands whose first run on a fresh install is timed (in order: later ones read what earlier ones
    wrote)."""
    return {
        "jethr1 plan configs/jet_hr1_trial.yaml": [*jethr1, "plan", "configs/jet_hr1_trial.yaml", "-o", str(out),
                                                   "--no-progress"],
        "jethr1 verify <the trial's plan>": [*jethr1, "verify", str(out / "jet_hr1_trial")],
        "jethr1 simulate <the trial's plan>": [*jethr1, "simulate", str(out / "jet_hr1_trial"), "--no-progress"],
        "jethr1 walk configs/walks/jethr1_walk.yaml": [*jethr1, "walk", "configs/walks/jethr1_walk.yaml", "-o",
                                                       str(out)],
        "jethr1 robot show": [*jethr1, "robot", "show"],
        "jethr1 balance-space --resolution 0.05": [*jethr1, "balance-space", "--resolution", "0.05", "-o",
                                                   str(out / "bs"), "--no-progress"],
        "jethr1 route configs/terrains/jet_hr1_trial.yaml": [*jethr1, "route", TERRAINS[0], "-o", str(out / "route"),
                                                             "--no-progress"],
        "jethr1 ditch-curve --gaps 0.40:0.40:0.01 --scales ''": [*jethr1, "ditch-curve", "--gaps", "0.40:0.40:0.01",
                                                                 "--scales", "", "-j", "1", "-o", str(out / "dc"),
                                                                 "--no-progress"],
    }


BEFORE = ("jethr1 plan configs/jet_hr1_trial.yaml", "jethr1 balance-space --resolution 0.05",
          "jethr1 route configs/terrains/jet_hr1_trial.yaml")  # the first runs the issue names, timed without warm-up


def first_runs(jethr1: list[str], out: Path, before: bool) -> None:
    """Each command's first run on a fresh install (an empty numba cache and map cache), after ``jethr1 warm-up``
    (what ``make install`` runs); with ``before``, also each one's first run without the warm-up (a fresh pair of
    caches per command, for the commands of :data:`BEFORE`: it compiles what it needs and computes its maps
    itself). One run each, beside the yardstick measured before and after them (the smaller kept)."""
    def fresh(name: str) -> dict[str, str]:
        env = dict(os.environ)
        env["NUMBA_CACHE_DIR"] = str(out / name / "numba")
        env["JETHR1_CACHE"] = str(out / name / "maps")
        return env

    units = [bare_evaluations_seconds()]
    rows: list[tuple[str, float, float, bool]] = []
    env = fresh("installed")
    said: list[str] = []
    wall, cpu, _ = run_command([*jethr1, "warm-up", *TERRAINS], ROOT, env, said)
    rows.append(("jethr1 warm-up (make install runs it; once)", wall, cpu, True))
    for name, argv in first_commands(jethr1, out / "installed" / "out").items():
        said = []
        wall, cpu, _ = run_command(argv, ROOT, env, said)
        rows.append((name, wall, cpu, any("compiling the planner's kernels" in line for line in said)))
    if before:
        for name, argv in first_commands(jethr1, out / "bare" / "out").items():
            if name not in BEFORE:
                continue
            said = []
            wall, cpu, _ = run_command(argv, ROOT, fresh(f"bare_{len(rows)}"), said)
            rows.append((f"{name} (no warm-up)", wall, cpu, any("compiling the planner's kernels" in line
                                                                for line in said)))
    units.append(bare_evaluations_seconds())
    unit_wall, unit_cpu = min(units)
    print(f"first runs on a fresh install (empty numba and map caches), one run each, against {EVALUATIONS:,} bare "
          f"PlaCo evaluations in the same run ({unit_wall:.2f} s wall, {unit_cpu:.2f} s CPU; target <= 4 units):")
    print(f"  {'command':62s} {'wall [s]':>9s} {'CPU [s]':>8s} {'units (wall)':>13s} {'units (CPU)':>12s}  compiled")
    for name, wall, cpu, compiled in rows:
        print(f"  {name:62s} {wall:9.2f} {cpu:8.2f} {wall / unit_wall:13.2f} {cpu / unit_cpu:12.2f}  "
              f"{'yes' if compiled else 'no'}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3, help="runs of each (the best is kept)")
    ap.add_argument("--jethr1", default=None, help="command prefix that runs jethr1 (default: this venv's)")
    ap.add_argument("--baseline", default=None, help="command prefix of another jethr1 (e.g. an older checkout), "
                    "timed in the same run beside this one")
    ap.add_argument("--first-runs", choices=["yes", "no", "only"], default="yes",
                    help="also time each command's first run on a fresh install, after jethr1 warm-up (only: nothing "
                         "else)")
    ap.add_argument("--only", default=None, help="time only the whole commands whose name holds this text (e.g. "
                    "simulate; the trial's plan is still written first, untimed)")
    ap.add_argument("--before", action="store_true", help="with the first runs, also each one without the warm-up "
                    "(a fresh numba cache each: minutes)")
    args = ap.parse_args()
    kinds = {"": shlex.split(args.jethr1) if args.jethr1 else [str(Path(sys.executable).with_name("jethr1"))]}
    if args.first_runs != "no":
        first = Path(tempfile.mkdtemp(prefix="bench_first_runs_"))
        try:
            first_runs(kinds[""], first, args.before)
        finally:
            shutil.rmtree(first, ignore_errors=True)
        if args.first_runs == "only":
            return
    if args.baseline:
        kinds = {"baseline": shlex.split(args.baseline), "this": kinds[""]}
    out = Path(tempfile.mkdtemp(prefix="bench_commands_"))
    best: dict[tuple[str, str], tuple[float, float]] = {}
    bare: list[tuple[float, float]] = []
    try:
        cmds = {kind: commands(prefix, out / (kind or "this")) for kind, prefix in kinds.items()}
        for kind in kinds:  # warm the OS's file cache and numba's
            run_command(cmds[kind]["jethr1 plan configs/jet_hr1_trial.yaml"], ROOT)
        for _ in range(args.repeats):
            bare.append(bare_evaluations_seconds())
            for kind in kinds:
                for name, argv in cmds[kind].items():
                    if kind == "baseline" and name.startswith(("imports", "floor")):
                        continue
                    if args.only and args.only not in name:
                        continue
                    wall, cpu, _ = run_command(argv, ROOT)
                    if (kind, name) not in best or wall < best[kind, name][0]:
                        best[kind, name] = (wall, cpu)
        unit_wall, unit_cpu = min(bare)
    finally:
        shutil.rmtree(out, ignore_errors=True)
    print(f"whole commands, a fresh process each, best of {args.repeats} (its wall time, and the CPU time of that "
          f"run), against {EVALUATIONS:,} bare PlaCo evaluations ({IK_ITERATIONS} IK iterations + CoM each) in this "
          "process in the same run (1 unit; CPU against CPU, the steadier figure on a shared machine):")
    print(f"  {'command':58s} {'wall [s]':>9s} {'CPU [s]':>8s} {'units (wall)':>13s} {'units (CPU)':>12s}")
    print(f"  {'bare loop, 60k evaluations':58s} {unit_wall:9.2f} {unit_cpu:8.2f} {1.0:13.2f} {1.0:12.2f}")
    for (kind, name), (wall, cpu) in sorted(best.items(), key=lambda kv: (list(cmds[kv[0][0]]).index(kv[0][1]),
                                                                         kv[0][0])):
        label = f"{name} ({kind})" if kind else name
        target = "  target <= 1" if name.startswith("jethr1 plan") else ""
        print(f"  {label:58s} {wall:9.2f} {cpu:8.2f} {wall / unit_wall:13.2f} {cpu / unit_cpu:12.2f}{target}")
    print(f"  one bare evaluation: {unit_wall / EVALUATIONS * 1e6:.1f} us wall, "
          f"{unit_cpu / EVALUATIONS * 1e6:.1f} us CPU")

if __name__ == "__main__":
    main()
