"""``jethr1 plan``: a scenario planned, re-checked and written."""

from __future__ import annotations

from pathlib import Path

import click

from jethr1_plan.cli.common import SEED, Progress, cap_jobs, err_console, print_json, report_kept, warn_minimal_policy
from jethr1_plan.errors import InfeasiblePlan
from jethr1_plan.optimisers import METHODS

__all__ = ["BALANCE_SPACE_LAYOUT", "LAYOUT", "ROUTE_LAYOUT", "WALK_LAYOUT", "plan"]


LAYOUT = Path(__file__).resolve().parents[1] / "foxglove_layout.json"  # Foxglove: the plan, its rehearsal, thrust
WALK_LAYOUT = LAYOUT.with_name("foxglove_walk_layout.json")  # a walk: robot, footsteps, yaw, momentum, ZMP margin
BALANCE_SPACE_LAYOUT = LAYOUT.with_name("foxglove_balance_space_layout.json")  # cells coloured by least thrust
ROUTE_LAYOUT = LAYOUT.with_name("foxglove_route_layout.json")  # a route: its plan, footholds, footsteps, map slices



@click.command()
@click.argument("scenario_path", metavar="SCENARIO.yaml", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "outdir", default="out", show_default=True, type=click.Path(file_okay=False,
              path_type=Path), help="Output directory; files go to OUTDIR/<scenario stem>/.")
@click.option("--optimiser", type=click.Choice(list(METHODS)), help="Override optimiser.method.")
@click.option("--seed", type=SEED, help="Override the scenario's seed.")
@click.option("--json", "as_json", is_flag=True, help="Print summary.json on stdout.")
@click.option("--no-progress", is_flag=True, help="No progress bar.")
@click.option("--write-infeasible", is_flag=True,
              help="On an infeasible plan, still write the trajectory; infeasible rows say so.")
@click.option("-j", "--jobs", default=1, show_default=True, type=click.IntRange(min=1),
              help="Processes optimising steps in parallel (output does not depend on it).")
@click.option("--kinematics", type=click.Choice(["placo", "analytic"]), default="placo", show_default=True,
              help="Leg IK: PlaCo's solver, or the closed form (same postures to 1e-9 m, faster).")
@click.option("--strict-torque", is_flag=True, help="Rows whose static torque exceeds a servo limit are infeasible.")
@click.option("--policy", type=click.Choice(["robust", "minimal"]),
              help="Override balance.policy: robust (thrust that survives model errors) or minimal (Paper A).")
@click.option("--timing", "timing_mode", type=click.Choice(["fixed", "fastest"]),
              help="Override timing.mode: fixed (timing.swing_s and transfer_s) or fastest (each swing and transfer "
                   "as fast as the rows' own dynamics allow).")
def plan(scenario_path: Path, outdir: Path, optimiser: str | None, seed: int | None, as_json: bool,
         no_progress: bool, write_infeasible: bool, jobs: int, kinematics: str, strict_torque: bool,
         policy: str | None, timing_mode: str | None) -> None:
    """Plan SCENARIO.yaml: optimise P_body along each swing, write CSV, MCAP and summary.json."""
    from dataclasses import replace

    from jethr1_plan.files.plan_folder import PLAN_WRITES, plan_folder
    from jethr1_plan.io.record import check_writable
    from jethr1_plan.pipeline.plan import plan_to_folder
    from jethr1_plan.scenario import check_plan_time, load_scenario

    scenario = load_scenario(scenario_path)
    if optimiser is not None:
        check_plan_time(scenario, (optimiser,), key="--optimiser")
    if policy is not None:
        scenario = replace(scenario, balance=replace(scenario.balance, policy=policy))
    if timing_mode is not None:
        scenario = replace(scenario, timing=replace(scenario.timing, mode=timing_mode))
    if scenario.timing.fastest:
        from jethr1_plan.scenario import check_fastest

        check_fastest(scenario.timing, scenario.yaw_mode, scenario.balance, str(scenario_path))
    check_writable(plan_folder(outdir, scenario), need_bytes=plan_bytes(scenario), writes=PLAN_WRITES)
    jobs = cap_jobs(jobs)
    try:
        with Progress(not no_progress, scenario.name) as progress:
            result, summary, folder, kept = plan_to_folder(
                scenario, outdir, strict_torque=strict_torque, write_infeasible=write_infeasible, method=optimiser,
                seed=seed, progress=progress, jobs=jobs, kinematics=kinematics)
    except InfeasiblePlan as exc:
        if exc.written is not None:
            report_kept(*exc.written)
        raise
    report_kept(folder, kept)
    if as_json:
        print_json(summary)
    bad = result.first_infeasible
    if bad is not None:
        raise InfeasiblePlan(f"infeasible: {bad.reason} (step {bad.step} {bad.phase} sample {bad.sample}); "
                             "trajectory written with infeasible rows marked")
    _report_plan(summary, folder)



