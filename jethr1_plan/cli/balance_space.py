"""``jethr1 balance-space``: where the swing sole can be held, with and without thrust."""

from __future__ import annotations

import contextlib
from pathlib import Path

import click
import numpy as np

from jethr1_plan.cli.common import (
    FiniteFloat,
    Progress,
    cap_jobs,
    check_memory,
    check_time,
    cores,
    err_console,
    pair_option,
    print_json,
    require_dask,
)
from jethr1_plan.errors import InputError
from jethr1_plan.io.json_text import json_text

MIN_RESOLUTION_M = 0.005  # a finer grid resolves nothing a plan holds to (its sole margin, its 10 mm of CoM error)
CELL_CPU_S = 57e-6  # CPU time a cell takes (at 1 cm: 51.5 s for 906,471 cells; wider grids take longer a cell) [s]
EXHAUSTIVE_CELL_S = 0.1  # the least CPU time the exhaustive search takes a cell at a 1 cm P_body grid (~0.3 s) [s]
CELL_BYTES = 400  # memory a grid cell takes at the peak of a sweep and its files (measured: ~500 MB at 0.9 M cells)
CELL_FILE_BYTES = 60  # bytes a cell takes in balance_space.csv and .mcap, at least
BALANCE_SPACE_FILES = ("balance_space.csv", "balance_space.mcap", "balance_space.png", "summary.json")

__all__ = ["balance_space"]


def _sweep_spec(robot, support, support_position, ranges, resolution, thrust_max, sole_margin, tolerance, method,
                pbody_resolution):
    """The sweep the options ask for: the grid about the support sole (by default where the robot stands), every
    fan's limit and the sole margin checked against the robot."""
    from jethr1_plan.balance_space.sweep import SweepSpec

    x_range, y_range, z_range = ranges
    if support_position is None:
        support_position = tuple(float(v) for v in robot.start_feet()[support])
    fan_max = max((f.thrust_max_n for f in robot.fans), default=0.0)
    if thrust_max is not None and thrust_max > fan_max:
        raise InputError("--thrust-max", f"{thrust_max:g}", f"more than the robot's fans give ({fan_max:g} N)")
    sx, sy, sz = support_position
    sgn = 1.0 if support == "right" else -1.0  # the swing foot is on the +y side of a right support
    spec = SweepSpec(robot=robot, support_side=support, support_xyz=tuple(support_position),
                     x_range=x_range or (sx - 0.8, sx + 0.9),
                     y_range=y_range or ((sy - 0.7875, sy + 0.9125) if sgn > 0 else (sy - 0.9125, sy + 0.7875)),
                     z_range=z_range or (sz, sz + 0.3), resolution_m=resolution, thrust_max_n=thrust_max,
                     sole_margin_m=sole_margin, tolerance=tolerance, method=method,
                     pbody_resolution_m=pbody_resolution)
    if sole_margin >= min(robot.sole_length_m, robot.sole_width_m) / 2:
        raise InputError("--sole-margin", f"{sole_margin:g}", "leaves no support polygon (sole "
                         f"{robot.sole_length_m} x {robot.sole_width_m} m)")
    return spec


@click.command("balance-space")
@click.option("--robot", "robot_name", default="jethr1", show_default=True, help="Robot name or path.")
@click.option("--support", type=click.Choice(["left", "right"]), default="right", show_default=True,
              help="Which sole supports; the other one sweeps.")
@click.option("--support-position", nargs=3, type=FiniteFloat(-100, 100), default=None, metavar="X Y Z",
              help="Support sole centre [m] (default: where the robot stands, its stance width apart).")
@click.option("--x-range", nargs=2, type=FiniteFloat(-100, 100), callback=pair_option, metavar="LOW HIGH",
              help="Swing sole x bounds [m].")
@click.option("--y-range", nargs=2, type=FiniteFloat(-100, 100), callback=pair_option, metavar="LOW HIGH",
              help="Swing sole y bounds [m].")
@click.option("--z-range", nargs=2, type=FiniteFloat(-100, 100), callback=pair_option, metavar="LOW HIGH",
              help="Swing sole z bounds [m].")
@click.option("--resolution", default=0.01, show_default=True, type=FiniteFloat(MIN_RESOLUTION_M, 1.0),
              help="Grid step [m] (at least 5 mm: the sole margin, and the CoM error the plans hold, are 5-10 mm).")
