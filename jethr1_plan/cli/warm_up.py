"""``jethr1 warm-up``: compile the planner's kernels ahead (numba's on-disk cache), in parallel processes, and compute
the balance-space maps of the terrains given, so that no command a user runs first waits for either.

``make install`` runs it after installing. Each process runs some of the commands on small inputs (a balance-space
sweep on a coarse grid for both supports; plans of Paper A's forward step over 300 mm, robust with the default SQP,
over 400 mm, robust with GAS (its share pass), and over 450 mm, minimal, with a trunk fan sharing the thrust; the
verification of a plan; a walk of Jet-HR1 and one of the DYROS-like humanoid swinging its arms),
which compiles every kernel those commands load, for the argument types they pass; what two processes both compile
is written twice, atomically (numba's cache). Then the kernels a plan calls from Python are compiled ahead of time into
one extension module (``physics.compiled.aot``), and each terrain's maps are computed (or found) where ``jethr1 route``
looks for them.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import click

from jethr1_plan.cli.common import cap_jobs, err_console

__all__ = ["warm_up_cmd"]

WALK = """name: warm_up_walk
robot: jethr1
footsteps: {kind: repetitive, step_length_m: 0.1, count: 2, first: left, step_width_m: 0.14}
timing: {start_s: 0.5, single_support_s: 0.8, double_support_s: 0.4, end_s: 0.5, control_hz: 100, swing_height_m: 0.03}
"""
#: a walk of the DYROS-like humanoid with its arms swinging (the arm-swing kernels: Jet-HR1 has no arms)
ARMS_WALK = """name: warm_up_arms
robot: dyros_jet_like
footsteps: {kind: repetitive, step_length_m: 0.2, count: 2, first: left}
timing: {start_s: 0.5, single_support_s: 0.8, double_support_s: 0.4, end_s: 0.5, control_hz: 100, swing_height_m: 0.05}
arm_swing: {enabled: true}
"""


def exercises(tmp: Path) -> list[list[list[str]]]:
    """The commands each warm-up process runs, in turn (argument lists of ``jethr1``), their inputs written into
    ``tmp``: the balance-space sweeps in one process, the plans, their verification and a walk in the other."""
    from jethr1_plan.robot.load import load_robot
    from jethr1_plan.studies.design_report import scenario_text

    judge = {"seed": 1, "optimiser": "sqp", "tolerance": {"thrust_error": 0.1, "mass_error": 0.05, "com_error_m": 0.01}}
    sole = load_robot("jethr1").sole_length_m
    (tmp / "robust.yaml").write_text(scenario_text("robust", "jethr1", 0.3, judge, 23.0, sole))
    # over 400 mm Jet-HR1 cannot hold the whole tolerance at every sample (its widest robust ditch is 350 mm): GAS
    # runs its share pass there, whose kernels a plan within the tolerance never calls
    (tmp / "edge.yaml").write_text(scenario_text("edge", "jethr1", 0.4, judge, 23.0, sole))
    minimal = {**judge, "tolerance": {"thrust_error": 0.0, "mass_error": 0.0, "com_error_m": 0.0}}
    (tmp / "trunk_fan.yaml").write_text(scenario_text("trunk_fan", "jethr1_trunk_fan", 0.45, minimal, 20.0, sole)
                                        .replace("policy: robust", "policy: minimal"))
    (tmp / "walk.yaml").write_text(WALK)
    (tmp / "arms.yaml").write_text(ARMS_WALK)
    out = str(tmp / "out")
    sweeps = [["balance-space", "--resolution", "0.1", "-j", "1", "--support", side,
               "-o", f"{out}/bs_{side}", "--no-progress"] for side in ("right", "left")]
    sweeps.append(["walk", str(tmp / "arms.yaml"), "-o", out, "--no-rehearse"])
    plans = [["plan", str(tmp / "robust.yaml"), "-o", out, "--no-progress"],
             ["plan", str(tmp / "edge.yaml"), "-o", f"{out}/gas", "--optimiser", "gas", "--no-progress"],
             ["plan", str(tmp / "trunk_fan.yaml"), "-o", out, "--no-progress"],
             ["verify", f"{out}/robust"],
             ["walk", str(tmp / "walk.yaml"), "-o", out, "--no-rehearse"]]
    return [sweeps, plans]


DRIVER = """import json, sys
from jethr1_plan.cli import run
for argv in json.loads(sys.argv[1]):
    code = run(argv)
    if code not in (0, 5):
        sys.exit(f"jethr1 {' '.join(argv)} exited {code}")