def plan_bytes(scenario) -> int:
    """A low estimate of the bytes a plan folder takes (its CSV and MCAP hold ~1 kB a row each)."""
    t = scenario.timing
    rows = (len(scenario.steps) * (t.swing_s + t.transfer_s) + t.transfer_s) * t.rate_hz
    return int(1500 * rows)


def _report_plan(summary: dict, folder: Path) -> None:
    from jethr1_plan.records.plan_columns import TOLERANCE_SHARE

    c = err_console
    c.print(f"[green]feasible[/] {summary['scenario']}: {summary['sample_count']} swing samples, "
            f"max thrust {summary['peak_thrust_n']:.2f} N, mean {summary['mean_thrust_n']:.2f} N, "
            f"{summary['evaluations']} evaluations in {summary['wall_s']:.1f} s")
    b = summary["balance"]
    tol = b["tolerance"]
    policy = ("minimal thrust (Paper A: the ZMP on the sole's edge)" if b["policy"] == "minimal" else
              f"robust to ±{100 * tol['thrust_error']:g} % thrust, ±{100 * tol['mass_error']:g} % mass, "
              f"{1000 * tol['com_error_m']:g} mm of CoM error")
    rob = summary.get("robustness", {})
    c.print(f"balance: {policy}")
    warn_minimal_policy(b["policy"])
    if rob.get("least_zmp_margin_m") is not None:
        at = rob["least_zmp_margin_at"]
        margin_mm = round(1000 * rob["least_zmp_margin_m"], 1) + 0.0  # no "-0.0"
        line = (f"least ZMP margin {margin_mm:.1f} mm (step {at['step']} {at['phase']} row {at['row']}, "
                f"t = {at['time_s']:.2f} s)")
        if "narrowest_window_n" in rob:
            lo, hi = rob["narrowest_window_n"]
            at = rob["narrowest_window_at"]
            line += (f"; narrowest thrust window [{lo:.2f}, {hi:.2f}] N (step {at['step']} {at['phase']} row "
                     f"{at['row']}, t = {at['time_s']:.2f} s)")
        c.print(line)
    share = rob.get(TOLERANCE_SHARE)
    if share is not None:
        at, tol = share["least_at"], share["tolerance"]
        if share["rows_below_full"] == 0:
            c.print("tolerance share 1 on every row: the whole tolerance holds")
        else:
            c.print(f"least tolerance share {share['least']:.3f} (step {at['step']} {at['phase']} row {at['row']}, "
                    f"t = {at['time_s']:.2f} s): there the plan holds ±{100 * tol['thrust_error']:.1f} % thrust, "
                    f"±{100 * tol['mass_error']:.1f} % mass, {1000 * tol['com_error_m']:.1f} mm of CoM error; "
                    f"{share['rows_below_full']} rows below the whole tolerance")
    dyn = summary.get("dynamics")
    if dyn is not None and dyn["least_zmp_margin_m"] is not None:
        at = dyn["least_zmp_margin_at"]
        margin_mm = round(1000 * dyn["least_zmp_margin_m"], 1) + 0.0
        where = f"step {at['step']} {at['phase']} row {at['row']}, t = {at['time_s']:.2f} s"
        if dyn["rows_outside_support"]:
            k = dyn["rows_outside_support"]
            c.print(f"[yellow]warning:[/] the rows' own motion (central differences) moves the ZMP off the support "
                    f"on {k} row{'s' if k > 1 else ''}, by up to {-margin_mm:.1f} mm ({where}): the quasistatic "
                    "balance holds there, the motion's accelerations do not (they shrink as timing.swing_s grows)")
        else:
            c.print(f"dynamic ZMP (the rows' own motion) least margin {margin_mm:.1f} mm ({where})")
        for pace in dyn["paced_swings"]:
            law = (f"a trunk acceleration of at most {pace['trunk_accel_m_s2']:g} m/s²"
                   if pace["trunk_accel_m_s2"] is not None else "the minimum-jerk law kept (no pace did better)")
            held = "" if pace["margin_held"] else ", nearer the edge than balance.sole_margin_m"
            c.print(f"paced: step {pace['step']}'s swing re-timed ({law}, same samples and duration): its dynamic "
                    f"ZMP {1000 * pace['least_zmp_margin_m']:.1f} mm inside{held}")
    c.print(f"wrote {folder}/trajectory.csv, trajectory.mcap, summary.json, optimised_steps.json")
    c.print(f"Foxglove/Lichtblick: open trajectory.mcap and import the layout {LAYOUT} (the robot comes from the "
            "file's /robot_description; its rehearsal, simulation.mcap, plays beside it); Rerun: jethr1 view "
            f"{folder}", markup=False)

