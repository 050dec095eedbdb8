"""``jethr1 ditch-curve``: the largest share of the robust tolerance that crosses each ditch, and its thrust."""

from __future__ import annotations

import math
from pathlib import Path

import click
import numpy as np
from rich.table import Table

from jethr1_plan.cli.common import Progress, cap_jobs, cores, err_console, print_json, range_spec
from jethr1_plan.errors import InputError
from jethr1_plan.io.json_text import json_text
from jethr1_plan.optimisers import METHODS

__all__ = ["ditch_curve_cmd"]

MAX_SCALES = 21  # fixed tolerances in one curve (0 to 5 in steps of 0.25)
ROBUST_PLANS_PER_GAP = 2  # the robust crossing of a gap: about two plans


@click.command("ditch-curve")
@click.option("--gaps", default="0.30:0.50:0.01", show_default=True, help="Ditch widths LO:HI:STEP [m].")
@click.option("--scales", default="0", show_default=True,
              help="Also plan every gap at these fixed tolerances, multiples of the scenario's robust tolerance "
                   "(0: Paper A's minimal thrust; '': none).")
@click.option("--scenario", "base_path", type=click.Path(dir_okay=False, path_type=Path),
              help="Take the robot, optimiser, timing and robust tolerance from this scenario (default: defaults).")
@click.option("--optimiser", type=click.Choice(list(METHODS)), help="Override the optimiser.")
@click.option("-j", "--jobs", default=2, show_default=True, type=click.IntRange(min=1), help="Worker processes.")
@click.option("-o", "--output", "outdir", default="out/ditch_curve", show_default=True,
              type=click.Path(file_okay=False, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print ditch_curve.json on stdout.")
@click.option("--no-progress", is_flag=True)
def ditch_curve_cmd(gaps, scales, base_path, optimiser, jobs, outdir, as_json, no_progress) -> None:
    """The largest share of the robust tolerance that crosses each ditch, and the thrust it needs.

    Paper A's forward step planned as the most robust plan that exists at every gap; and, at fixed
    tolerances (--scales), the widest ditch each crosses.
    """
    from dataclasses import replace

    from jethr1_plan.io.atomic import staged_directory
    from jethr1_plan.scenario import load_scenario
    from jethr1_plan.studies.ditch_curve import curve, curve_png, default_base, ditch_scenario, landing_x

    gap_values = np.array(range_spec(gaps, "--gaps"))
    try:
        scale_values = tuple(float(v) for v in scales.split(",")) if scales.strip() else ()
    except ValueError:
        raise InputError("--scales", scales, "expected comma-separated numbers") from None
    if any(not math.isfinite(v) or v < 0 or v > 5 for v in scale_values):
        raise InputError("--scales", scales[:60], "expected numbers in [0, 5]")
    if len(scale_values) > MAX_SCALES or len(set(scale_values)) != len(scale_values):
        raise InputError("--scales", scales[:60], f"{len(scale_values)} values: at most {MAX_SCALES}, each once (the "
                         "tolerance itself is known to ±25 %: finer steps of it mean nothing)")
    from jethr1_plan.io.record import check_writable
    from jethr1_plan.scenario import check_plan_time

    base = load_scenario(base_path) if base_path else default_base()
    span = 2 * (base.robot.leg_length_m + base.robot.hip_offset_m)  # both legs straight, hips side by side
    far = [float(g) for g in gap_values if landing_x(float(g), base.robot.sole_length_m) > span]
    if far:
        raise InputError("--gaps", gaps, f"{far[0]:g} m: out of reach: the landing sole would be "
                         f"{landing_x(far[0], base.robot.sole_length_m):.3f} m ahead of the support sole; "
                         f"{base.robot.name}'s legs span at most {span:.3f} m")
    method = optimiser or base.optimiser.method
    check_plan_time(ditch_scenario(base, float(gap_values[0]), base.balance.robust, base.robot.sole_length_m),
                    (method,), plans=len(gap_values) * (ROBUST_PLANS_PER_GAP + len(scale_values)),
                    workers=min(jobs, cores()), key="--gaps",
                    what=f"the curve ({len(gap_values)} gaps x {len(scale_values)} fixed tolerances)")
    check_writable(outdir, writes=("ditch_curve.json", "ditch_curve.png"))
    jobs = cap_jobs(jobs)
    if optimiser:
        base = replace(base, optimiser=replace(base.optimiser, method=optimiser))
    robot = base.robot
    with Progress(not no_progress, "ditch curve") as progress:
        doc = curve(base, gap_values, scale_values, robot.sole_length_m, jobs=jobs, progress=progress)
    with staged_directory(outdir, frozenset({"ditch_curve.json", "ditch_curve.png"})) as staging:
        tmp = staging.path
        (tmp / "ditch_curve.json").write_text(json_text(doc))
        (tmp / "ditch_curve.png").write_bytes(curve_png(doc))
    if as_json:
        print_json(doc)
    err_console.print(robustness_table(doc))
    if doc["tolerances"]:
        t = Table(title=f"widest ditch per fixed tolerance ({doc['optimiser']}, F_max {doc['thrust_max_n']:g} N)")
        for col in ("thrust error", "mass error", "CoM error [m]", "widest gap [m]", "max thrust there [N]"):
            t.add_column(col, justify="right")
        for row in doc["tolerances"]:
            t.add_row(f"±{100 * row['thrust_error']:.1f} %", f"±{100 * row['mass_error']:.1f} %",
                      f"{row['com_error_m']:.4f}", "-" if row["widest_gap_m"] is None else f"{row['widest_gap_m']:.3f}",
                      "-" if row["thrust_at_widest_n"] is None else f"{row['thrust_at_widest_n']:.2f}")
        err_console.print(t)
    err_console.print(f"wrote {outdir}/ditch_curve.json, ditch_curve.png")



def robustness_table(doc: dict) -> Table:
    """Per gap: the largest share of the robust tolerance that crosses it, what it means, where, and thrust."""
    tol = doc["robust_tolerance"]
    t = Table(title=f"the most robust crossing per gap ({doc['optimiser']}, F_max {doc['thrust_max_n']:g} N; "
                    f"tolerance ±{100 * tol['thrust_error']:g} % thrust, ±{100 * tol['mass_error']:g} % mass, "
                    f"{1000 * tol['com_error_m']:g} mm CoM)")
    for col in ("gap [m]", "share", "thrust", "mass", "CoM [mm]", "least at", "peak thrust [N]", "mean [N]"):
        t.add_column(col, justify="right")
    for r in doc["robustness"]:
        if r["share"] is None:
            t.add_row(f"{r['gap_m']:.3f}", "-", "", "", "", "not crossable", "", "")
            continue
        held, at = r["tolerance"], r["share_at"]
        t.add_row(f"{r['gap_m']:.3f}", f"{r['share']:.3f}", f"±{100 * held['thrust_error']:.1f} %",
                  f"±{100 * held['mass_error']:.1f} %", f"{1000 * held['com_error_m']:.1f}",
                  f"{at['phase']} row {at['row']}", f"{r['peak_thrust_n']:.2f}", f"{r['mean_thrust_n']:.2f}")
    return t