@click.option("--thrust-max", default=None, type=FiniteFloat(0.0, 1e4),
              help="F_max of every fan [N] (default: each fan's own maximum).")
@click.option("--policy", type=click.Choice(["minimal", "robust"]), default="minimal", show_default=True,
              help="The balance policy of the cells: minimal (Paper A's least thrust, Fig. 5) or robust (the least "
                   "thrust that survives the tolerance below), as a scenario's balance.policy.")
@click.option("--thrust-error", type=FiniteFloat(0.0, 0.9), default=None,
              help="Robust policy: relative thrust error (default: a scenario's, 0.10).")
@click.option("--mass-error", type=FiniteFloat(0.0, 0.9), default=None,
              help="Robust policy: relative mass error (default: a scenario's, 0.05).")
@click.option("--com-error", type=FiniteFloat(0.0, 0.1), default=None,
              help="Robust policy: CoM error [m] (default: a scenario's, 0.01).")
@click.option("--sole-margin", type=FiniteFloat(0.0, 0.1), default=0.0, show_default=True,
              help="The ZMP stays this far inside the support sole [m] (a scenario's balance.sole_margin_m).")
@click.option("--method", type=click.Choice(["continuation", "exhaustive"]), default="continuation", show_default=True,
              help="Inner search over P_body.")
@click.option("--pbody-resolution", default=0.01, show_default=True, type=FiniteFloat(0.001, 0.1),
              help="P_body grid step of the exhaustive method [m].")
@click.option("-j", "--jobs", default=2, show_default=True, type=click.IntRange(min=1), help="Worker processes.")
@click.option("--executor", type=click.Choice(["fork", "loky", "dask"]), default=None,
              help="fork (the default on Linux: workers forked from the command once it has loaded the compiled "
                   "kernels, sharing them: the least memory), loky (fresh worker processes; the default elsewhere) "
                   "or dask (a cluster). The output is the same with each.")