"""


def _build_ahead(say: Callable[..., None]) -> None:
    """Compile the kernels a plan calls from Python ahead of time (``physics.compiled.aot``: no numba import in
    ``plan`` and ``simulate``), in a child process (this one keeps numba unimported); where that fails (no C
    compiler, no setuptools), say why: every command still runs, on numba's cache."""
    from jethr1_plan.physics.compiled.aot import module_path
    from jethr1_plan.physics.compiled.jit import cache_dir

    path = module_path(cache_dir())
    if path.is_file():  # (built for these kernel sources, numba, Python and NumPy: nothing to do)
        say(f"jethr1 warm-up: the plan's kernels compiled ahead of time are in {path}", markup=False,
            highlight=False)
        return
    t0 = time.perf_counter()
    say("jethr1 warm-up: compiling the plan's kernels ahead of time (a C extension, about 20 s)", markup=False,
        highlight=False)
    code = "from jethr1_plan.physics.compiled.aot_build import build; print(build())"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    if done.returncode == 0:
        say(f"jethr1 warm-up: wrote {done.stdout.strip()} in {time.perf_counter() - t0:.0f} s", markup=False,
            highlight=False)
    else:
        last = (done.stderr.strip().splitlines() or [f"exit {done.returncode}"])[-1]
        say(f"jethr1 warm-up: no ahead-of-time module ({last}); plan and simulate load their kernels from numba's "
            f"cache instead (about 0.45 s more each)", markup=False, highlight=False)


@click.command("warm-up")
@click.argument("terrains", nargs=-1, type=click.Path(dir_okay=False, path_type=Path))
@click.option("-j", "--jobs", default=2, show_default=True, type=click.IntRange(min=1),
              help="Processes that compile (and compute the maps).")
@click.option("--cache", "cache", default=None, type=click.Path(file_okay=False, path_type=Path),
              help="Where the maps are kept (as jethr1 route's --cache).")
def warm_up_cmd(terrains: tuple[Path, ...], jobs: int, cache: Path | None) -> None:
    """Compile the planner's kernels ahead, in parallel processes, then the kernels a plan calls into one C extension
    (plan and simulate then run without importing numba; skipped, with a line saying why, where no C compiler is
    found), and compute the balance-space maps of the TERRAINS given (as jethr1 route would), so that the first
    command a user runs does not wait for them."""
    from jethr1_plan.route.terrain import load_terrain

    loaded = [load_terrain(t) for t in terrains]  # bad input before any work
    jobs = cap_jobs(jobs)
    t0 = time.perf_counter()
    say = err_console.print
    with tempfile.TemporaryDirectory(prefix="jethr1-warm-up-") as tmp:
        groups = exercises(Path(tmp))
        say(f"jethr1 warm-up: compiling the planner's kernels in {min(jobs, len(groups))} processes (about a minute)",
            markup=False, highlight=False)
        pending = [list(g) for g in groups]
        if jobs < len(groups):  # fewer processes: the groups run one after another in them
            pending = [[argv for g in groups[k::jobs] for argv in g] for k in range(jobs)]
        procs = [subprocess.Popen([sys.executable, "-c", DRIVER, json.dumps(argvs)], stdout=subprocess.DEVNULL,
                                  stderr=subprocess.PIPE, text=True) for argvs in pending]
        failed = []
        for p in procs:
            _, err = p.communicate()
            if p.returncode != 0:
                failed.append(err.strip().splitlines()[-1] if err.strip() else f"exit {p.returncode}")
        if failed:  # a command that works on its own small inputs failed: a bug
            raise RuntimeError(f"jethr1 warm-up: {failed[0]}")
    say(f"jethr1 warm-up: kernels compiled and cached in {time.perf_counter() - t0:.0f} s", markup=False,
        highlight=False)
    _build_ahead(say)
    if loaded:
        from jethr1_plan.route.planner import route_maps

        for terrain in loaded:
            route_maps(terrain, cache, jobs=jobs, say=lambda line: say(line, markup=False, highlight=False))
    say(f"jethr1 warm-up: done in {time.perf_counter() - t0:.0f} s", markup=False, highlight=False)