@click.option("--scheduler", default=None, help="Dask scheduler address (with --executor dask); default: local.")
@click.option("-o", "--output", "outdir", default="out/balance_space", show_default=True,
              type=click.Path(file_okay=False, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print summary.json on stdout.")
@click.option("--no-progress", is_flag=True)
def balance_space(robot_name, support, support_position, x_range, y_range, z_range, resolution, thrust_max, policy,
                  thrust_error, mass_error, com_error, sole_margin, method, pbody_resolution, jobs, executor, scheduler,
                  outdir, as_json, no_progress) -> None:
    """Sweep the swing sole over a grid: the balance space with and without thrust (Paper A, Fig. 5)."""
    from jethr1_plan.balance_space.spec import SearchSettings
    from jethr1_plan.balance_space.sweep import summary, sweep
    from jethr1_plan.balance_space.workers import ForkedSweep
    from jethr1_plan.files.balance_space import balance_space_mcap, balance_space_png, write_balance_space_csv
    from jethr1_plan.io.atomic import staged_directory
    from jethr1_plan.io.forked import ForkedFile, fork_available
    from jethr1_plan.io.pool import pool_config
    from jethr1_plan.io.record import check_writable
    from jethr1_plan.robot.load import load_robot

    if executor is None:
        executor = "fork" if fork_available() else "loky"
    if executor == "fork" and not fork_available():
        raise InputError("--executor", executor, "needs Linux (fork); use loky")
    require_dask(executor, scheduler)
    tolerance = _tolerance(policy, thrust_error, mass_error, com_error)
    robot = load_robot(robot_name)
    if not robot.fans:
        raise InputError("--robot", robot_name, f"{robot.name} has no fans: the balance space is swept with thrust")
    spec = _sweep_spec(robot, support, support_position, (x_range, y_range, z_range), resolution, thrust_max,
                       sole_margin, tolerance, method, pbody_resolution)
    cells = _check_grid(spec, (x_range, y_range, z_range))
    cell_s = CELL_CPU_S if method == "continuation" else EXHAUSTIVE_CELL_S * (0.01 / pbody_resolution) ** 3
    check_time(_grid_option(spec, (x_range, y_range, z_range)) if method == "continuation" or pbody_resolution >= 0.01
               else ("--pbody-resolution", f"{pbody_resolution:g}"), cells * cell_s / min(jobs, cores()),
               f"{cells:,} cells ({method})")
    check_writable(outdir, need_bytes=cells * CELL_FILE_BYTES, writes=BALANCE_SPACE_FILES)
    jobs = cap_jobs(jobs)
    settings = SearchSettings()
    # the forked sweep's workers are forked before the progress bar's thread starts (balance_space.workers)
    with ForkedSweep(spec, settings, jobs) if executor == "fork" else contextlib.nullcontext() as forked, \
            pool_config() if executor == "loky" else contextlib.nullcontext(), \
            Progress(not no_progress, f"balance space ({cells:,} cells)") as progress:
        result = sweep(spec, jobs=jobs, executor=executor, scheduler=scheduler, progress=progress, settings=settings,
                       forked=forked)
    doc = summary(result)
    doc["verified_members"] = result.extra["verified_members"]  # re-checked by PlaCo in the sweep's tasks
    with staged_directory(outdir, frozenset(BALANCE_SPACE_FILES)) as staging:
        tmp = staging.path
        # the PNG drawn by a forked child (with matplotlib, which this process never imports) beside the rest
        with ForkedFile(tmp / "balance_space.png",
                        lambda: balance_space_png(result, robot.sole_length_m, robot.sole_width_m)) as png:
            with open(tmp / "balance_space.csv", "w", encoding="utf-8", newline="") as f:  # (written as built)
                write_balance_space_csv(result, f)
            (tmp / "balance_space.mcap").write_bytes(balance_space_mcap(result, robot.sole_length_m,
                                                                        robot.sole_width_m))
            (tmp / "summary.json").write_text(json_text(doc))
            png.wait()
    if as_json:
        print_json(doc)
    w, wo = doc["with_thrust"], doc["without_thrust"]

    def metres(v: float | None) -> str:
        return "-" if v is None else f"{v:.3f} m"

    err_console.print(f"balance space: {w['cells']} cells with thrust (reach forward {metres(w['max_forward_m'])}, "
                      f"sideways {metres(w['max_sideways_m'])}), {wo['cells']} without (forward "
                      f"{metres(wo['max_forward_m'])}, sideways {metres(wo['max_sideways_m'])}) "
                      f"in {doc['wall_s']:.1f} s; wrote {outdir}/")
    from jethr1_plan.cli.plan import BALANCE_SPACE_LAYOUT

    err_console.print(f"Foxglove/Lichtblick: open balance_space.mcap and import the layout {BALANCE_SPACE_LAYOUT}; "
                      f"Rerun: jethr1 view {outdir}", markup=False)



def _tolerance(policy: str, thrust_error: float | None, mass_error: float | None, com_error: float | None):
    """The model errors of ``policy`` (a scenario's defaults where not given); the errors only with robust."""
    from jethr1_plan.physics.balance import NOMINAL, Tolerance
    from jethr1_plan.scenario import ROBUST_DEFAULT

    given = {"--thrust-error": thrust_error, "--mass-error": mass_error, "--com-error": com_error}
    if policy == "minimal":
        for option, value in given.items():
            if value is not None:
                raise InputError(option, f"{value:g}", "a tolerance needs --policy robust")
        return NOMINAL
    d = ROBUST_DEFAULT
    return Tolerance(d.thrust if thrust_error is None else thrust_error, d.mass if mass_error is None else mass_error,
                     d.com_m if com_error is None else com_error)


def _grid_option(spec, given) -> tuple[str, str]:
    """The option that makes the grid large: the range of its longest axis where given, else --resolution."""
    axes = spec.axes()
    names = ("--x-range", "--y-range", "--z-range")
    longest = int(np.argmax([len(a) for a in axes]))
    if given[longest] is not None:
        lo, hi = given[longest]
        return names[longest], f"{lo:g} {hi:g}"
    return "--resolution", f"{spec.resolution_m:g}"


def _check_grid(spec, given) -> int:
    """The grid's cell count, after checking the memory it needs (exit 2 naming the range that makes
    it large, or --resolution where none was given)."""
    axes = spec.axes()
    cells = int(np.prod([len(a) for a in axes]))
    need = cells * CELL_BYTES
    option, value = _grid_option(spec, given)
    check_memory(option, value, need, f"{len(axes[0])} x {len(axes[1])} x {len(axes[2])} = {cells:,} cells at "
                 f"{spec.resolution_m:g} m")
    return cells
